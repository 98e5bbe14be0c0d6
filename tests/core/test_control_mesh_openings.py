"""Openings and the fallback control mesh over the FPs present."""

import numpy as np

from addon.mpeg4.control_mesh import spans_opening, triangle_mask, triangulate_present


def face_point(x, z, radius=0.1):
    """A point on a sphere about the origin, on the face side (-Y), Blender frame."""
    return np.array([x, -np.sqrt(radius**2 - x * x - z * z), z])


LAYOUT = {  # face-frame x (left) and height, metres
    "2.1": (0, -0.08),
    "2.10": (0, -0.065),
    "2.2": (0, -0.045),
    "2.3": (0, -0.045),
    "2.4": (0.022, -0.046),
    "2.5": (-0.022, -0.046),
    "8.1": (0, -0.038),
    "8.2": (0, -0.055),
    "8.3": (0.026, -0.046),
    "8.4": (-0.026, -0.046),
    "9.15": (0, -0.025),
    "9.3": (0, -0.012),
    "3.1": (0.032, 0.026),
    "3.3": (0.032, 0.014),
    "3.7": (0.045, 0.02),
    "3.11": (0.018, 0.02),
    "3.2": (-0.032, 0.026),
    "3.4": (-0.032, 0.014),
    "3.12": (-0.045, 0.02),
    "3.8": (-0.018, 0.02),
    "4.1": (0.015, 0.04),
    "4.2": (-0.015, 0.04),
    "5.1": (0.05, -0.03),
    "5.2": (-0.05, -0.03),
    "11.1": (0, 0.07),
}


def test_opening_rules():
    assert spans_opening(["2.2", "2.3", "2.4"]) and spans_opening(["3.1", "3.3", "3.7"])
    assert not spans_opening(["2.2", "2.4", "8.3"]) and not spans_opening(["3.1", "3.7", "3.11"])
    assert triangle_mask(["8.1", "8.3", "2.2"]) == "upper_lip" and triangle_mask(["2.1", "2.10", "5.1"]) is None
    assert triangle_mask(["3.4", "3.8", "3.12"]) == "lower_eyelid"


def test_fallback_triangulation_keeps_closed_lips_apart_and_faces_out():
    positions = {k: face_point(*v) for k, v in LAYOUT.items()}  # 2.2 and 2.3 coincide: closed lips
    ids, tris, masks = triangulate_present(positions, centre=np.zeros(3))
    assert set(ids) == set(LAYOUT) and len(tris) > 20
    named = [[ids[k] for k in t] for t in tris]
    assert not any(spans_opening(t) for t in named)
    assert {"2.2", "2.3"} <= {fp for t in named for fp in t}  # both kept, on their own sides
    pts = np.array([positions[i] for i in ids])
    normals = np.cross(pts[tris[:, 1]] - pts[tris[:, 0]], pts[tris[:, 2]] - pts[tris[:, 0]])
    centroids = pts[tris].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", normals, centroids) > 0)  # outward, away from the head's centre
    assert masks == [triangle_mask(t) for t in named]
