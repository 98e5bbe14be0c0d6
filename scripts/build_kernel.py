"""Build the compiled Planar Bones kernel into a wheel of our own, and optionally install it.

    .venv/bin/python -m scripts.build_kernel [--install] [--out wheels]

Compiles `native/planar_bones_kernel.c` with this machine's C compiler ($CC, else gcc, else cc) into a
shared library. It is plain C with no Python C-API, so the wheel is ``py3-none-<platform>`` and serves
every Python version. The wheel holds the package ``mpeg4_face_kernel`` (the library, its path and ABI
version) and is written to ``wheels/mpeg4_face_kernel-<abi>.0.0-py3-none-<platform>.whl``; on Linux
x86-64 that is the file `blender_manifest.toml` lists, which `scripts.build_extension` bundles and
Blender installs. ``--install`` also installs the wheel into the Python running this script (set-up
does this for ``.venv``), offline and only when the installed kernel differs. Nothing is rebuilt when the
wheel was built from the same source, flags and compiler. Without a compiler it exits with status 2
and says so: the add-on then runs its numpy path.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import importlib.util
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = tuple(
    ROOT / "native" / name
    for name in (
        "planar_bones_kernel.c",
        "planar_bones_range.h",
        "lip_guard.h",
        "nearest_sources.h",
        "bind_regions.h",
        "lid_weights.h",
        "unfold.h",
    )
)
WHEELS = ROOT / "wheels"
PACKAGE = "mpeg4_face_kernel"
STEM = "planar_bones_kernel"
# IEEE arithmetic throughout (no -ffast-math): -fno-math-errno and -fno-trapping-math only let the loop
# of square roots and divisions vectorise; FMA contraction changes results by rounding only.
FLAGS = (
    "-O3",
    "-std=gnu11",
    "-fPIC",
    "-shared",
    "-pthread",
    "-fvisibility=hidden",
    "-fno-math-errno",
    "-fno-trapping-math",
    "-ffp-contract=fast",
    "-Wall",
    "-Wextra",
    "-Wno-psabi",
)
ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed, so that the same library gives the same wheel


class KernelBuildError(RuntimeError):
    pass


def abi_version() -> int:
    match = re.search(r"#define PBK_ABI_VERSION (\d+)", SOURCES[0].read_text(encoding="utf-8"))
    if match is None:
        raise KernelBuildError(f"{SOURCES[0]} defines no PBK_ABI_VERSION")
    return int(match.group(1))


def platform_tag() -> str:
    """The wheel platform tag of this Python, e.g. linux_x86_64 (Blender maps it to linux-x64)."""
    return re.sub(r"[-.]", "_", sysconfig.get_platform())


def library_name() -> str:
    suffix = {"win32": ".dll", "darwin": ".dylib"}.get(sys.platform, ".so")
    return STEM + suffix


def wheel_path(out_dir: Path = WHEELS) -> Path:
    return out_dir / f"{PACKAGE}-{abi_version()}.0.0-py3-none-{platform_tag()}.whl"


def compiler() -> str:
    for candidate in (os.environ.get("CC"), "gcc", "cc"):
        if candidate and shutil.which(candidate):
            return candidate
    raise KernelBuildError(
        "no C compiler found (install gcc, or set CC): the compiled kernel cannot be built, and the add-on "
        "will use its slower numpy path"
    )


def source_digest(cc: str) -> str:
    """What the library is built from: the sources, the flags and the compiler's version."""
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout
    digest = hashlib.sha256()
    for part in (*(p.read_bytes() for p in SOURCES), " ".join(FLAGS).encode(), version.encode()):
        digest.update(hashlib.sha256(part).digest())
    return digest.hexdigest()


def _package_init(digest: str) -> str:
    return (
        '"""The compiled Planar Bones kernel of the MPEG-4 Face Animation extension: plain C, loaded with ctypes\n'
        'by its addon/deform/fused.py. Built by scripts/build_kernel.py from native/planar_bones_kernel.c."""\n\n'
        "from pathlib import Path\n\n"
        f'LIBRARY = Path(__file__).with_name("{library_name()}")\n'
        f"ABI_VERSION = {abi_version()}\n"
        f'SOURCE_DIGEST = "{digest}"\n'
    )


def _record_hash(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def _digest_in(init_text: str) -> str | None:
    match = re.search(r'SOURCE_DIGEST = "([0-9a-f]+)"', init_text)
    return match.group(1) if match else None


def _wheel_digest(path: Path) -> str | None:
    try:
        with zipfile.ZipFile(path) as wheel:
            return _digest_in(wheel.read(f"{PACKAGE}/__init__.py").decode())
    except (OSError, KeyError, zipfile.BadZipFile):
        return None


def compile_library(cc: str, target: Path) -> None:
    command = [cc, *FLAGS, "-I", str(SOURCES[0].parent), str(SOURCES[0]), "-o", str(target), "-lm"]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise KernelBuildError(f"{' '.join(command)} failed:\n{result.stdout}{result.stderr}")


def build_wheel(out_dir: Path = WHEELS) -> Path:
    """The kernel's wheel, compiled and packed unless one from the same source is already there."""
    cc = compiler()
    digest = source_digest(cc)
    target = wheel_path(out_dir)
    if _wheel_digest(target) == digest:
        return target
    with tempfile.TemporaryDirectory() as scratch:
        library = Path(scratch) / library_name()
        compile_library(cc, library)
        binary = library.read_bytes()
    version = f"{abi_version()}.0.0"
    info = f"{PACKAGE}-{version}.dist-info"
    files = {
        f"{PACKAGE}/__init__.py": _package_init(digest).encode(),
        f"{PACKAGE}/{library_name()}": binary,
        f"{info}/METADATA": (
            f"Metadata-Version: 2.1\nName: {PACKAGE}\nVersion: {version}\n"
            "Summary: Compiled Planar Bones kernel of the MPEG-4 Face Animation Blender extension\n"
            "License: GPL-3.0-or-later\n"
        ).encode(),
        f"{info}/WHEEL": (
            "Wheel-Version: 1.0\nGenerator: scripts/build_kernel.py\nRoot-Is-Purelib: false\n"
            f"Tag: py3-none-{platform_tag()}\n"
        ).encode(),
    }
    record = "".join(f"{name},{_record_hash(data)},{len(data)}\n" for name, data in files.items())
    files[f"{info}/RECORD"] = (record + f"{info}/RECORD,,\n").encode()
    out_dir.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f"{target.name}.{os.getpid()}.part")  # builds running at once do not collide
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as wheel:
        for name, data in files.items():
            entry = zipfile.ZipInfo(name, ZIP_TIME)
            entry.external_attr = (0o755 if name.endswith(library_name()) else 0o644) << 16
            entry.compress_type = zipfile.ZIP_DEFLATED
            wheel.writestr(entry, data)
    partial.replace(target)
    return target


def installed_digest() -> str | None:
    """The source digest of the kernel installed in this Python, or None."""
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or spec.origin is None:
        return None
    return _digest_in(Path(spec.origin).read_text(encoding="utf-8"))


def install(wheel: Path) -> bool:
    """Install the wheel into this Python unless the same kernel is there; True if it installed."""
    if installed_digest() == _wheel_digest(wheel):
        return False
    command = [sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check"]
    command += ["--no-index", "--no-deps", "--force-reinstall", str(wheel)]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        raise KernelBuildError(f"installing {wheel.name} failed:\n{result.stdout}{result.stderr}")
    return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=WHEELS, help="folder for the wheel (default: wheels/)")
    parser.add_argument("--install", action="store_true", help="also install the wheel into this Python")
    args = parser.parse_args(argv)
    try:
        wheel = build_wheel(args.out)
        print(wheel)
        if args.install and install(wheel):
            print(f"installed {wheel.name} into {sys.prefix}")
    except KernelBuildError as exc:
        print(f"build_kernel: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
