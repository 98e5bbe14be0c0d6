"""Unfold Skin: a check after every deformation that smooths out faces turned over against the rest pose.

No deformer here is fold-free by construction. Planar Bones interpolates each control triangle's corners
(eq. 1), so where a feature point passes the line of two others the control triangle, and the skin it carries,
turns over (the lip corner rising past the nose wing and the cheek point in a full smile); where the control
mesh ends, the fade to rest (`planar_bones`, ``fade_below``) can be steeper than the skin's faces are wide
(under the chin with the jaw open); at 17k and 68k vertices the eyelids' fold-free weights stop short of their
limits in places. The Planar Bones paper does not treat fold-overs. This pass repairs them in the output:

1. find the turned-over faces: the triangles of the faces' fans whose deformed normal points against the rest
   one (`folds.inverted_faces`' test; a triangle of zero area at rest never counts);
2. smooth the displacement u = deformed − rest over the vertices of those triangles and the ``rings`` rings
   of edges around them, the rest of the mesh held: ``CHECK_EVERY`` Jacobi steps
   u_i ← u_i + λ (Σ_j w_ij u_j − u_i), λ = ``STEP``, with w_ij Floater's mean value weights of i's neighbours
   at rest (`mean_value_weights`; positive, summing to 1). A membrane: where the displacement is linear in the
   rest positions (a flat star) a step changes nothing, on any mesh. The plain mean of the neighbours (w_ij =
   1/degree) has that only on a regular mesh: on an irregular one it moves a linear displacement itself, and
   where a fold compresses the skin those moves turned other triangles over (a subdivided face with its new
   vertices jittered, the lips at demo frame 120: 565 steps over 3,645 vertices with the plain mean, the fold
   spreading to 78 triangles on the way; 25 steps over 12 vertices with these weights). With ``MOMENTUM`` each
   step is taken from Nesterov's look-ahead point y = x + k / (k + 3) (x − x_last) instead of x (Nesterov 1983;
   k counts the steps since the momentum last started again, which it does whenever the region takes in a vertex
   it did not have, that vertex having no last step). A fold that needs its region grown by many rings needs the
   change carried far, which plain Jacobi steps do in about the square of the distance: the Lee Perry-Smith
   scan's sealed lip line in the demo (frames 16-24, a frame's first opening) took 515-655 steps over 2,400-3,200
   vertices, with the momentum 340-375 over 1,130-1,140 (3.5-5.0x fewer vertex-steps); without the restarts,
   1,410-1,565 steps over all 8,838. The momentum lives within one call, so a frame still depends on its own
   positions alone;
3. look again; stop once no triangle is turned over, or after ``MAX_STEPS`` steps (what is left then stays, and
   where the steps have not left fewer triangles turned over than they found, the positions stay as they were
   found: the subdivided variant's lip fold, 25 faces, became 65 when a frame's budget ended mid-way).
   When the count has not fallen for ``STALL_CHECKS`` looks the region widens by one ring: a control triangle
   that turned over carries a fold several faces wide, which a one-ring membrane cannot open;
4. keep only the least share s of that change (deformed + s (opened − deformed) at the moved vertices) that
   leaves no triangle there turned over or within ``MARGIN`` of it, found by ``BISECTIONS`` halvings of
   [0, 1] on the positions as they will be stored (float32 in the add-on).

Step 4 makes the repair as small as the fold: the membrane's whole change does not shrink as a fold does (its
first steps smooth the sharp lip corner by millimetres whether the fold there is a hair or a face wide), so a
smile growing past the point where its corner skin starts to fold would lose millimetres of its corner in one
frame; the least share grows from 0 as the fold does (mouth-corner-puller: the corner kept within 0.3 mm at
its size, 4 mm at 1.5 times it, against 6 and 11 mm with the whole change). Only vertices near a fold move. A
frame without folds is left exactly as it was. The result depends on that frame's positions alone (no state
between frames), so a render farm's frames agree with the viewport's.

`unfold` is the reference; `fused.unfold` runs the same steps in the same order in the compiled kernel (equal
to it bit for bit, `tests/core/test_unfold.py`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import fused
from .inputs import DeformError, check_points

STEP = 0.5  # λ of a Jacobi step: half way to the neighbours' mean (the damped Jacobi of a membrane)
MOMENTUM = True  # each step taken from Nesterov's look-ahead point, restarted where the region grows (step 2)
CHECK_EVERY = 5  # steps between looks at the folds
STALL_CHECKS = 4  # looks without fewer folds before the region widens by a ring
GUARD_ROUNDS = 6  # a guard and the membrane taking turns after a frame's first unfold (`open_folds_guarded`), at most
MAX_STEPS = 2000  # at most this many steps a frame (a frame it cannot open keeps what is left)
# The add-on's per-frame budget (`frame_steps`): a step costs about as much as the vertices it smooths, and a fold
# covers more vertices the finer the mesh, so the steps a frame may take shrink as the mesh grows; a fold left open
# when the budget ends stays that frame (a render of that frame shows it too: the budget is a count, not a time).
FRAME_WORK = 4_000_000  # vertex-steps: MAX_STEPS on a face of up to 2000 vertices, 75 steps at 53k
MIN_FRAME_STEPS = 50
BISECTIONS = 16  # halvings in the search for the least share of the membrane's change (to 1.5e-5)
MARGIN = 1e-6  # a triangle the least share leaves must keep this much of its rest (doubled area)², as dot n·n


@dataclass(frozen=True, eq=False)
class SkinMesh:
    """What `unfold` needs of a mesh, made once from its rest pose (`prepare`)."""

    rest: np.ndarray  # (N, 3) float64
    triangles: np.ndarray  # (K, 3) int32: the faces' fans
    rest_normals: np.ndarray  # (K, 3) float64: (b − a) × (c − a) at rest, unnormalised
    neighbour_start: np.ndarray  # (N + 1,) int32: vertex i's neighbours are neighbours[start[i]:start[i + 1]]
    neighbours: np.ndarray  # (E,) int32, ascending within each vertex
    weights: np.ndarray  # (E,) float64: each neighbour's share of the vertex's mean (`mean_value_weights`)
    corner_start: np.ndarray  # (N + 1,) int32: the triangles at vertex i are corner_triangles[start[i]:start[i + 1]]
    corner_triangles: np.ndarray  # (3K,) int32

    @property
    def n_vertices(self) -> int:
        return len(self.rest)

    @functools.cached_property
    def padded(self) -> np.ndarray:
        """(N, D) int32: the neighbours padded with N (a row of zeros), for the numpy sums; made when the numpy
        path first needs it (the kernel reads the neighbour lists)."""
        degree = np.diff(self.neighbour_start)
        padded = np.full((self.n_vertices, max(int(degree.max(initial=0)), 1)), self.n_vertices, np.int32)
        padded[self._slots] = self.neighbours
        return padded

    @functools.cached_property
    def padded_weights(self) -> np.ndarray:
        """(N, D) float64: the weights in `padded`'s places, 0 in its padding."""
        weights = np.zeros(self.padded.shape)
        weights[self._slots] = self.weights
        return weights

    @functools.cached_property
    def _slots(self) -> tuple[np.ndarray, np.ndarray]:
        """Each neighbour entry's (row, column) in `padded`."""
        degree = np.diff(self.neighbour_start)
        column = np.arange(len(self.neighbours)) - np.repeat(self.neighbour_start[:-1], degree)
        return np.repeat(np.arange(self.n_vertices), degree), column

    @functools.cached_property
    def work(self) -> np.ndarray:
        """The compiled kernel's work space on this mesh (`fused.unfold`), zeroed once and kept between calls (empty
        where the kernel is unavailable)."""
        return np.zeros(fused.unfold_work_bytes(self.n_vertices, len(self.triangles)), np.uint8)


def prepare(rest: np.ndarray, triangles: np.ndarray) -> SkinMesh:
    """A `SkinMesh` for (N, 3) rest positions and (K, 3) triangles (a mesh's fans, `folds.fan_triangles`)."""
    rest = check_points(rest, "rest")
    n = len(rest)
    triangles = np.asarray(triangles).reshape(-1, 3)
    if triangles.size and (triangles.min() < 0 or triangles.max() >= n):
        raise DeformError(f"triangle indices must lie in [0, {n})")
    triangles = triangles.astype(np.int32)
    a, b, c = (rest[triangles[:, k]] for k in range(3))
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]).astype(np.int64)
    keys = np.unique(np.concatenate([edges[:, 0] * n + edges[:, 1], edges[:, 1] * n + edges[:, 0]]))
    edges = np.stack(np.divmod(keys, max(n, 1)), axis=1)  # sorted by vertex, then neighbour
    edges = edges[edges[:, 0] != edges[:, 1]]
    start = np.searchsorted(edges[:, 0], np.arange(n + 1)).astype(np.int32)
    corners = triangles.reshape(-1).astype(np.int64)
    order = np.argsort(corners, kind="stable")
    neighbours = edges[:, 1].astype(np.int32)
    return SkinMesh(
        rest=rest,
        triangles=triangles,
        rest_normals=np.cross(b - a, c - a),
        neighbour_start=start,
        neighbours=neighbours,
        weights=mean_value_weights(rest, triangles, start, neighbours),
        corner_start=np.searchsorted(corners[order], np.arange(n + 1)).astype(np.int32),
        corner_triangles=(order // 3).astype(np.int32),
    )


def mean_value_weights(
    rest: np.ndarray, triangles: np.ndarray, neighbour_start: np.ndarray, neighbours: np.ndarray
) -> np.ndarray:
    """(E,) each vertex's weights of its neighbours (in `SkinMesh.neighbours`' order), summing to 1 per vertex:
    Floater's mean value coordinates (Floater 2003, eq. 2.1, w_j = (tan(α_{j−1}/2) + tan(α_j/2)) / |v_j − v_0|),
    summed over the triangles at vertex i, each adding tan(α/2) / |x_j − x_i| to both of its other corners j, with
    α its angle at i. Every α lies in (0, π), so every weight is positive; a vertex of a flat star is the weighted
    mean of its neighbours' rest positions, so a displacement linear in them is its own mean. A vertex whose
    triangles are all degenerate (a weight not finite, or none above 0) takes the plain mean."""
    n = len(rest)
    row = np.repeat(np.arange(n, dtype=np.int64), np.diff(neighbour_start))
    keys = row * n + neighbours
    weights = np.zeros(len(neighbours))
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(3):
            at, one, other = triangles[:, k], triangles[:, (k + 1) % 3], triangles[:, (k + 2) % 3]
            u, v = rest[one] - rest[at], rest[other] - rest[at]
            lu, lv = np.linalg.norm(u, axis=1), np.linalg.norm(v, axis=1)
            half = np.linalg.norm(np.cross(u, v), axis=1) / (lu * lv + np.einsum("ij,ij->i", u, v))  # tan(α/2)
            for corner, length in ((one, lu), (other, lv)):
                real = at != corner  # a triangle with a repeated corner has no edge there
                edge = np.searchsorted(keys, at[real].astype(np.int64) * n + corner[real])
                np.add.at(weights, edge, (half / length)[real])
    total = np.bincount(row, weights, n)
    good = np.isfinite(total) & (total > 0.0)
    good &= np.bincount(row, ~np.isfinite(weights), n) == 0
    degree = np.diff(neighbour_start).astype(np.float64)
    return np.where(good[row], weights / np.where(good, total, 1.0)[row], 1.0 / np.maximum(degree, 1.0)[row])


def turned_over(mesh: SkinMesh, points: np.ndarray) -> np.ndarray:
    """(K,) True for the triangles whose normal at (N, 3) float64 `points` points against the rest one."""
    return _turned(mesh.triangles, mesh.rest_normals, points)


def _turned(t: np.ndarray, n: np.ndarray, points: np.ndarray) -> np.ndarray:
    """`turned_over` for the triangles `t` with rest normals `n`."""
    return _dots(t, n, points) < 0.0


def _dots(t: np.ndarray, n: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(b − a) × (c − a) · n for the triangles `t` at `points`, with rest normals `n`."""
    a, b, c = points[t[:, 0]], points[t[:, 1]], points[t[:, 2]]
    u, v = b - a, c - a
    # the dot product with the rest normal of (b − a) × (c − a), written out in the kernel's order
    dot = (u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]) * n[:, 0]
    dot += (u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]) * n[:, 1]
    dot += (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) * n[:, 2]
    return dot


def _grow(mesh: SkinMesh, region: np.ndarray) -> np.ndarray:
    """`region` (N,) bool and every neighbour of its vertices."""
    grown = region.copy()
    grown[_rows(mesh.neighbour_start, mesh.neighbours, np.flatnonzero(region))] = True
    return grown


def _rows(start: np.ndarray, values: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """values[start[r]:start[r + 1]] for each of `rows`, one after the other (a CSR list's rows)."""
    first, stop = start[rows], start[rows + 1]
    counts = stop - first
    offsets = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    return values[np.repeat(first, counts) + offsets]


@dataclass(frozen=True)
class Unfolded:
    """What one `unfold` did."""

    moved: np.ndarray  # (V,) int32: the vertices it may have moved, ascending
    steps: int  # Jacobi steps made
    left: int  # triangles still turned over (0: the frame is fold-free)
    share: float = 1.0  # how much of the membrane's change was kept (step 4)


def unfold(
    mesh: SkinMesh,
    positions: np.ndarray,
    max_steps: int = MAX_STEPS,
    start: np.ndarray | None = None,
    momentum: bool | None = None,
) -> Unfolded:
    """Open the folds of the (N, 3) deformed `positions` (float32 or float64), in place. With `start` (vertex
    indices), whose caller vouches that every turned-over triangle has a corner among them, only the triangles at
    those vertices and at the vertices the membrane moves are looked at (the compiled kernel's cost then follows the
    folds, not the mesh)."""
    if positions.shape != mesh.rest.shape:
        raise DeformError(f"positions have shape {positions.shape}, the mesh {mesh.rest.shape}")
    momentum = MOMENTUM if momentum is None else momentum
    points = positions.astype(np.float64)
    watched = None if start is None else _at_vertices(mesh, np.asarray(start, dtype=np.int64))
    bad = _watched_turned(mesh, points, watched)
    count = found = int(np.count_nonzero(bad))
    if count == 0:
        return Unfolded(np.zeros(0, np.int32), 0, 0)
    n = mesh.n_vertices
    rest = mesh.rest
    degree = np.diff(mesh.neighbour_start)
    moved = np.zeros(n, bool)
    displacement = np.zeros((n + 1, 3))  # the padding's row n stays 0
    last = np.zeros((n, 3))  # each region vertex's position before the last step (the momentum's)
    before = np.zeros(n, bool)  # the last batch's region
    rings, steps, best, stall, since = 1, 0, count, 0, 0
    while count and steps < max_steps:
        region = np.zeros(n, bool)
        region[mesh.triangles[bad].reshape(-1)] = True
        for _ in range(rings):
            region = _grow(mesh, region)
        region &= degree > 0
        if np.any(region & ~before):  # the region grew: the momentum starts again
            since = 0
        before = region
        moved |= region
        if watched is not None:
            watched |= _at_vertices(mesh, np.flatnonzero(region))
        inside = np.flatnonzero(region)
        padded, weights = mesh.padded[inside], mesh.padded_weights[inside]
        for _ in range(min(CHECK_EVERY, max_steps - steps)):
            if momentum:  # the step from y = x + β (x − x_last), β = k / (k + 3) after k steps since the restart
                ahead = points[inside]
                if since:
                    ahead = ahead + since / (since + 3) * (ahead - last[inside])
                last[inside] = points[inside]
                points[inside] = ahead
                since += 1
            displacement[:n] = points - rest
            total = weights[:, :1] * displacement[padded[:, 0]]
            for column in range(1, padded.shape[1]):
                total += weights[:, column : column + 1] * displacement[padded[:, column]]
            points[inside] += STEP * (total - displacement[inside])
            steps += 1
        bad = _watched_turned(mesh, points, watched)
        count = int(np.count_nonzero(bad))
        if count < best:
            best, stall = count, 0
        else:
            stall += 1
            if stall >= STALL_CHECKS:
                rings, stall = rings + 1, 0
    if count >= found:  # the budget ended with no fewer turned over: leave the frame as it came
        return Unfolded(np.zeros(0, np.int32), steps, found)
    where = np.flatnonzero(moved).astype(np.int32)
    share = 1.0
    if count == 0:
        points, share = _least_share(mesh, positions, points, where)
    positions[where] = points[where]
    return Unfolded(where, steps, count, share)


def _at_vertices(mesh: SkinMesh, vertices: np.ndarray) -> np.ndarray:
    """(K,) True for the triangles with a corner among `vertices`."""
    at = np.zeros(len(mesh.triangles), bool)
    at[_rows(mesh.corner_start, mesh.corner_triangles, vertices)] = True
    return at


def _watched_turned(mesh: SkinMesh, points: np.ndarray, watched: np.ndarray | None) -> np.ndarray:
    """`turned_over`, among the `watched` triangles alone where given."""
    bad = turned_over(mesh, points)
    return bad if watched is None else bad & watched


def _least_share(mesh: SkinMesh, start: np.ndarray, opened: np.ndarray, where: np.ndarray) -> tuple[np.ndarray, float]:
    """The least share s of the membrane's change (start + s (opened − start) at the moved vertices `where`, in
    the positions' own precision) that leaves no triangle at them turned over or within ``MARGIN`` of it, by
    ``BISECTIONS`` halvings; (the positions, s), s = 1 where no smaller share is found."""
    corners = np.isin(mesh.triangles, where).any(axis=1)
    triangles, normals = mesh.triangles[corners], mesh.rest_normals[corners]
    limit = MARGIN * (normals[:, 0] * normals[:, 0] + normals[:, 1] * normals[:, 1] + normals[:, 2] * normals[:, 2])
    before = start[where].astype(np.float64)
    trial = start.astype(np.float64)
    low, high, best = 0.0, 1.0, opened
    for _ in range(BISECTIONS):
        share = 0.5 * (low + high)
        trial[where] = (before + share * (opened[where] - before)).astype(start.dtype)
        if np.any(_dots(triangles, normals, trial) < limit):
            low = share
        else:
            high, best = share, trial.copy()
    return best, high


@dataclass(frozen=True, eq=False)
class Look:
    """Where a frame can have turned a triangle over: at rest none is, so only a triangle with a corner off its rest
    can be. ``off_rest`` (G,) flags the groups of vertices that may be off their rest (the caller sets it each
    frame; every vertex of an unflagged group must be exactly at its rest). The triangles are sorted into classes by
    the distinct groups of their corners, each looked at when one of its groups is flagged, its triangles' corners
    and rest normals read in one stream."""

    mesh: SkinMesh
    grouping: np.ndarray  # (N,) each vertex's group
    off_rest: np.ndarray  # (G,) uint8, C-contiguous
    class_groups: np.ndarray  # (C, 3) int32: a class's groups, the last repeated where it has fewer than 3
    class_start: np.ndarray  # (C + 1,) int32: class c is rows class_start[c]:class_start[c + 1] of the two below
    corners: np.ndarray  # (K, 3) int32: the triangles, class after class
    rest_normals: np.ndarray  # (K, 3) float64: their rest normals

    @functools.cached_property
    def arguments(self) -> tuple[int, ...]:
        """The kernel's pointers to the arrays (alive as long as the look)."""
        arrays = (self.off_rest, self.class_groups, self.class_start, self.corners, self.rest_normals)
        return tuple(a.ctypes.data for a in arrays)

    @functools.cached_property
    def found(self) -> np.ndarray:
        """(3K,) int32: room for the kernel's list of turned-over triangles' corners."""
        return np.empty(self.corners.size, np.int32)

    def turned_corners(self, positions: np.ndarray) -> np.ndarray:
        """The corners (three per triangle, repeats kept) of the triangles at a flagged group that are turned over at
        the (N, 3) `positions`: where an `unfold` must start (`open_folds`)."""
        found = fused.turned_at(self, positions)
        if found is None:
            active = self.off_rest[self.class_groups].any(axis=1)
            rows = np.repeat(active, np.diff(self.class_start))
            corners = self.corners[rows]
            found = corners[_turned(corners, self.rest_normals[rows], positions.astype(np.float64))].reshape(-1)
        return found


def group_look(mesh: SkinMesh, vertex_group: np.ndarray, n_groups: int, off_rest: np.ndarray | None = None) -> Look:
    """A `Look` for vertices grouped by (N,) `vertex_group` (values below `n_groups`) whose (G,) uint8 `off_rest`
    flags the caller sets (a new array, no group flagged, by default)."""
    vertex_group = np.asarray(vertex_group, dtype=np.int64)
    if vertex_group.shape != (mesh.n_vertices,) or (len(vertex_group) and vertex_group.max() >= n_groups):
        raise DeformError("vertex_group must give each vertex a group below n_groups")
    groups = np.sort(vertex_group[mesh.triangles], axis=1)
    groups[:, 1] = np.where(groups[:, 1] == groups[:, 0], groups[:, 2], groups[:, 1])  # distinct first, then repeats
    keys, inverse = np.unique((groups[:, 0] * n_groups + groups[:, 1]) * n_groups + groups[:, 2], return_inverse=True)
    sort = np.argsort(inverse, kind="stable")
    return Look(
        mesh=mesh,
        grouping=vertex_group,
        off_rest=np.zeros(n_groups, np.uint8) if off_rest is None else _flags(off_rest, n_groups),
        class_groups=np.stack([keys // n_groups**2, keys // n_groups % n_groups, keys % n_groups], axis=1).astype(
            np.int32
        ),
        class_start=np.searchsorted(inverse[sort], np.arange(len(keys) + 1)).astype(np.int32),
        corners=np.ascontiguousarray(mesh.triangles[sort]),
        rest_normals=np.ascontiguousarray(mesh.rest_normals[sort]),
    )


def _flags(off_rest: np.ndarray, n_groups: int) -> np.ndarray:
    if off_rest.dtype != np.uint8 or off_rest.shape != (n_groups,) or not off_rest.flags.c_contiguous:
        raise DeformError(f"off_rest must be a C-contiguous uint8 array of {n_groups} flags")
    return off_rest


def frame_steps(n_vertices: int) -> int:
    """The most Jacobi steps Unfold Skin takes in one played frame of a face of `n_vertices`: FRAME_WORK over the
    vertex count, within [MIN_FRAME_STEPS, MAX_STEPS]."""
    return int(np.clip(FRAME_WORK // max(n_vertices, 1), MIN_FRAME_STEPS, MAX_STEPS))


def open_folds(
    mesh: SkinMesh,
    positions: np.ndarray,
    look: Look | None = None,
    max_steps: int = MAX_STEPS,
    start: np.ndarray | None = None,
) -> Unfolded:
    """`unfold` by the compiled kernel where it runs (float32 positions), else by the numpy reference. With a
    `look`, whose caller vouches that every vertex outside its flagged groups is at its rest, only the triangles
    there are looked at, and the unfold starts from the turned ones' corners; with `start`, the unfold starts from
    those vertices (`unfold`); the result is the same as from a look at every triangle."""
    if look is not None:
        start = look.turned_corners(positions)
        if not len(start):
            return Unfolded(np.zeros(0, np.int32), 0, 0)
    steps = (max_steps, STEP, CHECK_EVERY, STALL_CHECKS, BISECTIONS, MARGIN, MOMENTUM)
    done = fused.unfold(mesh, positions, start, *steps)
    if done is None:
        return unfold(mesh, positions, max_steps, start)
    return Unfolded(*done)


class FrameBudget:
    """A frame's Unfold Skin budget shared by its calls: `max_steps` Jacobi steps (`frame_steps`, each costed at the
    whole mesh), and with `work` (vertex-steps, `FRAME_WORK`) more, each costed at the vertices the membrane has
    moved this frame (a step costs what its region does, and its region is the fold's, which grows from them).
    `frame_steps` alone left a small fold on a larger mesh turned over: the Lee Perry-Smith scan with its shoulders
    (8,838 vertices, 452 steps) at the sealed lip line in demo.fap's jaw opening, 3 faces for 18 frames, where the
    membrane needed 580 steps at 2,585 vertices (1.5 of the 4 million vertex-steps the budget means), and a face
    at frames 16 and 33 where the first opening took 440 steps and left 12 to the lip guard's rounds."""

    def __init__(self, n_vertices: int, max_steps: int, work: int | None = None):
        self.n_vertices, self.max_steps, self.work = n_vertices, max_steps, work
        self.steps = self.spent = 0
        self.moved = np.zeros(0, np.int32)

    def allowed(self) -> int:
        """The steps the next call may take."""
        steps = self.max_steps - self.steps
        if self.work is not None and len(self.moved):
            steps = max(steps, (self.work - self.spent) // len(self.moved))
        return int(min(steps, MAX_STEPS - self.steps))

    def used(self, done: Unfolded) -> None:
        cost = len(done.moved) or len(self.moved) or self.n_vertices
        self.steps, self.spent = self.steps + done.steps, self.spent + done.steps * cost
        self.moved = np.union1d(self.moved, done.moved).astype(np.int32)


def open_folds_within(
    mesh: SkinMesh,
    positions: np.ndarray,
    look: Look | None,
    budget: FrameBudget,
    start: np.ndarray | None = None,
) -> Unfolded:
    """`open_folds` within a frame's `budget`: where triangles are left turned over and the call moved skin, more
    calls from the vertices moved so far, while the budget allows a batch (`CHECK_EVERY` steps); a call that opened
    nothing ends it (its steps are lost with its positions). The steps are the calls' together, the triangles left
    the last call's."""
    done = open_folds(mesh, positions, look, max_steps=max(budget.allowed(), 0), start=start)
    budget.used(done)
    total, moved = done.steps, done.moved
    while done.left and len(done.moved):
        steps = budget.allowed()
        if steps < CHECK_EVERY:
            break
        done = open_folds(mesh, positions, None, max_steps=steps, start=budget.moved)
        budget.used(done)
        total, moved = total + done.steps, np.union1d(moved, done.moved).astype(np.int32)
    return Unfolded(moved, total, done.left, done.share)


def open_folds_guarded(
    mesh: SkinMesh,
    positions: np.ndarray,
    guard: Callable[[], bool],
    look: Look | None = None,
    max_steps: int = MAX_STEPS,
    guarded: np.ndarray | None = None,
    work: int | None = None,
) -> np.ndarray:
    """`open_folds`, then, where it moved skin, `guard` (a constraint on `positions` in place, such as the lip guard,
    saying whether it moved any) and the membrane take turns until a round leaves both content, at most
    GUARD_ROUNDS: the membrane may carry lip skin back across the other lip, the guard may turn a face over. The
    rounds share one `FrameBudget` (`max_steps`, a frame's `frame_steps`, and `work`: each round with a budget of
    its own made the 2 mm remesh's slowest frames 5x its median). `guarded`: the vertices the guard can move, where a
    round's unfold starts (a round follows one that left no triangle turned over, so only the guard's can be; each
    round looked at every triangle, 1.5 ms at 53k vertices, 7 rounds a third of the 2 mm remesh's slowest frames).
    A round whose membrane kept no smaller share of its change than the round before (`Unfolded.share`) opened no
    smaller fold: the guard and the membrane undo each other, and more rounds would spend the budget to end where
    they began (the Lee Perry-Smith scan's sealed lip line, demo frames 22-27: 4-5 rounds each keeping 0.79-0.81,
    the last out of budget with a face left turned over), so the rounds end there, as they do after a round that
    left a fold. The vertices the membrane moved."""
    budget = FrameBudget(mesh.n_vertices, max_steps, work)
    moved = open_folds_within(mesh, positions, look, budget).moved
    share = np.inf
    for _ in range(GUARD_ROUNDS if len(moved) else 0):
        if budget.allowed() <= 0 or not guard():
            break
        done = open_folds_within(mesh, positions, None, budget, start=guarded)
        if not len(done.moved):
            break
        moved = np.union1d(moved, done.moved)
        if done.left or done.share >= share:
            break
        share = done.share
    return moved
