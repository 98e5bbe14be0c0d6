"""Operators. Each is thin: it gathers its inputs and calls a service (setup, fap_io, bake)."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatVectorProperty, IntProperty, StringProperty
from bpy_extras import view3d_utils
from bpy_extras.io_utils import ExportHelper, ImportHelper
from mathutils import Vector

from ..mpeg4.feature_points import FP_IDS, feature_point
from . import bake, face_data, fap_io, setup
from .panel import active_face
from .reporting import Mpeg4Operator, UserError


def _face(context):
    face = active_face(context)
    if face is None:
        raise UserError("select the face mesh (or one of its feature point empties) first")
    return face


class MPEG4_OT_setup_face(Mpeg4Operator, bpy.types.Operator):
    """Build the control mesh from the feature point empties, compute FAPU, bind and turn deformation on"""

    bl_idname = "mpeg4.setup_face"
    bl_label = "Set Up Face"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        return setup.set_up(_face(context))


class MPEG4_OT_remove_face(Mpeg4Operator, bpy.types.Operator):
    """Take the set-up away: the mesh goes back to its rest shape and what set-up made is deleted"""

    bl_idname = "mpeg4.remove_face"
    bl_label = "Remove Set-Up"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        return setup.remove(_face(context))


def _fp_items(_self, _context):
    return [(fp_id, fp_id, feature_point(fp_id).description) for fp_id in FP_IDS]


def place_feature_point(face, fp_id: str, world_location) -> bpy.types.Object:
    """Create (or move) the empty of `fp_id` at a world location; skin points snap onto the face."""
    coll = setup.ensure_fp_collection(face)
    empty = face_data.fp_empties(face).get(fp_id)
    if empty is None:
        empty = bpy.data.objects.new(f"FP {fp_id}", None)
        empty[face_data.FP_PROP] = fp_id
        empty[face_data.CREATED_PROP] = True
        empty.empty_display_type = "SPHERE"
        empty.empty_display_size = 0.002 * max(face.dimensions.length, 1e-3) / max(face.scale.length, 1e-9)
        coll.objects.link(empty)
        empty.parent = face
    local = face.matrix_world.inverted() @ Vector(world_location)
    if feature_point(fp_id).surface == "skin":
        ok, on_surface, _n, _i = face.closest_point_on_mesh(local)
        if ok:
            local = on_surface
    empty.location = local
    return empty


class MPEG4_OT_place_feature_points(Mpeg4Operator, bpy.types.Operator):
    """Place feature points by clicking on the face: the header names the next point and where it goes"""

    bl_idname = "mpeg4.place_feature_points"
    bl_label = "Place Feature Points"
    bl_options = {"REGISTER", "UNDO"}

    fp_id: EnumProperty(name="Feature Point", items=_fp_items)
    location: FloatVectorProperty(name="Location", subtype="TRANSLATION", description="World position")

    def run(self, context):
        face = _face(context)
        place_feature_point(face, self.fp_id, self.location)
        return [f"placed FP {self.fp_id}"]

    # interactive: click on the face for each missing point in turn
    def invoke(self, context, event):
        face = active_face(context)
        if face is None or context.area is None or context.area.type != "VIEW_3D":
            self.report({"ERROR"}, "select the face mesh in a 3D viewport first")
            return {"CANCELLED"}
        self._face_name = face.name
        self._queue = [fp_id for fp_id in FP_IDS if fp_id not in face_data.fp_empties(face)]
        if not self._queue:
            self.report({"INFO"}, "all 84 feature points are placed")
            return {"CANCELLED"}
        self._placed = 0
        self._prompt(context)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _prompt(self, context):
        fp = feature_point(self._queue[0])
        context.area.header_text_set(
            f"Click: FP {fp.id}, {fp.description} ({fp.surface})   S: skip   Esc/Enter: finish "
            f"({len(self._queue)} left)"
        )

    def _finish(self, context):
        context.area.header_text_set(None)
        self.report({"INFO"}, f"placed {self._placed} feature points; run Set Up Face when done")
        return {"FINISHED"}

    def modal(self, context, event):
        if event.type in {"ESC", "RET"} and event.value == "PRESS":
            return self._finish(context)
        if event.type == "S" and event.value == "PRESS":
            self._queue.append(self._queue.pop(0))
            self._prompt(context)
            return {"RUNNING_MODAL"}
        if event.type == "LEFTMOUSE" and event.value == "PRESS":
            face = bpy.data.objects.get(self._face_name)
            hit = self._ray_cast(context, event)
            if face is None:
                return self._finish(context)
            if hit is not None:
                fp_id = self._queue.pop(0)
                place_feature_point(face, fp_id, hit)
                self._placed += 1
                bpy.ops.ed.undo_push(message=f"Place FP {fp_id}")
                if not self._queue:
                    return self._finish(context)
                self._prompt(context)
            return {"RUNNING_MODAL"}
        return {"PASS_THROUGH"}

    @staticmethod
    def _ray_cast(context, event):
        region, rv3d = context.region, context.region_data
        coord = (event.mouse_region_x, event.mouse_region_y)
        origin = view3d_utils.region_2d_to_origin_3d(region, rv3d, coord)
        direction = view3d_utils.region_2d_to_vector_3d(region, rv3d, coord)
        hit, location, *_rest = context.scene.ray_cast(context.evaluated_depsgraph_get(), origin, direction)
        return location if hit else None


class MPEG4_OT_import_fap(Mpeg4Operator, bpy.types.Operator, ImportHelper):
    """Import an MPEG-4 FAP stream: key the feature point empties (and head rotation) of the active face"""

    bl_idname = "mpeg4.import_fap"
    bl_label = "Import FAP Stream"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".fap"
    filter_glob: StringProperty(default="*.fap", options={"HIDDEN"})
    at_current_frame: BoolProperty(
        name="Start at Current Frame",
        default=False,
        description="Put the stream's time 0 at the current frame (else at the scene's start frame)",
    )
    set_frame_range: BoolProperty(
        name="Extend Frame Range", default=True, description="Extend the scene's end frame to the end of the stream"
    )

    def run(self, context):
        face = _face(context)
        scene = context.scene
        start = scene.frame_current if self.at_current_frame else scene.frame_start
        return fap_io.import_fap(
            context,
            face,
            self.filepath,
            start_frame=start,
            fill_partners=scene.mpeg4.fill_partners,
            set_frame_range=self.set_frame_range,
        )


class MPEG4_OT_export_fap(Mpeg4Operator, bpy.types.Operator, ExportHelper):
    """Write the posed or animated feature point empties as an MPEG-4 FAP stream"""

    bl_idname = "mpeg4.export_fap"
    bl_label = "Export FAP Stream"
    bl_options = {"REGISTER"}

    filename_ext = ".fap"
    filter_glob: StringProperty(default="*.fap", options={"HIDDEN"})
    frame_start: IntProperty(name="Start", default=-1, description="First frame (-1: the scene's)")
    frame_end: IntProperty(name="End", default=-1, description="Last frame (-1: the scene's)")

    def run(self, context):
        scene = context.scene
        start = scene.frame_start if self.frame_start < 0 else self.frame_start
        end = scene.frame_end if self.frame_end < 0 else self.frame_end
        return fap_io.export_fap(context, _face(context), self.filepath, start, end)


class MPEG4_OT_bake(Mpeg4Operator, bpy.types.Operator):
    """Bake the deformation over the scene's frame range so it plays without this extension"""

    bl_idname = "mpeg4.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER", "UNDO"}

    target: EnumProperty(
        name="Target",
        items=(
            ("SHAPE_KEYS", "Shape Keys", "One shape key per frame, keyed on and off"),
            ("POINT_CACHE", "Point Cache", "A .pc2 file next to the .blend read by a Mesh Cache modifier"),
        ),
    )
    filepath: StringProperty(name="Cache File", subtype="FILE_PATH", default="")

    def run(self, context):
        face = _face(context)
        scene = context.scene
        frames = range(scene.frame_start, scene.frame_end + 1)
        if self.target == "SHAPE_KEYS":
            return bake.bake_shape_keys(context, face, frames)
        return bake.bake_point_cache(context, face, frames, self.filepath or None)


def menu_import(self, _context):
    self.layout.operator(MPEG4_OT_import_fap.bl_idname, text="MPEG-4 FAP (.fap)")


def menu_export(self, _context):
    self.layout.operator(MPEG4_OT_export_fap.bl_idname, text="MPEG-4 FAP (.fap)")


CLASSES = (
    MPEG4_OT_setup_face,
    MPEG4_OT_remove_face,
    MPEG4_OT_place_feature_points,
    MPEG4_OT_import_fap,
    MPEG4_OT_export_fap,
    MPEG4_OT_bake,
)
