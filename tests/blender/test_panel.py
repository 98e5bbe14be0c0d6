"""The sidebar panel draws the face's state in each situation (recorded through a stand-in layout)."""

from types import SimpleNamespace

import bpy

from addon.blender.panel import MPEG4_PT_face

from .helpers import open_sample, select, set_up_sample


class Layout:
    """Records labels, properties and operators drawn; every container is itself."""

    def __init__(self):
        self.labels, self.props, self.operators = [], [], []

    def label(self, text="", icon="NONE"):
        self.labels.append(text)

    def prop(self, data, name, **_kw):
        self.props.append(name)

    def operator(self, idname, **_kw):
        self.operators.append(idname)
        return SimpleNamespace()

    def __getattr__(self, name):  # row, column, box, grid_flow, and flags like alert/active
        return lambda *a, **k: self


def draw():
    layout = Layout()
    MPEG4_PT_face.draw(SimpleNamespace(layout=layout), bpy.context)
    return layout


def test_panel_without_a_face():
    assert draw().labels == ["Select a face mesh"]


def test_panel_of_a_face_before_and_after_set_up():
    head = open_sample()
    select(head)
    bpy.ops.mpeg4.remove_face()
    before = draw()
    assert "mpeg4.setup_face" in before.operators and "mpeg4.import_fap" not in before.operators
    assert any(text.startswith("Feature points: 84 of 84") for text in before.labels)

    head = set_up_sample()
    after = draw()
    assert {"enabled", "mode", "radius_fraction", "falloff_exponent", "use_masks"} <= set(after.props)
    assert {"mpeg4.import_fap", "mpeg4.export_fap", "mpeg4.bake", "mpeg4.remove_face"} <= set(after.operators)
    assert "Bound" in after.labels and any(text.startswith("ES0 61.") for text in after.labels)


def test_panel_shows_why_the_effect_turned_off():
    head = set_up_sample()
    bpy.data.objects.remove(bpy.data.objects["FP 2.4"])
    bpy.context.scene.frame_set(5)
    layout = draw()
    assert any("2.4" in text for text in layout.labels)
    assert any(text.startswith("Missing: 2.4") for text in layout.labels)
    assert not head.mpeg4_face.enabled
