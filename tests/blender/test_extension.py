"""The extension zip: built from the manifest and the package, installed into a fresh Blender session."""

import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import bpy
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

import build_extension  # noqa: E402

SCRIPTS = Path(bpy.utils.system_resource("SCRIPTS"))
BLENDER_EXT = SCRIPTS / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
TAGS = SCRIPTS / "modules" / "_bpy_internal" / "extensions" / "tags.py"


@pytest.fixture(scope="module")
def built_zip(tmp_path_factory):
    return build_extension.build(tmp_path_factory.mktemp("dist"))


def test_zip_holds_manifest_and_package_at_the_root(built_zip):
    names = zipfile.ZipFile(built_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert "blender/registration.py" in names and "mpeg4/fap_file.py" in names and "deform/planar_bones.py" in names
    assert not any(n.startswith(("tests/", "scripts/", "addon/")) or "__pycache__" in n for n in names)


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
    import sys, bpy, addon_utils
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
    sample = ROOT / "sample_blends" / "makehuman_head.blend"
    # run where the checkout is not importable, so only the installed extension can answer
    result = subprocess.run(
        [sys.executable, "-c", INSTALL, str(sample), str(built_zip)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        cwd=tmp_path,
    )
    assert "INSTALL-OK" in result.stdout, result.stdout[-3000:] + result.stderr[-3000:]
