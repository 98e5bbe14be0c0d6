"""Operators. Each is thin: it says when it can run (`unavailable`), gathers its inputs and calls a service."""

import os

import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, IntProperty, StringProperty
from bpy_extras import view3d_utils
from bpy_extras.io_utils import ExportHelper, ImportHelper

from ..errors import Mpeg4Error
from ..mpeg4.feature_points import FP_IDS, feature_point
from . import auto_placement, bake, binding_store, face_data, face_setup, fap_io, fp_empties, poll, sealed_mouth
from .modal_job import ModalJob
from .motion_options import GainAndClamp
from .reporting import Mpeg4Operator, report_outside_operator


class MPEG4_OT_setup_face(Mpeg4Operator, bpy.types.Operator):
    """Make the selected face follow its feature point empties: builds the control mesh, measures the face and
    turns the deformation on (run it again after editing the mesh or moving the points at rest)"""

    bl_idname = "mpeg4.setup_face"
    bl_label = "Set Up Face"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        return poll.no_face(context)

    def run(self, context):
        return face_setup.set_up(poll.face(context))


class MPEG4_OT_remove_face(Mpeg4Operator, bpy.types.Operator):
    """Take the set-up away: the face, its feature points and its animation go back to how they were before"""

    bl_idname = "mpeg4.remove_face"
    bl_label = "Remove Set-Up"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        return face_setup.remove(poll.face(context))


class MPEG4_OT_open_sealed_mouth(Mpeg4Operator, bpy.types.Operator):
    """Cut the mesh open along the crease between the lips where the mesh seals them (a scan, a sculpt, welded
    lips), from FP 2.4 to FP 2.5: asks first, and Undo takes it back. Run it before Set Up Face"""

    bl_idname = "mpeg4.open_sealed_mouth"
    bl_label = "Open Sealed Mouth"
    bl_options = {"REGISTER", "UNDO"}

    show_only: BoolProperty(
        name="Show Only",
        default=False,
        options={"SKIP_SAVE"},
        description="Select the edges the cut would follow (Tab into Edit Mode to see them) and cut nothing",
    )

    @classmethod
    def unavailable(cls, context):
        reason = poll.no_face(context)
        face = face_data.active_face(context)
        if reason is None and binding_store.is_bound(face):
            return f"{face.name} is set up: Remove Set-Up first (the cut changes the mesh), then set it up again"
        return reason

    def run(self, context):
        face = poll.face(context)
        cut = sealed_mouth.plan(face)
        if self.show_only:
            return sealed_mouth.show(face, cut)
        return sealed_mouth.cut_open(face, cut)

    def invoke(self, context, event):
        if self.show_only or context.window is None:
            return self.execute(context)
        face = poll.face(context)
        try:
            cut = sealed_mouth.plan(face)
        except Exception:  # a refusal (or a failure): `execute` plans again and reports it as every operator does
            return self.execute(context)
        return context.window_manager.invoke_confirm(
            self,
            event,
            title="Cut the Mouth Open?",
            message=f"Cut {sealed_mouth.describe(face, cut)}",
            confirm_text="Cut",
        )


def _fp_items(_self, _context):
    return [(fp_id, fp_id, feature_point(fp_id).description) for fp_id in FP_IDS]


class MPEG4_OT_place_feature_points(Mpeg4Operator, bpy.types.Operator):
    """Place feature points by clicking on the face: the header names the next point and where it goes"""

    bl_idname = "mpeg4.place_feature_points"
    bl_label = "Place Feature Points"
    bl_options = {"REGISTER", "UNDO"}

    fp_id: EnumProperty(name="Feature Point", items=_fp_items)
    location: bpy.props.FloatVectorProperty(name="Location", subtype="TRANSLATION", description="World position")
    low_confidence: BoolProperty(
        name="Low-Confidence Points",
        default=False,
        options={"SKIP_SAVE"},
        description="Walk through the points automatic placement was unsure of, instead of the missing ones",
    )

    @classmethod
    def unavailable(cls, context):
        return poll.no_face(context)

    def run(self, context):
        face = poll.face(context)
        placed = fp_empties.place(face, self.fp_id, self.location, mirror=face.mpeg4_face.use_x_mirror)
        return [f"placed {', '.join(ob.name for ob in placed)}"]

    # interactive: click on the face for each missing point in turn
    def invoke(self, context, event):
        face = face_data.active_face(context)
        if context.area is None or context.area.type != "VIEW_3D":
            self.report({"ERROR"}, "Place Feature Points works in a 3D viewport")
            return {"CANCELLED"}
        self._face_name = face.name
        if self.low_confidence:
            self._queue = auto_placement.low_confidence(face)
        else:
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
        try:
            return self._step(context, event)
        except Exception as exc:
            context.area.header_text_set(None)
            report_outside_operator(bpy.data.objects.get(self._face_name), exc)
            return {"CANCELLED"}

    def _step(self, context, event):
        if event.type in {"ESC", "RET"} and event.value == "PRESS":
            return self._finish(context)
        if event.type == "S" and event.value == "PRESS":
            self._queue.append(self._queue.pop(0))
            self._prompt(context)
            return {"RUNNING_MODAL"}
        if event.type == "LEFTMOUSE" and event.value == "PRESS":
            face = bpy.data.objects.get(self._face_name)
            if face is None:
                return self._finish(context)
            hit = self._ray_cast(context, event)
            if hit is not None:
                fp_id = self._queue.pop(0)
                placed = fp_empties.place(face, fp_id, hit, mirror=face.mpeg4_face.use_x_mirror)
                for ob in placed[1:]:
                    if ob.get(face_data.FP_PROP) in self._queue:
                        self._queue.remove(ob[face_data.FP_PROP])
                self._placed += len(placed)
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


class MPEG4_OT_import_fap(GainAndClamp, Mpeg4Operator, bpy.types.Operator, ImportHelper):
    """Import an MPEG-4 FAP stream onto the active face: keys its feature points (and head turns) in one action
    named after the file"""

    bl_idname = "mpeg4.import_fap"
    bl_label = "Import FAP Stream"
    bl_options = {"REGISTER", "UNDO", "PRESET"}

    filename_ext = ".fap"
    filter_glob: StringProperty(default="*.fap", options={"HIDDEN"})
    directory: StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE", "HIDDEN"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"SKIP_SAVE", "HIDDEN"})
    timing: EnumProperty(
        name="Timing",
        items=(
            ("STREAM", "Stream's Frame Rate", "Keep the stream's timing: its frames are resampled to the scene's fps"),
            ("SCENE", "One Frame per Frame", "Each frame of the stream becomes one scene frame"),
        ),
        default="STREAM",
    )
    start_frame: IntProperty(name="Start Frame", default=1, description="The scene frame where the stream starts")
    mode: EnumProperty(
        name="Motion",
        items=(
            (
                "REPLACE",
                "Replace",
                "The stream replaces the feature points' motion (your own animation is kept in "
                "the file and comes back on Remove)",
            ),
            ("ADD", "Add", "The stream is added on top of the existing motion, as an NLA strip"),
        ),
        default="REPLACE",
    )
    set_frame_range: BoolProperty(
        name="Extend Frame Range", default=True, description="Extend the scene's end frame to the end of the stream"
    )

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def invoke(self, context, event):
        if not self.properties.is_property_set("start_frame"):
            self.start_frame = context.scene.frame_start
        if self.filepath or self.files:  # dropped on the viewport: ask only for the options
            return context.window_manager.invoke_props_dialog(self)
        return ImportHelper.invoke(self, context, event)

    def _paths(self) -> list[str]:
        if self.files and self.directory:
            return [os.path.join(self.directory, f.name) for f in self.files if f.name]
        return [self.filepath]

    def run(self, context):
        face = poll.face(context)
        paths = self._paths()
        if len(paths) != 1:
            raise Mpeg4Error(f"import one .fap stream at a time ({len(paths)} were given)")
        options = fap_io.ImportOptions(
            start_frame=self.start_frame,
            use_stream_fps=self.timing == "STREAM",
            gain=self.gain,
            clamp=self.clamp or None,
            add=self.mode == "ADD",
            fill_partners=context.scene.mpeg4.fill_partners,
            set_frame_range=self.set_frame_range,
        )
        return fap_io.import_fap(context, face, paths[0], options)


class MPEG4_OT_export_fap(Mpeg4Operator, bpy.types.Operator, ExportHelper):
    """Write the posed or animated feature points of the active face as an MPEG-4 FAP stream"""

    bl_idname = "mpeg4.export_fap"
    bl_label = "Export FAP Stream"
    bl_options = {"REGISTER"}

    filename_ext = ".fap"
    filter_glob: StringProperty(default="*.fap", options={"HIDDEN"})
    frame_start: IntProperty(name="Start", default=-1, description="First frame (-1: the scene's)")
    frame_end: IntProperty(name="End", default=-1, description="Last frame (-1: the scene's)")

    @classmethod
    def unavailable(cls, context):
        return poll.not_set_up(context)

    def run(self, context):
        scene = context.scene
        start = scene.frame_start if self.frame_start < 0 else self.frame_start
        end = scene.frame_end if self.frame_end < 0 else self.frame_end
        return fap_io.export_fap(context, poll.face(context), self.filepath, start, end)


class MPEG4_OT_bake(ModalJob, Mpeg4Operator, bpy.types.Operator):
    """Bake the deformation over a frame range so the animation plays without this extension (Esc cancels)"""

    bl_idname = "mpeg4.bake"
    bl_label = "Bake"
    bl_options = {"REGISTER", "UNDO"}

    target: EnumProperty(
        name="Target",
        items=(
            ("SHAPE_KEYS", "Shape Keys", "One shape key per frame, keyed on and off"),
            ("POINT_CACHE", "Point Cache", "A .pc2 file next to the .blend, read by a Mesh Cache modifier"),
            (
                "ALEMBIC",
                "Point Cache and Alembic",
                "A point cache as above, then Blender's Alembic exporter writes the baked face (and the eyes, "
                "teeth and tongue that follow it) to an .abc",
            ),
        ),
    )
    filepath: StringProperty(name="Cache File", subtype="FILE_PATH", default="")
    alembic_filepath: StringProperty(
        name="Alembic File", subtype="FILE_PATH", default="", description="Empty: the cache file's name with .abc"
    )
    frame_start: IntProperty(name="Start", description="First frame to bake (not set: the scene's start)")
    frame_end: IntProperty(name="End", description="Last frame to bake (not set: the scene's end)")

    CANCELLED_MESSAGE = "Bake cancelled"

    @classmethod
    def unavailable(cls, context):
        reason = poll.not_set_up(context)
        if reason is None and not face_data.active_face(context).mpeg4_face.enabled:
            return "Turn Deform on before baking"
        return reason

    def _make_job(self, context) -> bake.Bake:
        face = poll.face(context)
        scene = context.scene
        start = self.frame_start if self.properties.is_property_set("frame_start") else scene.frame_start
        end = self.frame_end if self.properties.is_property_set("frame_end") else scene.frame_end
        frames = range(start, end + 1)
        if self.target == "SHAPE_KEYS":
            return bake.ShapeKeyBake(context, face, frames)
        return bake.PointCacheBake(
            context, face, frames, self.filepath or None, self.target == "ALEMBIC", self.alembic_filepath or None
        )

    # without a window (background mode, scripts) the whole bake at once; after a modal run its end
    def run(self, context):
        return bake.run(context, self._job or self._make_job(context))

    # in a window: a timer bakes a few frames per tick, with progress in the status bar; Esc cancels
    def invoke(self, context, event):
        if context.window is None:
            return self.execute(context)
        return self.start_job(context)

    def _progress_total(self) -> int:
        return len(self._job.frames)

    def _show_progress(self):
        job = self._job
        text = f"Baking {job.face_name}: frame {job.baked} of {len(job.frames)}   Esc: cancel"
        if job.done:
            text = f"Baking {job.face_name}: {job.finishing}"
        self._show_text(text, job.baked)


CLASSES = (
    MPEG4_OT_setup_face,
    MPEG4_OT_remove_face,
    MPEG4_OT_open_sealed_mouth,
    MPEG4_OT_place_feature_points,
    MPEG4_OT_import_fap,
    MPEG4_OT_export_fap,
    MPEG4_OT_bake,
)
