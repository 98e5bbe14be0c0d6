"""Blender tests: the extension registered once per session, each test from an empty scene."""

import pytest

bpy = pytest.importorskip("bpy")


@pytest.fixture(scope="session", autouse=True)
def extension():
    import addon
    from addon.blender import reporting

    addon.register()
    reporting.RAISE_UNEXPECTED = True
    yield
    addon.unregister()


@pytest.fixture(autouse=True)
def empty_scene():
    bpy.ops.wm.read_homefile(use_empty=True)
    yield
