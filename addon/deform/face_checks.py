"""What a face's feature points and mesh will support, checked before set-up writes anything (no bpy).

- Missing FPs: each playback feature needs a set of FPs (`NEEDS`). A set placed in part is a mistake the
  user can fix (83 FPs placed and the pupil forgotten): set-up refuses, naming the FPs and what they are for,
  instead of finishing and failing at the first frame or the first import. A set not placed at all is the
  user's choice (a few FPs placed by clicking): a warning names what will not work.
- Swapped mirror pairs: a left FP on the face's right of its partner (the face frame's x from all the
  pairs, so one swapped pair is outvoted).
- FPs far off the surface: an FP that had to snap farther than FAR_OFF x the eye separation.
- Closed openings: the lips or an eye's lids fused in the mesh (no opening between the FPs on either side):
  the shortest path along the mesh's edges between them is about as short as the straight line, where an
  opening makes it go round a corner.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..mpeg4.feature_points import FEATURE_POINTS

LIP_GUARD_FPS = ("2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9", "8.1", "8.2")
LID_FPS = ("3.1", "3.2", "3.3", "3.4", "3.5", "3.6", "3.7", "3.8", "3.11", "3.12")
# feature -> the FPs it needs, all of them
NEEDS = {
    "FAPU ES0 (FAP import)": ("3.5", "3.6"),
    "FAPU ENS0 (FAP import)": ("3.5", "3.6", "9.15"),
    "FAPU MNS0 (FAP import)": ("9.15", "2.2"),
    "FAPU MW0 (FAP import)": ("8.3", "8.4"),
    "FAPU IRISD0 (FAP import) and the eyelids' turn over the eyes": LID_FPS,
    "Keep Lips Apart": LIP_GUARD_FPS,
}
FAR_OFF = 0.25  # x eye separation: an FP farther than this off the surface was probably put in the wrong place
# (opening, FPs on one side, FPs on the other, the FPs whose distance is the opening's width)
OPENINGS = (
    ("lips", ("2.2",), ("2.3",), ("2.4", "2.5")),
    ("left eye's lids", ("3.1",), ("3.3",), ("3.7", "3.11")),
    ("right eye's lids", ("3.2",), ("3.4",), ("3.8", "3.12")),
)
FUSED = 0.5  # a path round an opening is at least about half its width longer than the straight line


def _names(ids) -> str:
    ids = list(ids)
    return "FP " + ", ".join(ids) if len(ids) > 1 else f"FP {ids[0]}"


def missing_fps(present) -> tuple[list[str], list[str]]:
    """(refusals, warnings) for the FPs `present` (ids): a refusal per missing FP of a set placed in part, naming
    what needs it; one warning naming the features whose FPs are not placed at all."""
    present = set(present)
    needed_by, unplaced = {}, []
    for feature, ids in NEEDS.items():
        absent = [fp_id for fp_id in ids if fp_id not in present]
        if len(absent) == len(ids):
            unplaced.append(feature)
        for fp_id in absent if len(absent) < len(ids) else ():
            needed_by.setdefault(fp_id, []).append(feature)
    order = {fp.id: k for k, fp in enumerate(FEATURE_POINTS)}
    refusals = [f"FP {fp_id} (for {' and '.join(needed_by[fp_id])})" for fp_id in sorted(needed_by, key=order.get)]
    warnings = []
    if unplaced:
        warnings.append(f"without their feature points, these will not work: {'; '.join(unplaced)}")
    return refusals, warnings


def swapped_pairs(positions: Mapping[str, np.ndarray], frame: np.ndarray) -> list[tuple[str, str]]:
    """Mirror pairs (left id, right id) whose left FP lies on the face's right of its partner."""
    x = np.asarray(frame, dtype=np.float64)[0]
    swapped = []
    for fp in FEATURE_POINTS:
        if fp.side == "L" and fp.mirror and {fp.id, fp.mirror} <= positions.keys():
            if (np.asarray(positions[fp.id]) - np.asarray(positions[fp.mirror])) @ x < 0.0:
                swapped.append((fp.id, fp.mirror))
    return swapped


def far_off(placed: Mapping[str, np.ndarray], snapped: Mapping[str, np.ndarray], eye_separation: float) -> list[str]:
    """The FPs that snapped onto the surface from farther than FAR_OFF x the eye separation."""
    if not eye_separation > 0:
        return []
    return [
        fp_id
        for fp_id, p in placed.items()
        if fp_id in snapped and np.linalg.norm(np.asarray(snapped[fp_id]) - p) > FAR_OFF * eye_separation
    ]


def fused_openings(rest: np.ndarray, edges: np.ndarray, positions: Mapping[str, np.ndarray]) -> list[str]:
    """The openings (`OPENINGS`) the mesh closes: '<name> (FP a and FP b)' for each."""
    try:
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import dijkstra
    except ImportError:  # a warning only: where the platform has no scipy wheel, it is not given
        return []
    rest = np.asarray(rest, dtype=np.float64)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    if len(edges) == 0:
        return []
    length = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1)
    graph = coo_matrix((length, (edges[:, 0], edges[:, 1])), shape=(len(rest), len(rest))).tocsr()
    fused = []
    for name, side_a, side_b, across in OPENINGS:
        ids = (*side_a, *side_b, *across)
        if not set(ids) <= positions.keys():
            continue
        width = float(np.linalg.norm(np.asarray(positions[across[0]]) - positions[across[1]]))
        if joined_near(graph, rest, positions[side_a[0]], positions[side_b[0]], width, dijkstra):
            fused.append(f"{name} ({_names((side_a[0], side_b[0]))})")
    return fused


def nearest_vertices(rest: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The vertices nearest `point`: all of them where several lie at one place (a mesh cut open along a line has
    two vertices at each point of it, one for each side)."""
    distance = np.linalg.norm(rest - np.asarray(point, dtype=np.float64), axis=1)
    return np.flatnonzero(distance <= distance.min())


def joined_near(graph, rest: np.ndarray, point_a, point_b, width: float, dijkstra) -> bool:
    """`joined_over_skin` for the vertices nearest two points: joined when every vertex nearest one is joined to
    every vertex nearest the other (where a cut left two vertices at a point, one on each side, the opening
    is there)."""
    near_a, near_b = nearest_vertices(rest, point_a), nearest_vertices(rest, point_b)
    return all(joined_over_skin(graph, rest, int(a), int(b), width, dijkstra) for a in near_a for b in near_b)


def joined_over_skin(graph, rest: np.ndarray, a: int, b: int, width: float, dijkstra) -> bool:
    """Whether vertices `a` and `b` of an opening `width` wide are one surface between them: a path along the
    edges (`graph`, scipy sparse, edge lengths) at most `FUSED` x `width` longer than the straight line joins
    them. `dijkstra`: scipy's, passed in (scipy is imported where it is available)."""
    limit = float(np.linalg.norm(rest[a] - rest[b])) + FUSED * width
    return bool(dijkstra(graph, directed=False, indices=a, limit=limit)[b] <= limit)
