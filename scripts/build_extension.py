"""Build the installable extension zip: blender_manifest.toml and the `addon` package at the zip root.

    .venv/bin/python -m scripts.build_extension [--out dist]

Checks the manifest's required fields first and prints the zip's path. The wheels the manifest lists go
in under wheels/: the compiled kernel's, built first with this machine's C compiler by
`scripts.build_kernel` (an error if there is none, or if the manifest lists a kernel wheel for another
platform that is not in wheels/), and scipy's for each platform, fetched by pip (`pip download
scipy==<requirements.txt's pin> --only-binary=:all: --python-version 3.11 --platform <the file's tag>
--no-deps`) unless already there; a manifest wheel of another scipy version than the pin is an error.
Wheels go in stored (they are zips already). Nothing from tests/ or scripts/ goes in; caches and byte code
are left out.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

from scripts import build_kernel

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
PACKAGE = ROOT / "addon"
REQUIREMENTS = ROOT / "requirements.txt"
FETCHED = ("scipy",)  # wheels pip downloads (Blender ships numpy, not scipy)
PYTHON_VERSION = "3.11"  # Blender 4.2 to 5.0's Python

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


def check_manifest(path: Path = MANIFEST) -> dict:
    """The manifest as a dict, or ManifestError listing every problem (the rules Blender's validator applies)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
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
    for key in ("version", "schema_version", "blender_version_min"):
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


def pinned_version(project: str, requirements: Path = REQUIREMENTS) -> str:
    """The version requirements.txt pins `project` to (`project==X`), or ManifestError."""
    for line in requirements.read_text(encoding="utf-8").splitlines():
        name, _, version = line.split("#")[0].strip().partition("==")
        if name.strip().lower() == project and version.strip():
            return version.strip()
    raise ManifestError(f"{requirements}: no pinned version of {project} (a line {project}==X)")


def fetch_wheel(path: Path) -> None:
    """Download the wheel named `path` (one of FETCHED, at its pinned version) into its folder with pip."""
    project, version, _, _, tag = path.stem.split("-")
    pinned = pinned_version(project)
    if version != pinned:
        raise ManifestError(f"{MANIFEST}: wheel {path.name} is {project} {version}, requirements.txt pins {pinned}")
    command = [sys.executable, "-m", "pip", "download", f"{project}=={pinned}", "--only-binary=:all:"]
    command += ["--python-version", PYTHON_VERSION, "--no-deps", "-d", str(path.parent)]
    for platform in tag.split("."):  # a compressed tag set: any of them selects the file
        command += ["--platform", platform]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0 or not path.is_file():
        raise ManifestError(f"pip could not fetch {path.name}: {(result.stderr or result.stdout).strip()[-500:]}")


def wheel_files(manifest: dict) -> list[Path]:
    """The manifest's wheels, the kernel's built (or found up to date) and scipy's fetched first; ManifestError if
    one is missing."""
    wheels = [ROOT / name for name in manifest.get("wheels", [])]
    if wheels:
        build_kernel.build_wheel()
    for path in wheels:
        if path.name.split("-")[0] in FETCHED and not path.is_file():
            fetch_wheel(path)
    missing = [path.name for path in wheels if not path.is_file()]
    if missing:
        raise ManifestError(f"{MANIFEST}: wheels not in wheels/ (built on another platform?): {', '.join(missing)}")
    return wheels


def build(out_dir: Path) -> Path:
    manifest = check_manifest()
    wheels = wheel_files(manifest)
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"{manifest['id']}-{manifest['version']}.zip"
    partial = target.with_suffix(".zip.part")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.write(MANIFEST, "blender_manifest.toml")
        for path in package_files():
            zf.write(path, path.relative_to(PACKAGE).as_posix())
        for path in wheels:
            zf.write(path, path.relative_to(ROOT).as_posix(), zipfile.ZIP_STORED)
    partial.replace(target)
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "dist")
    args = parser.parse_args(argv)
    try:
        print(build(args.out))
    except (ManifestError, build_kernel.KernelBuildError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
