"""Place Feature Points Automatically: the operator. In a window it runs the placement a step per timer tick
with a progress bar and Esc to cancel; in the background (scripts, tests) it runs to the end at once. The
empties are made only when the placement has finished, so a cancelled or refused run leaves the file as it
was."""

import contextlib

import bpy
from bpy.props import BoolProperty

from ..errors import Mpeg4Error
from . import auto_placement, face_data, poll
from .reporting import Mpeg4Operator, progress, report_outside_operator

PROGRESS_STEPS = 100


class MPEG4_OT_auto_place_feature_points(Mpeg4Operator, bpy.types.Operator):
    """Place all 84 feature points on the active head from its shape alone (the sample head registered to
    it); the panel then lists the points it is unsure of. Esc cancels"""

    bl_idname = "mpeg4.auto_place_feature_points"
    bl_label = "Place Feature Points Automatically"
    bl_options = {"REGISTER", "UNDO"}

    move_existing: BoolProperty(
        name="Move Existing Points",
        default=False,
        description="Move the feature points already placed on this face (otherwise the operator stops and "
        "asks before moving any)",
    )

    _steps = None  # a modal run's placement generator
    _placement = None  # its result, applied by execute

    @classmethod
    def unavailable(cls, context):
        reason = poll.no_face(context)
        if reason is None and face_data.active_face(context).mpeg4_face.control_object is not None:
            return "The face is set up: Remove Set-Up first, then place its points again"
        return reason

    def _start(self, context):
        """Validate before anything changes, then the placement's step generator."""
        from ..placement.pipeline import placement_steps  # scipy: a missing wheel is a report, not a failed load

        face = poll.face(context)
        placed = face_data.fp_empties(face)
        if placed and not self.move_existing:
            raise Mpeg4Error(
                f"{face.name} already has {len(placed)} feature points: tick Move Existing Points (in the "
                "operator's redo panel) to move them"
            )
        vertices, triangles = auto_placement.world_arrays(auto_placement.head_objects(context, face))
        return placement_steps(vertices, triangles)

    def run(self, context):
        face = poll.face(context)
        placement = self._placement
        if placement is None:
            steps = self._start(context)
            while placement is None:
                try:
                    next(steps)
                except StopIteration as done:
                    placement = done.value
        self._placement = None
        return auto_placement.apply(face, placement)

    def invoke(self, context, event):
        if context.window is None:
            return self.execute(context)
        face = face_data.active_face(context)
        if face is not None and face_data.fp_empties(face) and not self.move_existing:
            self.move_existing = True
            return context.window_manager.invoke_confirm(
                self,
                event,
                title="Move Existing Feature Points?",
                message=f"{face.name} already has feature points: automatic placement moves all 84",
                confirm_text="Place Automatically",
            )
        return self._begin_modal(context)

    def _begin_modal(self, context):
        try:
            self._steps = self._start(context)
        except Exception as exc:
            report_outside_operator(face_data.active_face(context), exc)
            return {"CANCELLED"}
        self._face_name = face_data.active_face(context).name
        wm = context.window_manager
        self._ui = contextlib.ExitStack()
        self._update = self._ui.enter_context(progress(context, PROGRESS_STEPS))
        timer = wm.event_timer_add(0.01, window=context.window)
        self._ui.callback(wm.event_timer_remove, timer)
        self._ui.callback(context.workspace.status_text_set, None)
        context.workspace.status_text_set(f"Placing feature points on {self._face_name}   Esc: cancel")
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self.cancel(context)
            self.report({"WARNING"}, "Automatic placement cancelled: nothing was placed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            fraction = next(self._steps)
        except StopIteration as done:
            self._ui.close()
            self._placement = done.value
            return self.execute(context)
        except Exception as exc:
            self.cancel(context)
            report_outside_operator(bpy.data.objects.get(self._face_name), exc)
            return {"CANCELLED"}
        self._update(int(fraction * PROGRESS_STEPS))
        return {"RUNNING_MODAL"}

    def cancel(self, context):
        self._ui.close()
        self._steps = None


CLASSES = (MPEG4_OT_auto_place_feature_points,)
