"""The ARKit operators: Make ARKit Shape Keys, and Import ARKit Capture (to the shape keys or to FAPs)."""

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import arkit_io, arkit_keys, fap_io, poll
from .motion_options import GainAndClamp
from .reporting import Mpeg4Operator


class MPEG4_OT_make_arkit_shape_keys(Mpeg4Operator, bpy.types.Operator):
    """Make ARKit's 52 face shape keys (eyeBlinkLeft ... tongueOut) on the set-up face with its own engine; the eyes,
    lower teeth and tongue get matching keys. Running it again replaces them"""

    bl_idname = "mpeg4.make_arkit_shape_keys"
    bl_label = "Make ARKit Shape Keys"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        return arkit_keys.make_keys(context, poll.face(context))


class MPEG4_OT_import_arkit(GainAndClamp, Mpeg4Operator, bpy.types.Operator, ImportHelper):
    """Import an ARKit capture (Live Link Face CSV, Audio2Face JSON, or a CSV/JSON of the 52 weights per frame)
    onto the active face: key its ARKit shape keys, or turn it into a FAP stream that plays on any engine"""

    bl_idname = "mpeg4.import_arkit"
    bl_label = "Import ARKit Capture"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".csv"
    filter_glob: StringProperty(default="*.csv;*.json", options={"HIDDEN"})
    target: EnumProperty(
        name="Target",
        items=(
            (
                "FAPS",
                "FAP Stream",
                "Weights -> FAPs through the recipe table, keyed on the feature points (any engine; exports as .fap)",
            ),  # fmt: skip
            ("SHAPE_KEYS", "ARKit Shape Keys", "Key the face's 52 ARKit shape keys directly (make them first)"),
        ),
        default="FAPS",
    )
    start_frame: IntProperty(name="Start Frame", default=1, description="The scene frame where the capture starts")
    fps: FloatProperty(
        name="Frame Rate",
        default=30.0,
        min=0.001,
        max=10000.0,
        description="Frames per second of a file that carries no timing (a plain CSV without a time column)",
    )

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def invoke(self, context, event):
        if not self.properties.is_property_set("start_frame"):
            self.start_frame = context.scene.frame_start
        return ImportHelper.invoke(self, context, event)

    def run(self, context):
        options = fap_io.ImportOptions(
            start_frame=self.start_frame, gain=self.gain, clamp=self.clamp or None, set_frame_range=True
        )
        face = poll.face(context)
        return arkit_io.import_capture(context, face, self.filepath, self.target, options, fps=self.fps)


class MPEG4_OT_export_arkit_glb(Mpeg4Operator, bpy.types.Operator, ExportHelper):
    """Write the face and its eyes, teeth and tongue with the 52 ARKit shape keys as glTF morph targets (made first
    if the face has none), for three.js, Unity and Unreal"""

    bl_idname = "mpeg4.export_arkit_glb"
    bl_label = "Export ARKit glTF"
    bl_options = {"REGISTER"}

    filename_ext = ".glb"
    filter_glob: StringProperty(default="*.glb", options={"HIDDEN"})

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        return arkit_io.export_arkit_glb(context, poll.face(context), self.filepath)


def draw(layout) -> None:
    col = layout.column(align=True)
    col.operator(MPEG4_OT_make_arkit_shape_keys.bl_idname, icon="SHAPEKEY_DATA")
    row = col.row(align=True)
    row.operator(MPEG4_OT_import_arkit.bl_idname, text="Import ARKit", icon="IMPORT")
    row.operator(MPEG4_OT_export_arkit_glb.bl_idname, text="Export ARKit glTF", icon="EXPORT")


def menu_import(self, _context):
    self.layout.operator(MPEG4_OT_import_arkit.bl_idname, text="ARKit Capture (.csv, .json)")


def menu_export(self, _context):
    self.layout.operator(MPEG4_OT_export_arkit_glb.bl_idname, text="ARKit Face glTF (.glb)")


CLASSES = (MPEG4_OT_make_arkit_shape_keys, MPEG4_OT_import_arkit, MPEG4_OT_export_arkit_glb)
