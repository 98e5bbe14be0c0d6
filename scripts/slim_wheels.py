"""Wheels without the files the add-on never loads, so that each platform's zip stays small.

`scripts.build_extension` bundles scipy, PocketSphinx and espeak-ng's loader as PyPI ships them, and those wheels
carry much the add-on never touches: scipy's test suites, the subpackages it does not import (statistics, signal
processing, file formats ...: 12 of its 20) and its files for building against it (C headers, Cython sources, type
stubs), and PocketSphinx's 27 MB word language model (the add-on aligns with the dictionary and recognises with the
phone language model; it decodes words without a transcript only where the word model is installed and does without
it: addon/speech/phone_alignment.py). `slim(wheel)` writes a copy without those files, its RECORD listing exactly
what is left (their hashes are unchanged: the kept files are copied byte for byte), under the same name with the
build tag BUILD_TAG (`scipy-1.15.3-1slim-cp311-...whl`: a wheel name's optional build tag, which pip and Blender
read as a tie-breaker only), so the trimmed wheel is never taken for PyPI's. Every other file, the licences and the
METADATA included, is kept. Wheels of projects TRIMS does not name are used as they are.

What is dropped is checked by tests/scripts/test_slim_wheels.py: every scipy module the add-on's source imports,
and what those load, is outside DROPPED_SCIPY, and only the recogniser names the dropped language model.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
import re
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from scripts import build_kernel

BUILD_TAG = "1slim"

# scipy's subpackages the add-on neither imports nor loads through what it imports (the add-on imports
# scipy.spatial, scipy.sparse (.linalg, .csgraph) and scipy.optimize; those load _lib, constants, fft, linalg and
# special, which stay)
DROPPED_SCIPY = (
    "cluster",
    "datasets",
    "differentiate",
    "fftpack",
    "integrate",
    "interpolate",
    "io",
    "misc",
    "ndimage",
    "odr",
    "signal",
    "stats",
)
UNUSED_LANGUAGE_MODEL = "pocketsphinx/model/en-us/en-us.lm.bin"


# files for building against scipy, which nothing reads at run time: C headers, Cython sources and declarations, type
# stubs (360 KB of the macOS x86-64 wheel, the largest zip's margin under 45 MB)
BUILD_ONLY_SUFFIXES = (".h", ".pyx", ".pxd", ".pyi")


def _scipy_unused(name: str) -> bool:
    parts = PurePosixPath(name).parts
    if parts[0] != "scipy":
        return False
    return name.endswith(BUILD_ONLY_SUFFIXES) or (
        len(parts) > 2 and (parts[1] in DROPPED_SCIPY or "tests" in parts[1:-1])
    )


@dataclass(frozen=True)
class Trim:
    unused: Callable[[str], bool]  # a wheel member's name -> never loaded by the add-on
    why: str


TRIMS = {
    "scipy": Trim(_scipy_unused, "its test suites and the 12 subpackages the add-on does not load"),
    "pocketsphinx": Trim(lambda name: name == UNUSED_LANGUAGE_MODEL, "the word language model (optional)"),
}


class WheelError(ValueError):
    pass


def project_of(wheel: Path) -> str:
    return wheel.name.split("-")[0].lower().replace("_", "-")


def slim_name(wheel: Path) -> str:
    """`name-version-tags.whl` with the build tag: `name-version-1slim-tags.whl`."""
    parts = wheel.name.split("-")
    if len(parts) != 5:
        raise WheelError(f"{wheel.name}: not a wheel name without a build tag (name-version-python-abi-platform.whl)")
    return "-".join([*parts[:2], BUILD_TAG, *parts[2:]])


def _dist_info(names: list[str]) -> str:
    found = {name.split("/")[0] for name in names if re.fullmatch(r"[^/]+\.dist-info/RECORD", name)}
    if len(found) != 1:
        raise WheelError(f"expected one .dist-info/RECORD, found {len(found)}")
    return found.pop()


def slim(wheel: Path, out_dir: Path | None = None) -> Path:
    """The wheel without what TRIMS says the add-on never loads, written beside it (or into `out_dir`) unless a copy
    made from the same wheel is there; the wheel itself when TRIMS has nothing for its project."""
    trim = TRIMS.get(project_of(wheel))
    if trim is None:
        return wheel
    target = (out_dir or wheel.parent) / slim_name(wheel)
    # the copy is made again when the wheel or what is dropped changes (a rule added left stale copies before)
    rules = repr((DROPPED_SCIPY, BUILD_ONLY_SUFFIXES, UNUSED_LANGUAGE_MODEL)).encode()
    source_digest = hashlib.sha256(wheel.read_bytes() + rules).hexdigest()
    stamp = target.with_name(target.name + ".source")
    if target.is_file() and stamp.is_file() and stamp.read_text() == source_digest:
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f"{target.name}.{os.getpid()}.part")
    try:
        _write_slim(wheel, partial, trim)
    except BaseException:
        partial.unlink(missing_ok=True)  # no half-written wheel left behind
        raise
    partial.replace(target)
    stamp.write_text(source_digest)
    return target


def _write_slim(wheel: Path, partial: Path, trim: Trim) -> None:
    with zipfile.ZipFile(wheel) as src:
        members = src.infolist()
        info = _dist_info([m.filename for m in members])
        record, wheel_meta = f"{info}/RECORD", f"{info}/WHEEL"
        kept = [m for m in members if not trim.unused(m.filename)]
        listed = {row[0]: row for row in csv.reader(io.StringIO(src.read(record).decode("utf-8"))) if row}
        rows, out = [], io.StringIO()
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as dst:
            for member in kept:
                if member.filename == record:
                    continue
                data = src.read(member)
                if member.filename == wheel_meta:  # the build tag, stated where the wheel spec puts it
                    text = re.sub(r"(?m)^Build:.*\n", "", data.decode("utf-8"))
                    data = (text.rstrip("\n") + f"\nBuild: {BUILD_TAG}\n").encode("utf-8")
                    rows.append([member.filename, build_kernel.record_hash(data), str(len(data))])
                elif member.filename in listed:
                    rows.append(listed[member.filename])
                elif not member.is_dir():
                    rows.append([member.filename, build_kernel.record_hash(data), str(len(data))])
                dst.writestr(member, data, compress_type=zipfile.ZIP_DEFLATED)
            rows.append([record, "", ""])
            csv.writer(out, lineterminator="\n").writerows(rows)
            dst.writestr(next(m for m in members if m.filename == record), out.getvalue().encode("utf-8"))
