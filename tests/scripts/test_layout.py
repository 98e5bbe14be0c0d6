"""The scripts run one way, as modules from the repository root, and every command the README, the docs/ pages
and the shell entry points give names a script that is there."""

import re
import subprocess
import sys

import pytest

from .helpers import ROOT

SCRIPTS = ROOT / "scripts"
COMMANDS = sorted(
    ".".join(path.relative_to(ROOT).with_suffix("").parts)
    for path in SCRIPTS.rglob("*.py")
    if 'if __name__ == "__main__":' in path.read_text(encoding="utf-8")
)


def test_only_convert_sets_up_a_path():
    """`convert.py` also runs as a file inside Blender; everything else is imported as `scripts.…`."""
    editing = sorted(str(p.relative_to(SCRIPTS)) for p in SCRIPTS.rglob("*.py") if "sys.path" in p.read_text("utf-8"))
    assert editing == ["convert.py"]
    assert (SCRIPTS / "convert.py").read_text("utf-8").count("sys.path.insert") == 1


def test_every_script_sits_in_a_package():
    folders = {p.parent for p in SCRIPTS.rglob("*.py") if "__pycache__" not in p.parts}
    assert all((folder / "__init__.py").is_file() for folder in folders)
    assert {p.name for p in SCRIPTS.iterdir() if p.suffix == ".py"} == {
        "__init__.py",
        "build_extension.py",
        "build_kernel.py",
        "convert.py",
        "say.py",
        "slim_wheels.py",  # build_extension's, as build_kernel.py is
    }


def test_commands_name_scripts_that_exist():
    texts = [ROOT / "README.md", *(ROOT / "docs").glob("*.md"), ROOT / ".ci" / "run", *SCRIPTS.glob("*.sh")]
    named = set()
    for path in texts:
        text = path.read_text("utf-8")
        named |= {ROOT / m for m in re.findall(r"(?<![\w/])scripts/[\w/]+\.(?:py|sh)\b", text)}
        named |= {ROOT / (m.replace(".", "/") + ".py") for m in re.findall(r"-m (scripts(?:\.\w+)+)", text)}
    assert named and not [str(p.relative_to(ROOT)) for p in sorted(named) if not p.is_file()]


@pytest.mark.parametrize("module", COMMANDS)
def test_every_script_runs_as_a_module(module):
    pytest.importorskip("bpy")
    result = subprocess.run(
        [sys.executable, "-m", module, "--help"], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert result.returncode == 0 and "usage:" in result.stdout, result.stdout + result.stderr


def test_no_tracked_text_file_keeps_merge_conflict_markers():
    """A merge once left `<<<<<<< HEAD` … `>>>>>>> branch` in the README; every tracked text file is read for them."""
    names = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    marked = []
    for name in names:
        path = ROOT / name
        if not path.is_file() or path.suffix in {".png", ".blend", ".glb", ".whl", ".zip", ".wav", ".npz", ".npy"}:
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        if re.search(r"^(<{7} |>{7} )", text, re.MULTILINE):
            marked.append(name)
    assert marked == []
