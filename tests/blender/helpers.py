"""Shared steps for the Blender tests: open the sample, set it up, read meshes."""

from pathlib import Path

import bpy
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_blends" / "makehuman_head.blend"
DEMO_FAP = ROOT / "sample_blends" / "demo.fap"


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
