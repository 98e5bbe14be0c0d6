"""The one place where errors become reports, and a progress indicator that always ends.

Domain errors (a bad .fap file, missing feature points, a failed bind) carry a message written for the
user; operators catch them here and return CANCELLED with that message. Anything else is a bug: it is
logged with its traceback and reported as an internal error (or re-raised when `RAISE_UNEXPECTED` is
set, which the tests do).
"""

from __future__ import annotations

import contextlib
import logging
import traceback

import bpy

from ..deform.planar_bones import DeformError
from ..geometry.delaunay import TriangulationError
from ..mpeg4.fap_file import FapFileError
from ..mpeg4.fapu import FapuError

log = logging.getLogger(__name__)
RAISE_UNEXPECTED = False


class UserError(Exception):
    """A problem the user can fix; the message says how."""


DOMAIN_ERRORS = (UserError, FapFileError, FapuError, DeformError, TriangulationError)


class Mpeg4Operator:
    """Mix-in for operators: implement `run(context)` returning report lines; errors become reports."""

    def execute(self, context):
        try:
            notes = self.run(context) or []
        except DOMAIN_ERRORS as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        except Exception as exc:
            if RAISE_UNEXPECTED:
                raise
            log.error("%s failed:\n%s", self.bl_idname, traceback.format_exc())
            self.report({"ERROR"}, f"Internal error in {self.bl_label}: {exc} (details in the console)")
            return {"CANCELLED"}
        for note in notes:
            self.report({"INFO"}, note)
        return {"FINISHED"}


@contextlib.contextmanager
def progress(context, total: int):
    """`with progress(context, n) as step: step(i)`; the indicator ends however the block ends."""
    wm = context.window_manager if context else bpy.context.window_manager
    wm.progress_begin(0, max(total, 1))
    try:
        yield wm.progress_update
    finally:
        wm.progress_end()
