"""The face frame read from FPs, and the checks set-up makes before it writes (no scene)."""

import sys

import numpy as np
from scipy.spatial.transform import Rotation

from addon.deform.face_checks import fused_openings, missing_fps, swapped_pairs
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.face_frame import face_frame, frame_from_fps

# a few FPs of a face in its own frame (x left, y up, z forward), metres
FACE = {
    "3.5": (0.03, 0.03, 0.0),
    "3.6": (-0.03, 0.03, 0.0),
    "4.1": (0.02, 0.05, 0.01),
    "4.2": (-0.02, 0.05, 0.01),
    "8.3": (0.025, -0.04, 0.01),
    "8.4": (-0.025, -0.04, 0.01),
    "2.1": (0.0, -0.08, 0.0),
}


def _in_mesh(frame: np.ndarray) -> dict:
    return {k: np.array(v) @ frame for k, v in FACE.items()}


def test_the_frame_comes_from_the_fps_and_snaps_to_the_mesh_axes():
    assert np.array_equal(face_frame(_in_mesh(BLENDER_FACE_AXES)), BLENDER_FACE_AXES)
    assert np.array_equal(face_frame(_in_mesh(np.eye(3))), np.eye(3))  # Y up, facing +Z: a Y-up import
    tilted = Rotation.from_euler("x", 10, degrees=True).as_matrix() @ BLENDER_FACE_AXES.T
    assert np.array_equal(face_frame(_in_mesh(tilted.T)), BLENDER_FACE_AXES)  # a nod of 10°: the mesh's axes
    turned = Rotation.from_euler("z", 45, degrees=True).as_matrix() @ BLENDER_FACE_AXES.T
    assert np.allclose(face_frame(_in_mesh(turned.T)), turned.T, atol=0.03)  # 45° off the axes: the FPs' frame
    assert frame_from_fps({"3.5": FACE["3.5"], "3.6": FACE["3.6"]}) is None  # nothing above and below


def test_a_swapped_pair_is_outvoted_and_named():
    fps = _in_mesh(BLENDER_FACE_AXES)
    fps["3.5"], fps["3.6"] = fps["3.6"], fps["3.5"]
    frame = face_frame(fps)
    assert np.array_equal(frame, BLENDER_FACE_AXES)
    assert swapped_pairs(fps, frame) == [("3.5", "3.6")]


def test_a_set_placed_in_part_is_refused_one_not_placed_is_a_warning():
    refusals, warnings = missing_fps(["8.3", "2.1"])
    assert refusals == ["FP 8.4 (for FAPU MW0 (FAP import))"]
    assert "Keep Lips Apart" in warnings[0] and "FAPU MW0" not in warnings[0]
    assert "FP 9.15 (for FAPU MNS0 (FAP import))" in missing_fps(["2.2"])[0]


def _grid(slit: bool):
    """A 9 x 5 grid of 1 cm squares, cut open along the middle row's inner edges when `slit`."""
    xs, ys = np.meshgrid(np.arange(9) * 0.01, np.arange(5) * 0.01)
    rest = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(45)])
    edges = [(r * 9 + c, r * 9 + c + 1) for r in range(5) for c in range(8)]
    edges += [(r * 9 + c, (r + 1) * 9 + c) for r in range(4) for c in range(9) if not (slit and r == 2 and 0 < c < 8)]
    return rest, np.array(edges)


def test_fused_lips_are_found_by_the_path_round_the_opening():
    fps = {"2.2": (0.04, 0.03, 0.0), "2.3": (0.04, 0.02, 0.0), "2.4": (0.08, 0.025, 0.0), "2.5": (0.0, 0.025, 0.0)}
    fps = {k: np.array(v) for k, v in fps.items()}
    assert fused_openings(*_grid(slit=False), fps) == ["lips (FP 2.2, 2.3)"]
    assert fused_openings(*_grid(slit=True), fps) == []


def test_loose_pieces_are_the_same_without_scipy(monkeypatch):
    """Where a platform has no scipy wheel, the numpy hooking finds the same pieces as scipy's components."""
    from addon.deform.loose_parts import loose_parts

    rng = np.random.default_rng(0)
    for n in (1, 12, 300, 4000):
        edges = rng.integers(0, n, size=(n // 2 + 1, 2))
        with_scipy = loose_parts(n, edges)
        monkeypatch.setitem(sys.modules, "scipy", None)
        without = loose_parts(n, edges)
        monkeypatch.undo()
        # the same partition: each label of one names exactly one label of the other
        pairs = np.unique(np.stack([with_scipy, without], axis=1), axis=0)
        assert len(pairs) == len(np.unique(with_scipy)) == len(np.unique(without))
    chain = np.array([[0, 1], [1, 2], [4, 5]])
    monkeypatch.setitem(sys.modules, "scipy", None)
    labels = loose_parts(7, chain)
    assert labels[0] == labels[1] == labels[2] and labels[4] == labels[5]
    assert len({labels[0], labels[3], labels[4], labels[6]}) == 4
    assert labels[0] == 0  # numbered from the largest piece down
