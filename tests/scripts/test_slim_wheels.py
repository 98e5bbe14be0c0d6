"""The trimmed wheels: what goes, what stays, a RECORD that lists exactly what is left, and that the add-on never
loads what is dropped."""

import ast
import base64
import csv
import hashlib
import io
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from scripts import slim_wheels

ROOT = Path(__file__).resolve().parents[2]


def _hash(data: bytes) -> str:
    return "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def _wheel(path: Path, files: dict[str, bytes]) -> Path:
    info = path.name.split("-")[0] + "-" + path.name.split("-")[1] + ".dist-info"
    files = {**files, f"{info}/WHEEL": b"Wheel-Version: 1.0\nRoot-Is-Purelib: false\nTag: cp311-cp311-x\n"}
    record = "".join(f"{name},{_hash(data)},{len(data)}\n" for name, data in files.items())
    with zipfile.ZipFile(path, "w") as wheel:
        for name, data in files.items():
            wheel.writestr(name, data)
        wheel.writestr(f"{info}/RECORD", record + f"{info}/RECORD,,\n")
    return path


SCIPY = {
    "scipy/__init__.py": b"# scipy",
    "scipy/spatial/_qhull.so": b"qhull" * 100,
    "scipy/spatial/tests/test_qhull.py": b"def test(): pass",
    "scipy/stats/_stats.so": b"stats" * 100,
    "scipy/stats/__init__.py": b"",
    "scipy/_lib/tests/test_x.py": b"",
    "scipy/.dylibs/libopenblas.dylib": b"blas" * 50,
    "scipy/testsuite.py": b"# a file named like tests, kept",
    "scipy/_lib/_ccallback_c.pyx": b"# Cython source",  # files for building against scipy go
    "scipy/special/cython_special.pxd": b"# Cython declarations",
    "scipy/_lib/_uarray/vectorcall.h": b"/* header */",
    "scipy/optimize/_lsq/__init__.pyi": b"# stub",
    "scipy.libs/libgfortran.so": b"fortran",
    "scipy-1.15.3.dist-info/LICENSE.txt": b"BSD",
}


def test_scipy_loses_its_tests_and_unused_subpackages_and_its_record_lists_what_is_left(tmp_path):
    source = _wheel(tmp_path / "scipy-1.15.3-cp311-cp311-macosx_12_0_arm64.whl", SCIPY)
    slim = slim_wheels.slim(source, tmp_path / "out")
    assert slim.name == "scipy-1.15.3-1slim-cp311-cp311-macosx_12_0_arm64.whl"
    with zipfile.ZipFile(slim) as wheel:
        names = set(wheel.namelist())
        kept = {
            "scipy/__init__.py",
            "scipy/spatial/_qhull.so",
            "scipy/.dylibs/libopenblas.dylib",
            "scipy/testsuite.py",
            "scipy.libs/libgfortran.so",
            "scipy-1.15.3.dist-info/LICENSE.txt",
        }
        info = {"scipy-1.15.3.dist-info/WHEEL", "scipy-1.15.3.dist-info/RECORD"}
        assert names == kept | info
        for name in kept:
            assert wheel.read(name) == SCIPY[name]
        assert wheel.read("scipy-1.15.3.dist-info/WHEEL").decode().endswith("Tag: cp311-cp311-x\nBuild: 1slim\n")
        rows = list(csv.reader(io.StringIO(wheel.read("scipy-1.15.3.dist-info/RECORD").decode())))
        assert {row[0] for row in rows} == names
        for name, digest, size in rows:
            if name.endswith("RECORD"):
                assert (digest, size) == ("", "")
            else:
                data = wheel.read(name)
                assert (digest, int(size)) == (_hash(data), len(data)), name


def test_pocketsphinx_loses_only_the_word_language_model_and_a_repeat_reuses_the_copy(tmp_path):
    model = "pocketsphinx/model/en-us/"
    files = {model + "en-us.lm.bin": b"lm" * 1000, model + "en-us-phone.lm.bin": b"phones", model + "cmudict": b"d"}
    source = _wheel(tmp_path / "pocketsphinx-5.1.1-cp313-cp313-win_amd64.whl", files)
    slim = slim_wheels.slim(source)
    assert slim.parent == tmp_path and slim.name == "pocketsphinx-5.1.1-1slim-cp313-cp313-win_amd64.whl"
    names = set(zipfile.ZipFile(slim).namelist())
    assert model + "en-us.lm.bin" not in names and {model + "en-us-phone.lm.bin", model + "cmudict"} <= names
    made = slim.stat().st_mtime_ns
    assert slim_wheels.slim(source) == slim and slim.stat().st_mtime_ns == made
    _wheel(source, {**files, model + "cmudict": b"another dictionary"})  # a new source wheel: made again
    assert zipfile.ZipFile(slim_wheels.slim(source)).read(model + "cmudict") == b"another dictionary"


def test_other_projects_are_used_as_they_are_and_a_name_with_a_build_tag_is_refused(tmp_path):
    loader = _wheel(tmp_path / "espeakng_loader-0.2.4-py3-none-win_amd64.whl", {"espeakng_loader/x": b"x"})
    assert slim_wheels.slim(loader) == loader
    tagged = _wheel(tmp_path / "scipy-1.15.3-2-cp311-cp311-win_amd64.whl", {"scipy/x.py": b""})
    with pytest.raises(slim_wheels.WheelError, match="without a build tag"):
        slim_wheels.slim(tagged)


def _scipy_modules_in_the_addon() -> set[str]:
    found = set()
    for path in (ROOT / "addon").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("scipy"):
                found.add(node.module)
            elif isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names if alias.name.startswith("scipy"))
    return found


def test_the_addon_imports_no_dropped_scipy_subpackage_nor_anything_that_loads_one():
    imported = _scipy_modules_in_the_addon()
    assert {"scipy.spatial", "scipy.sparse.linalg", "scipy.sparse.csgraph", "scipy.optimize"} <= imported
    assert not {name.split(".")[1] for name in imported if "." in name} & set(slim_wheels.DROPPED_SCIPY)
    # and what those load, calls included (some scipy functions import more when first called)
    script = "\n".join(f"import {name}" for name in sorted(imported)) + (
        "\nimport numpy as np, sys"
        "\nfrom scipy.optimize import lsq_linear; lsq_linear(np.eye(2), [1.0, 2.0], bounds=(0, 1))"
        "\nfrom scipy.sparse import csc_matrix; from scipy.sparse.linalg import splu"
        "\nsplu(csc_matrix(np.eye(3)), permc_spec='MMD_AT_PLUS_A', options={'SymmetricMode': True}).solve(np.ones(3))"
        "\nfrom scipy.sparse.csgraph import dijkstra, connected_components"
        "\ndijkstra(csc_matrix(np.eye(3)), indices=0); connected_components(csc_matrix(np.eye(3)))"
        "\nfrom scipy.spatial import Delaunay, cKDTree; p = np.random.default_rng(0).random((20, 3))"
        "\nDelaunay(p); cKDTree(p).query(p[0])"
        "\nprint(' '.join(sorted({m.split('.')[1] for m in sys.modules if m.startswith('scipy.')})))"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    loaded = set(result.stdout.split())
    assert "spatial" in loaded, result.stderr and not loaded & set(slim_wheels.DROPPED_SCIPY)


def test_only_the_recogniser_names_the_dropped_language_model_and_does_without_it():
    # recognition without a transcript decodes words with it where it is installed and falls back to the phone
    # loop where it is not (tests/core/test_voice.py: ..._the_phone_loop_is_used)
    for path in (ROOT / "addon").rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        if path.name != "phone_alignment.py":
            assert "en-us.lm" not in text.replace("en-us-phone.lm", ""), path
    assert "en-us.lm.bin" in (ROOT / "addon" / "speech" / "phone_alignment.py").read_text(encoding="utf-8")


def test_a_wheel_without_its_record_is_refused_and_leaves_no_partial_file(tmp_path):
    broken = tmp_path / "scipy-1.15.3-cp311-cp311-win_amd64.whl"
    with zipfile.ZipFile(broken, "w") as wheel:
        wheel.writestr("scipy/__init__.py", "")
    with pytest.raises(slim_wheels.WheelError, match="one .dist-info/RECORD"):
        slim_wheels.slim(broken)
    assert sorted(p.name for p in tmp_path.iterdir()) == [broken.name]
