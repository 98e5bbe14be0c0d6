"""Build the installable extension zips: one per platform and Blender line, each with only its own wheels.

    .venv/bin/python -m scripts.build_extension [--out dist] [--platforms linux-x64 ...] [--lines 4.2-5.0 ...]

Blender 4.2 to 5.0 run CPython 3.11 and Blender 5.1 and 5.2 CPython 3.13 (LINES); Blender installs a wheel only
on its own platform and Python, so a zip for both would carry two of each (scipy alone: 70 MB). Each zip,
`dist/<id>-<version>-<platform>-blender<line>.zip`, holds blender_manifest.toml (stating that platform, that line's
Blender versions and its wheels) and the `addon` package at the root, and under wheels/: the compiled kernel's,
cross-compiled for the platform by `scripts.build_kernel`, and those of BUNDLED at the versions requirements.txt
(3.11) or requirements313.txt (3.13) pins, fetched by pip (`pip download --only-binary=:all: --no-deps
--python-version <line's> --platform <the platform's tags>`) into wheels/ unless already there. A project with no
wheel for a platform and Python is left out of that zip only where NO_WHEEL says so (that feature then says what
is missing); any other failure to fetch is an error. Checks the manifest's required fields first, and prints each
zip's path and size. Wheels go in stored (they are zips already). Nothing from tests/ or scripts/ goes in; caches
and byte code are left out.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from dataclasses import dataclass
from pathlib import Path

from scripts import build_kernel, slim_wheels

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
PACKAGE = ROOT / "addon"
WHEELS = build_kernel.WHEELS
MEGABYTE = 1e6


@dataclass(frozen=True)
class Line:
    """Blender versions [minimum, maximum) that share one Python, and the requirements file pinning its wheels."""

    python: str
    minimum: str
    maximum: str
    requirements: Path


LINES = {
    "4.2-5.0": Line("3.11", "4.2.0", "5.1.0", ROOT / "requirements.txt"),
    "5.1-5.2": Line("3.13", "5.1.0", "5.3.0", ROOT / "requirements313.txt"),
}
# What Blender does not ship and the add-on needs: scipy (fitting, Elastic Bones' weights), PocketSphinx (audio
# lip-sync), espeak-ng's library and voices (speech from text). Blender ships numpy.
BUNDLED = ("scipy", "pocketsphinx", "espeakng-loader")
# pip's --platform tags per Blender platform (pip adds older macOS versions and universal2 itself). scipy's macOS
# arm64 wheels need macOS 12: none is older.
PIP_PLATFORMS = {
    "windows-x64": ("win_amd64",),
    "windows-arm64": ("win_arm64",),
    "macos-x64": ("macosx_11_0_x86_64",),
    "macos-arm64": ("macosx_12_0_arm64",),
    "linux-x64": tuple(f"manylinux_2_{glibc}_x86_64" for glibc in (28, 27, 17)) + ("manylinux2014_x86_64",),
    "linux-arm64": tuple(f"manylinux_2_{glibc}_aarch64" for glibc in (28, 27, 17)) + ("manylinux2014_aarch64",),
}
# (project, Python, platform) that PyPI has no wheel for at the pinned version
NO_WHEEL = {
    ("scipy", "3.11", "windows-arm64"),  # scipy's first win_arm64 wheels (1.16) need NumPy 1.25, Blender 4.2 has 1.24
    ("pocketsphinx", "3.11", "windows-arm64"),
    ("pocketsphinx", "3.13", "windows-arm64"),
}

REQUIRED = (
    "schema_version",
    "id",
    "version",
    "name",
    "tagline",
    "maintainer",
    "type",
    "license",
    "blender_version_min",
)
SEMVER = re.compile(r"^\d+\.\d+\.\d+$")
WHEEL = re.compile(r"^\./wheels/[\w.+]+(-[\w.+]+){4,5}\.whl$")  # the wheel file name spec


class ManifestError(ValueError):
    pass


def check_manifest(path: Path = MANIFEST, text: str | None = None) -> dict:
    """The manifest at `path` (or `text`, named by `path`) as a dict, or ManifestError listing every problem (the
    rules Blender's validator applies)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8") if text is None else text)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ManifestError(f"{path}: cannot read: {exc}") from None
    problems = [f"missing required field {key!r}" for key in REQUIRED if key not in data]
    if "id" in data and not (
        data["id"].isidentifier()
        and "__" not in data["id"]
        and not data["id"].startswith("_")
        and not data["id"].endswith("_")
    ):
        problems.append(f"id {data['id']!r} must be a Python identifier without '__' or edge underscores")
    for key in ("version", "schema_version", "blender_version_min", "blender_version_max"):
        if key in data and not SEMVER.match(str(data[key])):
            problems.append(f"{key} {data[key]!r} must look like 1.2.3")
    tagline = data.get("tagline", "")
    if len(tagline) > 64 or (tagline and not (tagline[-1].isalnum() or tagline[-1] in ")]}")):
        problems.append("tagline must be at most 64 characters and must not end with punctuation")
    if data.get("type") not in (None, "add-on"):
        problems.append("type must be 'add-on'")
    if "license" in data and not (isinstance(data["license"], list) and data["license"]):
        problems.append("license must be a non-empty list")
    wheels = data.get("wheels", [])
    if not (isinstance(wheels, list) and all(isinstance(w, str) and WHEEL.match(w) for w in wheels)):
        problems.append("wheels must be a list of paths like ./wheels/NAME-VERSION-PY-ABI-PLATFORM.whl")
    if problems:
        raise ManifestError(f"{path}: " + "; ".join(problems))
    return data


def package_files() -> list[Path]:
    return sorted(
        p
        for p in PACKAGE.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and p.suffix not in (".pyc", ".pyo")
    )


def pinned_version(project: str, requirements: Path = LINES["4.2-5.0"].requirements) -> str:
    """The version a requirements file pins `project` to (`project==X`), or ManifestError."""
    for line in requirements.read_text(encoding="utf-8").splitlines():
        name, _, version = line.split("#")[0].strip().partition("==")
        if name.strip().lower() == project and version.strip():
            return version.strip()
    raise ManifestError(f"{requirements}: no pinned version of {project} (a line {project}==X)")


def fetch_wheel(project: str, line: Line, platform: str, out_dir: Path = WHEELS) -> Path | None:
    """The wheel of `project` at the line's pinned version for its Python on `platform`, downloaded by pip into
    `out_dir` unless there; None where NO_WHEEL says PyPI has none, ManifestError when pip fails otherwise."""
    if (project, line.python, platform) in NO_WHEEL:
        return None
    command = [sys.executable, "-m", "pip", "download", f"{project}=={pinned_version(project, line.requirements)}"]
    command += ["--only-binary=:all:", "--no-deps", "--python-version", line.python, "--disable-pip-version-check"]
    for tag in PIP_PLATFORMS[platform]:
        command += ["--platform", tag]
    with tempfile.TemporaryDirectory() as scratch:  # the one file pip chose (pip's own cache makes a repeat fast)
        result = subprocess.run([*command, "-d", scratch], capture_output=True, text=True)
        fetched = list(Path(scratch).glob("*.whl"))
        if result.returncode != 0 or len(fetched) != 1:
            raise ManifestError(
                f"pip could not fetch {project} for Python {line.python} on {platform}: "
                f"{(result.stderr or result.stdout).strip()[-500:]}"
            )
        target = out_dir / fetched[0].name
        if not target.is_file():
            out_dir.mkdir(parents=True, exist_ok=True)
            fetched[0].replace(target)
    return target


def zip_manifest(template: str, platform: str, line: Line, wheels: list[Path]) -> str:
    """The manifest text of one zip: the template's, stating one platform, the line's Blender versions and its
    wheels (Blender derives the Python the zip needs from the wheels' tags)."""
    text, platforms = re.subn(r"(?m)^platforms = \[.*\]$", f'platforms = ["{platform}"]', template)
    text, versions = re.subn(
        r'(?m)^blender_version_min = ".*"$',
        f'blender_version_min = "{line.minimum}"\nblender_version_max = "{line.maximum}"',
        text,
    )
    if (platforms, versions) != (1, 1) or re.search(r"(?m)^(wheels|blender_version_max) =", template):
        raise ManifestError(
            f"{MANIFEST}: needs one `platforms = [...]` line and one `blender_version_min`, and no `wheels` or "
            "`blender_version_max` (the build states them per zip)"
        )
    listed = ",\n".join(f'  "./wheels/{wheel.name}"' for wheel in wheels)
    return text.replace(f'platforms = ["{platform}"]', f'platforms = ["{platform}"]\nwheels = [\n{listed},\n]', 1)


def zip_name(manifest: dict, platform: str, line: str) -> str:
    return f"{manifest['id']}-{manifest['version']}-{platform.replace('-', '_')}-blender{line}.zip"


def build_zip(out_dir: Path, template: str, platform: str, line: str) -> Path:
    wheels = [build_kernel.build_wheel(platform)]
    wheels += [slim_wheels.slim(wheel) for project in BUNDLED if (wheel := fetch_wheel(project, LINES[line], platform))]
    text = zip_manifest(template, platform, LINES[line], wheels)
    with tempfile.TemporaryDirectory() as scratch:
        manifest = check_manifest(Path(scratch) / "blender_manifest.toml", text)
    target = out_dir / zip_name(manifest, platform, line)
    partial = target.with_suffix(".zip.part")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("blender_manifest.toml", text)
        for path in package_files():
            zf.write(path, path.relative_to(PACKAGE).as_posix())
        for path in wheels:
            zf.write(path, f"wheels/{path.name}", zipfile.ZIP_STORED)
    partial.replace(target)
    return target


def build(out_dir: Path, platforms=tuple(build_kernel.PLATFORMS), lines=tuple(LINES)) -> list[Path]:
    """The zips of these platforms and Blender lines, built into `out_dir`."""
    template = MANIFEST.read_text(encoding="utf-8")
    listed = check_manifest(MANIFEST, template)["platforms"]
    unknown = sorted(set(platforms) - set(listed))
    if unknown:
        raise ManifestError(f"{MANIFEST}: lists no platform {', '.join(unknown)}")
    out_dir.mkdir(parents=True, exist_ok=True)
    return [build_zip(out_dir, template, platform, line) for platform in platforms for line in lines]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "dist")
    parser.add_argument("--platforms", nargs="+", choices=build_kernel.PLATFORMS, default=list(build_kernel.PLATFORMS))
    parser.add_argument("--lines", nargs="+", choices=LINES, default=list(LINES), help="Blender versions")
    args = parser.parse_args(argv)
    try:
        for path in build(args.out, args.platforms, args.lines):
            print(f"{path}  {path.stat().st_size / MEGABYTE:.1f} MB")
    except (ManifestError, build_kernel.KernelBuildError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
