"""Elastic Bones (`addon.elastic`) on the accuracy benchmark's sample face, with the `METHODS` interface
(`evaluate(control_positions, out=None)`), so `scripts/bench/evaluate.py --method elastic_bones` scores it.

The skeleton is placed on all the face's FP empties, the skin weights come from the head's edges and its
lip and eyelid vertex groups, and each evaluation drives the engine by the control FPs' motion. As the add-on
plays it (Unfold Skin on, its default), Unfold Skin's membrane then opens the skinned faces turned over
(`addon.elastic.membrane`, a played frame's budget); `unfold_skin=False` gives the paper's engine alone.
"""

from __future__ import annotations

import bpy
import numpy as np

from addon.blender.face_data import mesh_edges
from addon.deform import unfold
from addon.elastic.membrane import skin_unfolded
from addon.elastic.parameters import TRAINED, Parameters
from addon.elastic.pose import pose_from_fps
from addon.elastic.skeleton import place_skeleton
from addon.elastic.skinning import blended_matrices, linear_blend_skinning, skin_weights


def fp_empties(head: bpy.types.Object) -> dict[str, np.ndarray]:
    """FP id -> (3,) position of every `FP <id>` empty of the head (head-local, as evaluate reads them)."""
    return {
        obj["mpeg4_fp"]: np.array(obj.location, dtype=np.float64)
        for obj in bpy.data.collections[f"{head.name} FPs"].objects
        if obj.type == "EMPTY" and "mpeg4_fp" in obj
    }


class ElasticBonesMethod:
    """The engine bound to the sample face (an evaluate.SampleFace) with the given parameters."""

    def __init__(self, face, params: Parameters = TRAINED, unfold_skin: bool = True):
        self.rest = face.rest
        self.fp_ids = face.fp_ids
        self.rest_fps = fp_empties(face.head)
        self.skeleton = place_skeleton(self.rest_fps)
        self.weights = skin_weights(face.rest, mesh_edges(face.head.data), self.skeleton, face.vertex_masks)
        self.params = params
        self.skin = unfold.prepare(face.rest, face.fans[0]) if unfold_skin else None

    def moved_fps(self, control_positions: np.ndarray) -> dict[str, np.ndarray]:
        return dict(zip(self.fp_ids, np.asarray(control_positions, dtype=np.float64), strict=True))

    def evaluate(self, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        transforms = pose_from_fps(self.skeleton, self.rest_fps, self.moved_fps(control_positions), self.params)
        deformed = self.skin_with(transforms)
        if out is None:
            return deformed
        out[...] = deformed
        return out

    def skin_with(self, transforms: np.ndarray) -> np.ndarray:
        """(N, 3) the face skinned by (B, 4, 4) transforms (eq. 1), its folds opened when Unfold Skin is on."""
        if self.skin is None:
            return linear_blend_skinning(self.rest, self.weights, transforms)
        matrices = blended_matrices(self.weights, transforms)
        return skin_unfolded(self.skin, matrices, unfold.frame_steps(len(self.rest))).deformed
