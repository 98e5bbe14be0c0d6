"""The extension package works under any name Blender gives it (bl_ext.<repo>.mpeg4_face)."""

import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "addon"


def test_the_package_imports_itself_only_relatively():
    absolute = re.compile(r"^\s*(from|import)\s+addon\b", re.MULTILINE)
    offenders = [str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py") if absolute.search(p.read_text())]
    assert offenders == []


def test_the_numerical_core_does_not_import_bpy():
    core = [
        p
        for folder in ("mpeg4", "deform", "geometry", "formats", "speech", "fitting", "arkit")
        for p in (PACKAGE / folder).rglob("*.py")
    ]
    blender = re.compile(r"^\s*(import|from)\s+(bpy|mathutils)\b", re.MULTILINE)
    assert core and [p.name for p in core if blender.search(p.read_text())] == []
