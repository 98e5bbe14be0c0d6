"""The one place where errors become reports, and a progress indicator that always ends.

An `Mpeg4Error` (a bad .fap file, missing feature points, a failed bind) carries a message written for
the user: operators report it and return CANCELLED; property callbacks, handlers and modal steps,
which have no operator to report through, put it in the face's status line (shown in the panel) and
the console. Anything else is a bug: it is logged with its traceback and reported as an internal error
(or re-raised when `RAISE_UNEXPECTED` is set, which the tests do).
"""

from __future__ import annotations

import contextlib
import functools
import logging
import traceback

import bpy

from ..errors import Mpeg4Error

log = logging.getLogger(__name__)
RAISE_UNEXPECTED = False


class Mpeg4Operator:
    """Mix-in for operators: implement `run(context)` returning report lines (`Warn` lines for warnings),
    and `unavailable(context)` returning why the operator cannot run now (None when it can)."""

    @classmethod
    def unavailable(cls, context) -> str | None:
        return None

    @classmethod
    def poll(cls, context):
        reason = cls.unavailable(context)
        if reason is not None:
            cls.poll_message_set(reason)
            return False
        return True

    def execute(self, context):
        try:
            notes = self.run(context) or []
        except Mpeg4Error as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except Exception as exc:
            if RAISE_UNEXPECTED:
                raise
            log.error("%s failed:\n%s", self.bl_idname, traceback.format_exc())
            self.report({"ERROR"}, f"Internal error in {self.bl_label}: {exc} (details in the console)")
            return {"CANCELLED"}
        for note in notes:
            level = "WARNING" if isinstance(note, Warn) else "INFO"
            self.report({level}, str(note))
        return {"FINISHED"}


class Warn(str):
    """A report line the user should act on: reported as WARNING, not INFO."""


def report_outside_operator(face, exc: BaseException) -> None:
    """Report an error met in a property callback, handler or modal step (no operator to report through)."""
    if isinstance(exc, Mpeg4Error):
        message = str(exc)
        log.warning("%s: %s", getattr(face, "name", "?"), message)
    else:
        if RAISE_UNEXPECTED:
            raise exc
        message = f"Internal error: {exc} (details in the console)"
        log.error("%s", "".join(traceback.format_exception(exc)))
    if face is not None:
        face.mpeg4_face.status = message
    wm = bpy.context.window_manager
    if not bpy.app.background and wm is not None and wm.windows:

        def draw(menu, _context):
            menu.layout.label(text=message)

        wm.popup_menu(draw, title="MPEG-4 Face", icon="ERROR")


def property_callback(function):
    """Decorate an RNA update callback `(settings, context)` so errors become a report, not a traceback."""

    @functools.wraps(function)
    def guarded(settings, context):
        try:
            function(settings, context)
        except Exception as exc:
            report_outside_operator(settings.id_data, exc)

    return guarded


@contextlib.contextmanager
def progress(context, total: int):
    """`with progress(context, n) as step: step(i)`; the indicator ends however the block ends."""
    wm = context.window_manager if context else bpy.context.window_manager
    wm.progress_begin(0, max(total, 1))
    try:
        yield wm.progress_update
    finally:
        wm.progress_end()
