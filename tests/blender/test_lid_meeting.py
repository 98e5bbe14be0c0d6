"""A full blink on the sample head: the lids meet along the whole eye and no part of one passes through the other
(`eyelids.meet_lids`), and a viewer sees no opening between them (`overlaps.seen_lid_gap`; docs/eyes_brows.md)."""

import dataclasses

import bpy
import numpy as np

from addon.blender import eyelid_rig, face_data, live
from addon.deform.overlaps import crossing_pairs, edge_chain, lid_gap, seen_lid_gap

from .helpers import positions, set_up_sample

LIDS = ((("3.11", "3.1", "3.7"), ("3.11", "3.3", "3.7")), (("3.8", "3.2", "3.12"), ("3.8", "3.4", "3.12")))


def closed_eyes(head) -> np.ndarray:
    """The head's positions with each upper mid-lid FP moved onto the lower one (then put back)."""
    empties = face_data.fp_empties(head)
    rests = {fp_id: empties[fp_id].location.copy() for fp_id in ("3.1", "3.2")}
    empties["3.1"].location = empties["3.3"].location
    empties["3.2"].location = empties["3.4"].location
    bpy.context.view_layer.update()
    live.apply_face(head, force=True)
    closed = positions(head.data).astype(np.float64)
    for fp_id, location in rests.items():
        empties[fp_id].location = location
    bpy.context.view_layer.update()
    return closed


def test_a_full_blink_closes_the_lids_without_one_passing_through_the_other():
    head = set_up_sample()
    rest = positions(head.data).astype(np.float64)
    triangles = face_data.mesh_fans(head.data)[0]
    empties = face_data.fp_empties(head)
    every = np.arange(len(rest))
    chains = [
        [edge_chain(rest, every, np.array([empties[f].location for f in line]), 24) for line in lids] for lids in LIDS
    ]
    closed = closed_eyes(head)
    assert len(crossing_pairs(closed, triangles, np.any(closed != rest, axis=1))) == 0
    gaps = [lid_gap(closed, upper, lower) for upper, lower in chains]
    rest_gaps = [lid_gap(rest, upper, lower) for upper, lower in chains]
    assert min(rest_gaps) > 0.009  # 9.15 mm open at rest
    assert max(gaps) < 0.0017  # 1.67 mm at most over the middle half between the edge chains (the margins' back edges)
    # what a viewer sees: nothing of the eye straight on, at most 0.5 mm from 30 degrees below (the upper lid closes
    # in front of the lower one, 0.6-1.4 mm apart in depth)
    rig = eyelid_rig._rigs[head.session_uid][1]
    for e, (inner, outer, pupil) in enumerate((("3.11", "3.7", "3.5"), ("3.8", "3.12", "3.6"))):
        centre = rig.centres[e] @ rig.axes
        radius = np.linalg.norm(np.array(empties[pupil].location) - centre)
        for pitch, seen in ((0.0, 1e-9), (-30.0, 0.0005)):
            a = np.radians(pitch)
            axes = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]]) @ rig.axes
            corners = tuple((np.array([empties[inner].location, empties[outer].location]) - centre) @ axes[0])
            assert seen_lid_gap(rest, triangles, centre, radius, axes, corners) > 0.004  # open at rest
            assert seen_lid_gap(closed, triangles, centre, radius, axes, corners) <= seen
    # the lids stopped only under the mid-lid FPs (as before `meet_lids`): rows behind the upper margin near the
    # inner corner pass through the lower lid
    eyelid_rig._rigs[head.session_uid] = (eyelid_rig._rigs[head.session_uid][0], dataclasses.replace(rig, meeting=None))
    crossed = closed_eyes(head)
    assert len(crossing_pairs(crossed, triangles, np.any(crossed != rest, axis=1))) == 46
