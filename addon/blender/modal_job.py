"""Long work in a window: a job stepped by a timer, with progress in the status bar, Esc to cancel.

An operator mixes in `ModalJob` and gives `_make_job(context)` (checks everything, changes nothing),
`_progress_total()` (the progress bar's length) and `_show_progress()` (the status text and the bar, through
`_show_text`, from `self._job`); its `run` finishes `self._job`
(or, without a window, makes and runs a job at once). A job has `face_name`, `done`, `step()` (a little of the
work), and `cancel()` (takes back what it did). `start_job` starts the timer; when the job is done the next
tick ends the run through the operator's `execute`, so it reports like any run.
"""

from __future__ import annotations

import contextlib
import time

import bpy

from . import face_data
from .reporting import progress, report_outside_operator

NAVIGATION_EVENTS = {
    "MOUSEMOVE",
    "INBETWEEN_MOUSEMOVE",
    "MIDDLEMOUSE",
    "WHEELUPMOUSE",
    "WHEELDOWNMOUSE",
    "TRACKPADPAN",
    "TRACKPADZOOM",
}


class ModalJob:
    TICK_SECONDS = 0.1  # work per timer tick: as much as fits, so the window stays responsive
    CANCELLED_MESSAGE = "Cancelled"
    _job = None  # the job a modal run steps

    def start_job(self, context):
        """Make the job and step it from a timer."""
        try:
            self._job = self._make_job(context)
        except Exception as exc:
            report_outside_operator(face_data.active_face(context), exc)
            return {"CANCELLED"}
        wm = context.window_manager
        self._ui = contextlib.ExitStack()
        self._update = self._ui.enter_context(progress(context, self._progress_total()))
        timer = wm.event_timer_add(0.01, window=context.window)
        self._ui.callback(wm.event_timer_remove, timer)
        self._texts = [context.workspace.status_text_set]
        if context.area is not None:
            self._texts.append(context.area.header_text_set)
        for show in self._texts:
            self._ui.callback(show, None)
        self._show_progress()
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _show_text(self, text: str, done: int) -> None:
        for show in self._texts:
            show(text)
        self._update(done)

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self.cancel(context)
            self.report({"WARNING"}, self.CANCELLED_MESSAGE)
            return {"CANCELLED"}
        if event.type in NAVIGATION_EVENTS:
            return {"PASS_THROUGH"}
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}  # nothing else: the scene must not change under the job
        job = self._job
        if job.done:  # a tick after the last step, so the window says what happens meanwhile
            self._ui.close()
            return self.execute(context)  # stores the result and reports like any run
        try:
            deadline = time.perf_counter() + self.TICK_SECONDS
            job.step()
            while not job.done and time.perf_counter() < deadline:
                job.step()
        except Exception as exc:
            self.cancel(context)
            report_outside_operator(bpy.data.objects.get(job.face_name), exc)
            return {"CANCELLED"}
        self._show_progress()
        return {"RUNNING_MODAL"}

    def cancel(self, context):
        """Esc, an error, or Blender ending the operator (a file loaded): the job is taken back."""
        self._ui.close()
        self._job.cancel()
