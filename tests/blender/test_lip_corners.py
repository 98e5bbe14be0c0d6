"""The lips' corners at the demo's widest mouth: the smoothed binding (`face_binding.bind_face`) keeps each vertex's
share of the motion flat at the control FPs, so the corners' small triangles do not pass through each other."""

import bpy
import numpy as np

from addon.blender import face_data, rest_shape
from addon.deform.overlaps import crossing_pairs

from .helpers import DEMO_FAP, positions, set_up_sample


def test_the_demo_crosses_nothing_at_the_lips_corners():
    head = set_up_sample()
    assert bpy.ops.mpeg4.import_fap(filepath=str(DEMO_FAP), start_frame=1) == {"FINISHED"}
    rest = rest_shape.stored_rest(head.data).astype(np.float64)
    triangles = face_data.mesh_fans(head.data)[0]
    # 6 pairs in each before, at the corners: the share falling linearly from the FP (1-3 % less of a 10 mm motion
    # on 0.5 mm triangles)
    for frame in (118, 121):
        bpy.context.scene.frame_set(frame)
        now = positions(head.data).astype(np.float64)
        assert np.linalg.norm(now - rest, axis=1).max() > 0.008  # the mouth moves
        assert len(crossing_pairs(now, triangles, np.any(now != rest, axis=1))) == 0
