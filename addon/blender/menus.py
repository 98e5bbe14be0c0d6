"""Where the operators appear: File > Import/Export, Object > MPEG-4 Face (so F3 search finds them too), and
a .fap file dropped on the 3D viewport."""

import bpy

from . import arkit_ops, auto_placement_ops, fitting_ops, ops, speech_ops, voice_ops


class MPEG4_MT_object(bpy.types.Menu):
    bl_idname = "MPEG4_MT_object"
    bl_label = "MPEG-4 Face"

    def draw(self, _context):
        layout = self.layout
        layout.operator(ops.MPEG4_OT_place_feature_points.bl_idname)
        layout.operator(auto_placement_ops.MPEG4_OT_auto_place_feature_points.bl_idname)
        layout.operator(ops.MPEG4_OT_setup_face.bl_idname)
        layout.operator(ops.MPEG4_OT_open_sealed_mouth.bl_idname)
        layout.separator()
        layout.operator(ops.MPEG4_OT_import_fap.bl_idname)
        layout.operator(ops.MPEG4_OT_export_fap.bl_idname)
        layout.operator(speech_ops.MPEG4_OT_speak_text.bl_idname, text="Speak Text…")
        layout.operator(speech_ops.MPEG4_OT_import_cues.bl_idname, text="Import Lip-Sync Cues…")
        layout.operator(voice_ops.MPEG4_OT_lipsync_audio.bl_idname, text="Lip-Sync from Audio…")
        layout.operator(voice_ops.MPEG4_OT_lipsync_strip.bl_idname, text="Lip-Sync from Sound Strip…")
        layout.separator()
        layout.operator(fitting_ops.MPEG4_OT_fit_to_feature_points.bl_idname)
        layout.operator(fitting_ops.MPEG4_OT_import_fdp.bl_idname, text="Import FDP…")
        layout.operator(fitting_ops.MPEG4_OT_export_fdp.bl_idname, text="Export FDP…")
        layout.operator(fitting_ops.MPEG4_OT_fit_to_calibration_mesh.bl_idname)
        layout.operator(fitting_ops.MPEG4_OT_fit_reset.bl_idname)
        layout.separator()
        layout.operator(arkit_ops.MPEG4_OT_make_arkit_shape_keys.bl_idname)
        layout.operator(arkit_ops.MPEG4_OT_import_arkit.bl_idname, text="Import ARKit Capture…")
        layout.separator()
        layout.operator(ops.MPEG4_OT_bake.bl_idname, text="Bake to Shape Keys").target = "SHAPE_KEYS"
        layout.operator(ops.MPEG4_OT_bake.bl_idname, text="Bake to Point Cache").target = "POINT_CACHE"
        layout.operator(ops.MPEG4_OT_bake.bl_idname, text="Bake to Point Cache and Alembic").target = "ALEMBIC"
        layout.separator()
        layout.operator(ops.MPEG4_OT_remove_face.bl_idname)


class MPEG4_FH_fap(bpy.types.FileHandler):
    """A .fap file dropped on the 3D viewport imports onto the active face."""

    bl_idname = "MPEG4_FH_fap"
    bl_label = "MPEG-4 FAP stream"
    bl_import_operator = ops.MPEG4_OT_import_fap.bl_idname
    bl_file_extensions = ".fap"

    @classmethod
    def poll_drop(cls, context):
        return context.area is not None and context.area.type == "VIEW_3D"


def menu_import(self, _context):
    self.layout.operator(ops.MPEG4_OT_import_fap.bl_idname, text="MPEG-4 FAP (.fap)")
    self.layout.operator(fitting_ops.MPEG4_OT_import_fdp.bl_idname, text="MPEG-4 FDP (.json, XFace .fdp)")
    self.layout.operator(speech_ops.MPEG4_OT_import_cues.bl_idname, text="Lip-Sync Cues (.tsv, .json)")
    arkit_ops.menu_import(self, _context)


def menu_export(self, _context):
    self.layout.operator(ops.MPEG4_OT_export_fap.bl_idname, text="MPEG-4 FAP (.fap)")
    self.layout.operator(fitting_ops.MPEG4_OT_export_fdp.bl_idname, text="MPEG-4 FDP (.json)")
    arkit_ops.menu_export(self, _context)


def menu_object(self, _context):
    self.layout.separator()
    self.layout.menu(MPEG4_MT_object.bl_idname)


CLASSES = (MPEG4_MT_object, MPEG4_FH_fap)
MENU_ENTRIES = (
    (bpy.types.TOPBAR_MT_file_import, menu_import),
    (bpy.types.TOPBAR_MT_file_export, menu_export),
    (bpy.types.VIEW3D_MT_object, menu_object),
)
