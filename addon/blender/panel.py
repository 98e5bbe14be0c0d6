"""The sidebar panel: View3D > Sidebar > MPEG-4."""

import bpy

from ..mpeg4.fap_groups import GROUP_NAMES
from ..mpeg4.feature_points import FP_IDS
from . import arkit_ops, auto_placement, binding_store, elastic_ops, face_data, fap_io, followers, inner_parts

FAPU_LABELS = ("IRISD0", "ES0", "ENS0", "MNS0", "MW0")


class MPEG4_PT_face(bpy.types.Panel):
    bl_label = "MPEG-4 Face"
    bl_idname = "MPEG4_PT_face"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "MPEG-4"

    def draw(self, context):
        layout = self.layout
        face = face_data.active_face(context)
        if face is None:
            layout.label(text="Select a face mesh", icon="INFO")
            return
        settings = face.mpeg4_face
        layout.label(text=face.name, icon="MESH_DATA")
        if settings.status:
            box = layout.box()
            box.alert = True
            box.label(text=settings.status, icon="ERROR")

        empties = face_data.fp_empties(face)
        bound = binding_store.is_bound(face)
        col = layout.column(align=True)
        col.label(
            text=f"Feature points: {len(empties)} of {len(FP_IDS)} placed",
            icon="CHECKMARK" if len(empties) == len(FP_IDS) else "DOT",
        )
        if empties and len(empties) < len(FP_IDS):
            missing = [fp_id for fp_id in FP_IDS if fp_id not in empties]
            col.label(text="Missing: " + ", ".join(missing[:8]) + (" ..." if len(missing) > 8 else ""))
        col.label(text="Bound" if bound else "Not bound", icon="LINKED" if bound else "UNLINKED")
        row = layout.row(align=True)
        row.operator("mpeg4.place_feature_points", icon="EMPTY_AXIS")
        row.prop(settings, "use_x_mirror", text="", icon="MOD_MIRROR")
        row.operator("mpeg4.setup_face", icon="MOD_MESHDEFORM")
        layout.operator("mpeg4.auto_place_feature_points", icon="SHADERFX")
        if not bound:
            row = layout.row(align=True)
            row.operator("mpeg4.open_sealed_mouth", icon="MOD_EDGESPLIT")
            row.operator("mpeg4.open_sealed_mouth", text="", icon="HIDE_OFF").show_only = True
        low = auto_placement.low_confidence(face)
        if low:
            col = layout.column(align=True)
            col.label(text="Low confidence: " + ", ".join(low[:8]) + (" ..." if len(low) > 8 else ""), icon="ERROR")
            col.operator("mpeg4.place_feature_points", text="Place Low-Confidence Points").low_confidence = True
        if bound:
            layout.operator("mpeg4.remove_face", icon="X")

        if bound:
            box = layout.box()
            box.prop(settings, "enabled")
            elastic_ops.draw_engine(box, settings)
            sub = box.column()
            sub.active = settings.enabled
            sub.prop(settings, "mode")
            sub.prop(settings, "keep_lips_apart")
            sub.prop(settings, "unfold_skin")
            sub.prop(settings, "still_upper_face")
            sub.prop(settings, "radius_fraction")
            sub.prop(settings, "falloff_exponent")
            sub.prop(settings, "use_masks")
            row = sub.row()
            row.active = settings.use_masks
            row.prop(settings, "mask_image")
            if settings.made_masks and settings.use_masks and settings.mask_image is None:
                col = sub.column(align=True)
                col.label(text="Masks made from the feature points:", icon="GROUP_VERTEX")
                col.label(text=settings.made_masks.replace(",", ", ") + " (vertex groups: edit to refine)")
                filled = face.get(face_data.FILLED_MASKS_PROP)
                if filled:
                    col.label(text=f"{', '.join(filled)}: the groups had no weights", icon="INFO")

            box = layout.box()
            box.label(text="Face Parts", icon="OUTLINER_OB_GROUP_INSTANCE")
            col = box.column(align=True)
            for name in followers.PARTS:
                col.prop(settings, name)
            inside = inner_parts.listed(face)
            if inside:
                col = box.column(align=True)
                col.label(text=f"Inside {face.name} (vertex groups):", icon="GROUP_VERTEX")
                for group, what, how in inside:
                    col.label(text=f"{group}: taken for the {what}, {how}")

            box = layout.box()
            box.label(text="FAP Gains", icon="MODIFIER")
            grid = box.grid_flow(columns=2, align=True)
            for name in GROUP_NAMES:
                grid.prop(settings, f"gain_{name}")
            box.prop(settings, "use_soft_limits")
            record = settings.get(fap_io.RECORD)
            if record is not None:
                box.label(text=f"Changes key {record['source']} again", icon="FILE_REFRESH")
            else:
                box.label(text="Changes apply to the next import", icon="INFO")

            if any(settings.fapu):
                grid = layout.grid_flow(columns=2, align=True)
                for label, value in zip(FAPU_LABELS, settings.fapu, strict=True):
                    grid.label(text=f"{label} {value * 1000:.1f} mm")
            else:
                layout.label(text="FAPU unknown: place the eye, nose and mouth points", icon="ERROR")

            col = layout.column(align=True)
            col.operator("mpeg4.import_fap", icon="IMPORT")
            col.operator("mpeg4.export_fap", icon="EXPORT")
            col.operator("mpeg4.speak_text", text="Speak Text", icon="PLAY_SOUND")
            col.operator("mpeg4.import_cues", text="Import Lip-Sync Cues", icon="SPEAKER")
            col.operator("mpeg4.lipsync_audio", text="Lip-Sync from Audio", icon="SOUND")
            col.prop(context.scene.mpeg4, "fill_partners")
            arkit_ops.draw(layout)
            col = layout.column(align=True)
            col.label(text="Bake the scene's frames:")
            row = col.row(align=True)
            row.prop(context.scene, "frame_start", text="Start")
            row.prop(context.scene, "frame_end", text="End")
            row = col.row(align=True)
            row.operator("mpeg4.bake", text="Bake Shape Keys").target = "SHAPE_KEYS"
            row.operator("mpeg4.bake", text="Bake Point Cache").target = "POINT_CACHE"
            col.operator("mpeg4.bake", text="Bake Point Cache + Alembic").target = "ALEMBIC"

            box = layout.box()
            box.label(text="Fitting", icon="SHAPEKEY_DATA")
            col = box.column(align=True)
            col.operator("mpeg4.fit_to_feature_points", icon="PIVOT_INDIVIDUAL")
            col.operator("mpeg4.fit_to_calibration_mesh", icon="MOD_SHRINKWRAP")
            row = col.row(align=True)
            row.operator("mpeg4.import_fdp", text="Import FDP", icon="IMPORT")
            row.operator("mpeg4.export_fdp", text="Export FDP", icon="EXPORT")
            col.operator("mpeg4.fit_reset", icon="LOOP_BACK")


CLASSES = (MPEG4_PT_face,)
