"""Planar Bones deformer and its SoFFD special case (Sánchez Lorenzo & Maddock, paper 000).

A control mesh (triangulated MPEG-4 feature points) drives a dense mesh. `bind` runs once on the rest
pose and keeps every (vertex, triangle) pair whose eq. 9 weight is positive, with the pair's region,
normalised weight and local coordinates. `evaluate` rebuilds each control triangle's frames for new
control positions and blends the per-triangle images (eq. 8): eq. 1 everywhere in ``"soffd"`` mode; eq. 1
in the face region, eq. 12 in edge regions and eq. 13–14 in apex regions in ``"planar_bones"`` mode.

Choices where the paper leaves room (see also `regions.locate`):

* Affection radius (§3): for each triangle, ``radius_fraction`` × the point–triangle distance to the
  nearest control-mesh vertex that is not one of its corners. Control points that coincide with a
  corner (the inner-lip points of a closed mouth) count as that corner, so they do not shrink the radius
  to zero; masks separate such lips instead. A triangle with no other control point starts at 0.
* Coverage: every ``cover`` vertex outside all affection volumes raises the radius of its nearest
  triangle (among those its masks allow; all of them where several are equally near, so that the order
  of the triangles does not matter) to ``(1 + RAISE_MARGIN)`` × its distance, so its raw eq. 9
  weight is at least about 4e-4 at n = 2 instead of vanishing; weights are normalised afterwards anyway.
  The paper covers "every vertex of the targeted face geometry"; on a whole head (scalp, neck, ears)
  covering every vertex raises border radii to the head's size and drags the scalp along with the face
  (and binds ~5x more pairs), so `cover_over_control_mesh` gives the face part: vertices near the control
  mesh whose nearest point on it is not on its outline (the rims of its holes, the mouth and eye
  openings, count as inside: the lips' and lids' inner sides are face too).
* Partial coverage: with normalised weights (eq. 8) a vertex at the far edge of the union of the
  affection volumes takes the full motion of a triangle whose weight there is nearly 0, while its
  neighbour outside stays put, so the surface tears where the covered region ends. The paper avoids
  this by covering the whole face mesh; for a mesh the control mesh covers only in part (a whole
  head), ``fade_below=τ`` scales the eq. 8 weights by s(Σw / τ), with s the smoothstep 3x² − 2x³
  (1 from x = 1 up), and gives the remainder to the rest position: eq. 8 exactly wherever Σw ≥ τ (rigid
  motion reproduced exactly there), and a fade to rest where Σw falls from τ to 0 at the edge of the
  volumes that is smooth at both ends (a linear ramp, Σw / τ, creases the skin where it starts). Raised
  radii then reach π / arccos(2 τ^(1/n) − 1) times a covered vertex's distance, so that every ``cover``
  vertex keeps Σw ≥ τ (before masks).
* Zero-area control triangles (collinear or coincident corners) have no plane, so they are excluded
  from influence and counted in `Binding.n_excluded`.
* At evaluation a control triangle collapsed to a line has no normal: its normal and edge normals are
  taken as zero (the height term vanishes) instead of NaN. In eq. 13 the in-plane part
  (Π(S) − V_j) C⁻¹ C' · D/d always has length D; when d = 0 (then D = 0 too, or the deformed triangle is
  collapsed) its limit is taken as the zero vector.
"""

import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import BinaryIO

import numpy as np

from . import fused
from .inputs import COINCIDENCE, DeformError, check_points, check_positive, check_triangles
from .regions import (
    APEX,
    EDGE,
    FACE,
    Location,
    TriangleFrames,
    affection_weight,
    deformation_basis,
    distance_lower_bound,
    locate,
    triangle_frames,
)

FORMAT_VERSION = 1
MODES = ("planar_bones", "soffd")
RAISE_MARGIN = 0.1
FLATNESS = 1e-10  # ‖cross‖ / (longest edge)² below this is a zero-area triangle
CHUNK = 64  # pairs per batched product in `evaluate`; measured best of 32-1024 for 4k-68k vertices
BOUND_SLACK = 1e-9  # relative rounding allowance when `distance_lower_bound` rules a point out
FAINT_PAIR = 1e-3  # eq. 8 weights below this are dropped at bind time (`_drop_faint_pairs`)
# per-pair local coordinates (eq. 1, 12-14: alpha, beta, h; the region frames' x, y, h; D_j), which a saved
# binding keeps in float32
LOCAL_FIELDS = ("pair_face_local", "pair_region_local", "pair_apex_distance")
TIE = 1e-6  # triangles this close (relative) to an uncovered vertex's nearest distance are all raised


@dataclass(frozen=True, eq=False)
class Binding:
    """Everything `evaluate` needs, in float64; pairs are sorted by triangle, then vertex.

    Per pair p: ``pair_vertex``/``pair_triangle`` indices, ``pair_region`` (regions.FACE, EDGE + j,
    APEX + j), ``pair_weight`` (eq. 9 × mask, normalised to sum 1 per vertex), ``pair_face_local``
    (α, β, h) of eq. 1, ``pair_region_local`` in the region's own frame (A, B_j or C_j) and
    ``pair_apex_distance`` D_j(S) of eq. 14. ``affection_radius`` (T,) is the final radius per triangle,
    ``active`` (T,) is False for excluded zero-area triangles, ``n_raised`` counts triangles whose radius
    was raised to cover the face.
    """

    rest_vertices: np.ndarray
    control_rest: np.ndarray
    triangles: np.ndarray
    affection_radius: np.ndarray
    active: np.ndarray
    n_raised: int
    pair_vertex: np.ndarray
    pair_triangle: np.ndarray
    pair_region: np.ndarray
    pair_weight: np.ndarray
    pair_face_local: np.ndarray
    pair_region_local: np.ndarray
    pair_apex_distance: np.ndarray
    _evaluation: dict = field(init=False, repr=False)

    def __post_init__(self) -> None:
        _check_pairs(self)
        object.__setattr__(self, "_evaluation", {})  # what evaluating needs, made on first use

    @property
    def n_vertices(self) -> int:
        return len(self.rest_vertices)

    @property
    def n_pairs(self) -> int:
        return len(self.pair_vertex)

    @property
    def n_excluded(self) -> int:
        """Zero-area control triangles left out of the deformation."""
        return int(np.count_nonzero(~self.active))

    @property
    def n_static(self) -> int:
        """Vertices no triangle affects; `evaluate` returns them bit-identical to the rest pose."""
        return self.n_vertices - len(np.unique(self.pair_vertex))


def bind(
    rest_vertices: np.ndarray,
    control_rest: np.ndarray,
    triangles: np.ndarray,
    *,
    radius_fraction: float = 1.0,
    falloff_exponent: float = 2.0,
    vertex_masks: Mapping[str, np.ndarray] | None = None,
    triangle_masks: Sequence[str | None] | None = None,
    cover: np.ndarray | None = None,
    fade_below: float = 0.0,
    raisable: np.ndarray | None = None,
    local_float32: bool = False,
) -> Binding:
    """Bind (N, 3) rest vertices to the control mesh (M, 3) points / (T, 3) triangles.

    ``vertex_masks`` maps names to (N,) weights in [0, 1] (vertex-group weights or a mask image sampled
    at the UVs); ``triangle_masks[t]`` names the mask that multiplies triangle t's weights (the paper's
    texture masks at the eye and mouth openings) or is None. ``cover`` (N,) bool marks the vertices that
    must lie in at least one affection volume (default: all); one that every nearby triangle's mask
    excludes cannot be covered and stays at rest (counted in `Binding.n_static`). ``fade_below``
    (0 = the paper) normalises a vertex's weights by max(their sum, fade_below) and gives the remainder to
    its rest position, for meshes the control mesh covers only in part (see the module notes).
    ``radius_fraction`` may also be (T,), one per triangle; ``raisable`` (T,) bool limits the triangles whose
    radii coverage may raise (default: all). ``local_float32`` rounds the per-pair local
    coordinates (``LOCAL_FIELDS``) to float32, as a saved binding stores them, before the evaluation arrays
    are built (once). Raises `DeformError` on bad input.
    """
    rest = check_points(rest_vertices, "rest_vertices")
    control = check_points(control_rest, "control_rest")
    tris = check_triangles(triangles, len(control))
    fraction = _radius_fractions(radius_fraction, len(tris))
    exponent = check_positive(falloff_exponent, "falloff_exponent")
    mask_values = _triangle_mask_values(vertex_masks, triangle_masks, len(tris), len(rest))
    must_cover = _cover(cover, len(rest))
    fade = float(fade_below)
    if not 0.0 <= fade < 1.0:  # a single weight reaches 1 only on the triangle itself
        raise DeformError(f"fade_below must be in [0, 1), got {fade_below!r}")

    frames = triangle_frames(control[tris])
    used = np.unique(tris)
    tolerance = COINCIDENCE * max(float(np.ptp(control[used], axis=0).max()), 1e-300)
    longest = frames.edge_lengths.max(axis=1)
    active = (frames.doubled_areas > FLATNESS * longest**2) & (longest > tolerance)

    radius = _initial_radius(frames, control, tris, used, active, tolerance) * fraction
    sphere_centre, sphere_radius = _bounding_spheres(frames)
    squared_norms = np.einsum("ij,ij->i", rest, rest)
    rounding = 1e-12 * (squared_norms.max() + np.einsum("ij,ij->i", sphere_centre, sphere_centre).max())

    # the compiled kernel's `collect` (native/bind_regions.h) where it is available; the numpy below is the reference
    located = _Regions(frames, sphere_centre)
    collector = None if located.rows is None else fused.Collector(rest, squared_norms)

    def collect(t: int) -> dict[str, np.ndarray]:
        reach = sphere_radius[t] + radius[t]
        if collector is not None:
            limits = (reach * reach + rounding, radius[t] * (1.0 + BOUND_SLACK), radius[t], exponent)
            pairs = collector.collect(located.rows[t], mask_values[t], *limits)
            if pairs is not None:
                return pairs
        centre = sphere_centre[t]
        squared = squared_norms - 2.0 * (rest @ centre) + centre @ centre
        candidates = np.flatnonzero(squared <= reach * reach + rounding)  # cheap pre-filters
        if mask_values[t] is not None:
            candidates = candidates[mask_values[t][candidates] > 0.0]
        bound = distance_lower_bound(frames, t, rest[candidates])
        candidates = candidates[bound < radius[t] * (1.0 + BOUND_SLACK)]
        location = locate(frames, t, rest[candidates])
        weight = affection_weight(location.distance, radius[t], exponent)
        if mask_values[t] is not None:
            weight *= mask_values[t][candidates]
        keep = weight > 0.0
        return {
            "vertex": candidates[keep],
            "weight": weight[keep],
            "region": location.region[keep],
            "face_local": location.face_local[keep],
            "region_local": location.region_local[keep],
            "apex_distance": location.apex_distance[keep],
        }

    active_ids = np.flatnonzero(active)
    pairs = {t: collect(t) for t in active_ids}
    reached = np.zeros(len(rest))
    for p in pairs.values():
        np.add.at(reached, p["vertex"], p["weight"])
    uncovered = np.flatnonzero(must_cover & ((reached < fade) | (reached == 0.0)))
    # radius / distance at which a single triangle's eq. 9 weight is fade_below (RAISE_MARGIN at least)
    reach = np.pi / np.arccos(2.0 * fade ** (1.0 / exponent) - 1.0) if fade > 0.0 else 0.0
    factor = max(1.0 + RAISE_MARGIN, reach)
    may_raise = active_ids if raisable is None else active_ids[np.asarray(raisable, dtype=bool)[active_ids]]
    raised_radius = _raised_radius(located, rest, uncovered, radius, may_raise, mask_values, tolerance, factor)
    raised = np.flatnonzero(raised_radius > radius)
    radius = raised_radius
    for t in raised:
        pairs[t] = collect(t)

    ordered = [pairs[t] for t in active_ids]
    vertex = np.concatenate([p["vertex"] for p in ordered]) if ordered else np.zeros(0, np.intp)
    weight = np.concatenate([p["weight"] for p in ordered]) if ordered else np.zeros(0)
    triangle = np.repeat(active_ids, [len(p["vertex"]) for p in ordered])
    total = np.bincount(vertex, weight, minlength=len(rest))
    # eq. 8 weights sum to 1 per vertex (less where the sum of raw weights is below fade_below)
    final = weight * _fade(total, fade)[vertex]
    keep, final = _drop_faint_pairs(vertex, final, len(rest))

    def stacked(key: str, shape: tuple[int, ...]) -> np.ndarray:
        out = np.concatenate([p[key] for p in ordered])[keep] if ordered else np.zeros(shape)
        return out.astype(np.float32).astype(np.float64) if local_float32 and out.dtype == np.float64 else out

    return Binding(
        rest_vertices=rest,
        control_rest=control,
        triangles=tris,
        affection_radius=radius,
        active=active,
        n_raised=len(raised),
        pair_vertex=vertex[keep].astype(np.int32),
        pair_triangle=triangle[keep].astype(np.int32),
        pair_region=stacked("region", (0,)).astype(np.int8),
        pair_weight=final[keep],
        pair_face_local=stacked("face_local", (0, 3)),
        pair_region_local=stacked("region_local", (0, 3)),
        pair_apex_distance=stacked("apex_distance", (0,)),
    )


def _drop_faint_pairs(vertex: np.ndarray, weight: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """(keep mask, weights): pairs under FAINT_PAIR of their vertex's motion dropped, the vertex's other pairs
    scaled up so its eq. 8 weights keep their sum (rigid motion stays exact; a vertex that would lose every
    pair keeps them all).

    Not in the paper: with the wide fade a fifth of the pairs carry under 1e-3 each (the cosine tail of eq. 9
    near the affection radius); they cost a fifth of every frame and move a vertex by at most 1e-3 of the spread
    between its triangles' images (about 0.01 mm at 10 mm of motion)."""
    keep = weight >= FAINT_PAIR
    if keep.all():
        return keep, weight
    full = np.bincount(vertex, weight, minlength=n_vertices)
    kept = np.bincount(vertex[keep], weight[keep], minlength=n_vertices)
    lost = kept == 0.0
    keep |= lost[vertex]
    scale = np.divide(full, kept, out=np.ones_like(full), where=~lost)
    return keep, weight * scale[vertex]


class _Regions:
    """`regions.locate` and `regions.distance_lower_bound` for the triangles of ``frames``, by the compiled kernel
    (native/bind_regions.h) where it is available; the numpy functions are the reference."""

    def __init__(self, frames: TriangleFrames, centres: np.ndarray):
        self.frames = frames
        self.rows = fused.bind_frames(frames, centres) if fused.available() else None

    def locate(self, t: int, points: np.ndarray) -> Location:
        located = None if self.rows is None else fused.locate(self.rows[t], points)
        return locate(self.frames, t, points) if located is None else located

    def bound(self, t: int, points: np.ndarray) -> np.ndarray:
        bound = None if self.rows is None else fused.distance_bound(self.rows[t], points)
        return distance_lower_bound(self.frames, t, points) if bound is None else bound


def cover_over_control_mesh(
    rest_vertices: np.ndarray, control_rest: np.ndarray, triangles: np.ndarray, max_distance: float
) -> np.ndarray:
    """(N,) True for the vertices "of the targeted face geometry" (§3), as `bind`'s ``cover``.

    A vertex counts when the control mesh is at most ``max_distance`` away and its nearest point on the
    control mesh is not on the mesh's outline (a triangle's inside, an edge two triangles share, a rim of
    a hole such as the mouth opening, or a control point with no outline edge). Covering every vertex of
    a whole head instead raises the radii of the outline triangles until they reach the scalp and neck,
    which then follow the face.
    """
    rest = check_points(rest_vertices, "rest_vertices")
    control = check_points(control_rest, "control_rest")
    tris = check_triangles(triangles, len(control))
    reach = check_positive(max_distance, "max_distance")
    frames = triangle_frames(control[tris])
    centre, sphere_radius = _bounding_spheres(frames)
    located = _Regions(frames, centre)
    nearest = np.full(len(rest), np.inf)
    nearest_triangle = np.zeros(len(rest), np.intp)
    nearest_region = np.zeros(len(rest), np.intp)
    squared_norms = np.einsum("ij,ij->i", rest, rest)
    rounding = 1e-12 * (squared_norms.max(initial=0.0) + np.einsum("ij,ij->i", centre, centre).max(initial=0.0))
    for t in range(len(tris)):
        squared = squared_norms - 2.0 * (rest @ centre[t]) + centre[t] @ centre[t]  # to the sphere's centre
        near = np.flatnonzero(squared <= (sphere_radius[t] + reach) ** 2 + rounding)
        bound = located.bound(t, rest[near])
        near = near[bound < np.minimum(nearest[near], reach) * (1.0 + BOUND_SLACK)]
        location = located.locate(t, rest[near])
        closer = location.distance < nearest[near]
        chosen = near[closer]
        nearest[chosen] = location.distance[closer]
        nearest_triangle[chosen] = t
        nearest_region[chosen] = location.region[closer]

    edges = np.sort(np.stack([tris, np.roll(tris, -1, axis=1)], axis=-1), axis=-1)  # (T, 3, 2): edge j
    unique_edges, edge_index, uses = np.unique(edges.reshape(-1, 2), axis=0, return_inverse=True, return_counts=True)
    outline = _outline(unique_edges, uses == 1, control)
    border_edge = outline[edge_index.reshape(-1, 3)]  # (T, 3)
    border_point = np.zeros(len(control), dtype=bool)
    border_point[unique_edges[outline].ravel()] = True
    j = (nearest_region - 1) % 3
    on_border = np.select(
        [nearest_region == FACE, nearest_region < APEX],
        [False, border_edge[nearest_triangle, j]],
        border_point[tris[nearest_triangle, j]],
    )
    return (nearest <= reach) & ~on_border


def _outline(edges: np.ndarray, border: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Which of the (E, 2) edges lie on the control mesh's outline: of the loops the ``border`` edges form,
    the longest one. The others are holes in the mesh (the mouth and eye openings), and the skin just
    inside them (the lips' and lids' inner sides) belongs to the face."""
    parent = list(range(len(points)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    border_ids = np.flatnonzero(border)
    for a, b in edges[border_ids].tolist():
        parent[root(a)] = root(b)
    loop = np.array([root(a) for a in edges[border_ids, 0].tolist()], dtype=np.intp)
    length = np.linalg.norm(points[edges[border_ids, 0]] - points[edges[border_ids, 1]], axis=1)
    outline = np.zeros(len(edges), dtype=bool)
    if len(border_ids):
        perimeter = np.bincount(loop, length, minlength=len(points))
        outline[border_ids[loop == np.argmax(perimeter)]] = True
    return outline


def evaluate(
    binding: Binding,
    control_positions: np.ndarray,
    mode: str = "planar_bones",
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Deformed (N, 3) vertex positions for new (M, 3) control positions (eq. 8).

    ``mode`` is ``"planar_bones"`` (eq. 1 / 12 / 13 by region) or ``"soffd"`` (eq. 1 for every region).
    ``out``, if given, is an (N, 3) float64 or float32 array that receives the result and is returned;
    a float32 ``out`` selects float32 per-pair coefficients, the cheaper path for Blender's float32 vertex
    buffer. Vertices no triangle affects are copied from the rest pose. Runs the compiled kernel of
    `fused` where it is available (equal to the numpy reference below within 1e-8 m; the first call per
    mode and dtype builds its layout), else the numpy reference, whose float32 products err by about
    1e-7 relative. The binding holds per-frame scratch arrays and caches, so one binding must not be
    evaluated from two threads at once.
    """
    if mode not in MODES:
        raise DeformError(f"unknown mode {mode!r}; expected one of {MODES}")
    control = check_points(control_positions, "control_positions")
    if control.shape != binding.control_rest.shape:
        raise DeformError(
            f"control_positions has shape {control.shape}, the binding expects {binding.control_rest.shape}"
        )
    n = binding.n_vertices
    if out is not None and (out.shape != (n, 3) or out.dtype not in (np.float32, np.float64)):
        raise DeformError(f"out must be a float32 or float64 array of shape {(n, 3)}")
    if fused.available():
        result = np.empty((n, 3)) if out is None else out
        if fused.evaluate_into(_fused_layout(binding, mode, result.dtype.type), control, result):
            return result
    return _evaluate_numpy(binding, deformation_basis(control[binding.triangles]), mode, out)


def prepare_playback(binding: Binding, mode: str, dtype: type = np.float32) -> None:
    """Build what `playback` needs for this binding, mode and output dtype now (on a worker thread, say),
    so that its first call does not; nothing where the compiled kernel is unavailable."""
    if mode not in MODES:
        raise DeformError(f"unknown mode {mode!r}; expected one of {MODES}")
    if fused.available():
        _fused_layout(binding, mode, dtype)


def playback(
    binding: Binding, mode: str, out: np.ndarray, rewritten: np.ndarray | None = None
) -> fused.Playback | None:
    """An evaluator for playing frames one after another into ``out`` (N, 3): ``evaluate(binding, control,
    mode, out)`` in effect, summing only the vertices whose triangles moved and writing the others only when
    they do not already hold their rest result. Only it writes ``out`` between frames but for the vertices
    ``rewritten`` after each frame and what the caller reports with `fused.Playback.changed`. None where the
    compiled kernel is unavailable (use `evaluate`)."""
    if mode not in MODES:
        raise DeformError(f"unknown mode {mode!r}; expected one of {MODES}")
    if not fused.available():
        return None
    return fused.Playback(_fused_layout(binding, mode, out.dtype.type), out, rewritten)


def _evaluate_numpy(binding: Binding, basis: np.ndarray, mode: str, out: np.ndarray | None) -> np.ndarray:
    """The reference implementation of `evaluate` for the deformed basis (T, 7, 3), and its fallback."""
    n = binding.n_vertices
    single = out is not None and out.dtype == np.float32
    arrays = _evaluation_arrays_for(binding, np.float32 if single else None)
    chunk_basis = basis.transpose(0, 2, 1).astype(arrays["dtype"])[arrays["chunk_triangle"]]  # (K, 3, 7)

    if mode == "planar_bones":
        coefficients = arrays["bones"]
        if arrays["n_apex_chunks"]:
            # Eq. 13–14: d_j(S) = ‖a b'_j + b b'_{j−1}‖ from the deformed Gram term g' = b'_j·b'_{j−1}.
            edge_normals = basis[:, 4:7]
            gram = np.einsum("tjk,tjk->tj", edge_normals, edge_normals[:, [2, 0, 1]]).ravel()
            gram = gram.astype(arrays["dtype"])[arrays["apex_group"]]
            squared = arrays["apex_squares"] + arrays["apex_cross"] * gram
            d = np.sqrt(np.maximum(squared, 0.0, out=squared), out=squared)
            ratio = arrays["apex_ratio"]  # w · D / d; 0 in the padding, where d = 0
            ratio.fill(0.0)
            np.divide(arrays["apex_scale"], d, out=ratio, where=d > 0.0)
            apex_block = coefficients[-arrays["n_apex_chunks"] :, 4:7]
            np.multiply(arrays["apex_rows"], ratio[:, None, :], out=apex_block)
    else:
        coefficients = arrays["soffd"]
        chunk_basis = chunk_basis[:, :, :4]
    images = arrays["images"]  # (3, K, CHUNK): weighted images, one contiguous block per axis
    np.matmul(chunk_basis, coefficients, out=images.transpose(1, 0, 2))

    # Eq. 8; static vertices (and the padding, on vertex 0) get 0 from bincount, then their rest position.
    result = np.empty((n, 3)) if out is None else out
    for axis in range(3):
        summed = np.bincount(arrays["vertex"], images[axis].ravel(), minlength=n)
        np.add(summed, arrays["static"][axis], out=result[:, axis])
    return result


def save_binding(binding: Binding, file: str | BinaryIO) -> None:
    """Write the binding as a compressed .npz with a format version."""
    np.savez_compressed(
        file,
        format_version=np.int64(FORMAT_VERSION),
        n_raised=np.int64(binding.n_raised),
        **{name: getattr(binding, name) for name in _SAVED_ARRAYS},
    )


def load_binding(file: str | BinaryIO) -> Binding:
    """Read a binding written by `save_binding`; a file of another format version is a `DeformError`."""
    try:
        with np.load(file, allow_pickle=False) as data:
            version = int(data["format_version"]) if "format_version" in data.files else None
            if version != FORMAT_VERSION:
                raise DeformError(f"binding format version {version}, this add-on reads {FORMAT_VERSION}")
            missing = [name for name in _SAVED_ARRAYS if name not in data.files]
            if missing:
                raise DeformError(f"binding file lacks {', '.join(missing)}")
            arrays = {name: data[name] for name in _SAVED_ARRAYS}
            n_raised = int(data["n_raised"])
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as error:
        if isinstance(error, DeformError):
            raise
        raise DeformError(f"cannot read binding: {error}") from error
    return Binding(n_raised=n_raised, **arrays)


@dataclass(frozen=True)
class PlanarBonesDeformer:
    """A `Binding` with a fixed mode, for looping over methods by name (see `addon.deform.METHODS`)."""

    binding: Binding
    mode: str = "planar_bones"

    def evaluate(self, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        return evaluate(self.binding, control_positions, self.mode, out)


def bind_planar_bones(rest_vertices, control_rest, triangles, **params) -> PlanarBonesDeformer:
    return PlanarBonesDeformer(bind(rest_vertices, control_rest, triangles, **params), "planar_bones")


def bind_soffd(rest_vertices, control_rest, triangles, **params) -> PlanarBonesDeformer:
    return PlanarBonesDeformer(bind(rest_vertices, control_rest, triangles, **params), "soffd")


_SAVED_ARRAYS = (
    "rest_vertices",
    "control_rest",
    "triangles",
    "affection_radius",
    "active",
    "pair_vertex",
    "pair_triangle",
    "pair_region",
    "pair_weight",
    "pair_face_local",
    "pair_region_local",
    "pair_apex_distance",
)


def _check_pairs(binding: Binding) -> None:
    n = len(binding.rest_vertices)
    p = len(binding.pair_vertex)
    if not (
        len(binding.pair_triangle) == len(binding.pair_region) == len(binding.pair_weight) == p
        and len(binding.pair_apex_distance) == p
        and binding.pair_face_local.shape == binding.pair_region_local.shape == (p, 3)
        and np.all(np.diff(binding.pair_triangle) >= 0)
        and (p == 0 or (binding.pair_vertex.min() >= 0 and binding.pair_vertex.max() < n))
    ):
        raise DeformError("inconsistent binding arrays")


def _pair_coefficients(binding: Binding) -> dict:
    """Per-pair coefficients on the rows of `regions.deformation_basis`, pre-multiplied by the weight, the
    pairs ordered by (apex or not, triangle): what both the numpy path's layout and the result at rest are
    made from (cached on the binding)."""
    if "pairs" in binding._evaluation:
        return binding._evaluation["pairs"]
    p = len(binding.pair_vertex)
    is_apex = binding.pair_region >= APEX
    order = np.concatenate([np.flatnonzero(~is_apex), np.flatnonzero(is_apex)])  # each part stays by triangle
    vertex = binding.pair_vertex.astype(np.intp)[order]
    triangle = binding.pair_triangle.astype(np.intp)[order]
    region = binding.pair_region.astype(np.intp)[order]
    weight = binding.pair_weight[order]
    alpha, beta, height = binding.pair_face_local[order].T
    x, y, h = binding.pair_region_local[order].T
    soffd = np.stack([1.0 - alpha - beta, alpha, beta, height], axis=1) * weight[:, None]  # eq. 1 on V, n

    # Eq. 1 / 12 / 13 as coefficients on [V_0, V_1, V_2, n, b_0, b_1, b_2].
    pairs = np.arange(p)
    j = (region - 1) % 3
    is_face = region == FACE
    is_edge = (region >= EDGE) & (region < APEX)
    is_apex = region >= APEX
    bones = np.zeros((p, 7))
    bones[is_face, :4] = soffd[is_face]
    edge, edge_j = pairs[is_edge], j[is_edge]
    bones[edge, edge_j] = (1.0 - x[edge]) * weight[edge]
    bones[edge, (edge_j + 1) % 3] = x[edge] * weight[edge]
    bones[edge, 4 + edge_j] = y[edge] * weight[edge]
    apex, apex_j = pairs[is_apex], j[is_apex]
    bones[apex, apex_j] = weight[apex]
    bones[~is_face, 3] = h[~is_face] * weight[~is_face]
    a, b = x[apex], y[apex]  # in-plane coordinates on the rows b_j, b_{j−1} of C_j
    apex_rows = np.zeros((len(apex), 3))  # each apex pair's b'_0, b'_1, b'_2 coefficients ÷ (w·D/d)
    apex_rows[np.arange(len(apex)), apex_j] = a
    apex_rows[np.arange(len(apex)), (apex_j + 2) % 3] = b
    apex_scale = weight[apex] * binding.pair_apex_distance[order][apex]  # w · D of eq. 13–14
    # 1 for unaffected vertices, 0 where the weights were normalised, in between when fading to rest
    rest_weight = 1.0 - np.bincount(vertex, weight, minlength=binding.n_vertices)
    rest_weight[np.abs(rest_weight) < 1e-12] = 0.0
    coefficients = {
        "vertex": vertex,
        "triangle": triangle,
        "is_apex": is_apex,
        "soffd": soffd,
        "bones": bones,
        "a": a,
        "b": b,
        "apex_j": apex_j,
        "apex_rows": apex_rows,
        "apex_scale": apex_scale,
        "static": binding.rest_vertices.T * rest_weight,  # (3, N) the rest pose's share of each vertex
    }
    binding._evaluation["pairs"] = coefficients
    return coefficients


def _evaluation_arrays(binding: Binding) -> dict:
    """The numpy path's layout of `_pair_coefficients`.

    Laid out so that a frame is one batched matrix product and one `bincount` per axis, with no
    Python loop: the pairs are ordered by (apex or not, triangle), each triangle's run is cut into
    chunks of `CHUNK` pairs (zero-padded), and a chunk holds its pairs' coefficients as a (7, CHUNK)
    matrix that its triangle's (3, 7) transposed basis multiplies. (One product per triangle costs more
    in numpy's per-call overhead at face-mesh sizes; longer chunks cost more in padding.) The apex
    coefficients on b'_j, b'_{j−1} of eq. 13 are a·w·D/d and b·w·D/d, which depend on the deformed
    triangle: `evaluate` rewrites that block of the trailing apex chunks each frame, so a binding must
    not be evaluated from two threads at once.
    """
    pairs = _pair_coefficients(binding)
    p = len(binding.pair_vertex)
    vertex, triangle, is_apex = pairs["vertex"], pairs["triangle"], pairs["is_apex"]
    soffd, bones, apex_rows, apex_scale = pairs["soffd"], pairs["bones"], pairs["apex_rows"], pairs["apex_scale"]
    a, b, apex_j = pairs["a"], pairs["b"], pairs["apex_j"]
    apex = np.flatnonzero(is_apex)
    chunk_run, run_start, slot = _chunks(triangle * 2 + is_apex)
    n_chunks = len(chunk_run)
    n_apex_chunks = int(np.count_nonzero(is_apex[run_start][chunk_run]))
    apex_slot = slot[p - len(apex) :] - (n_chunks - n_apex_chunks) * CHUNK

    def padded(values: np.ndarray, where: np.ndarray, chunks: int) -> np.ndarray:
        """(chunks, rows, CHUNK): per-pair values (P,) or (P, rows) in their slots, zero in the padding."""
        result = np.zeros((chunks * CHUNK, *values.shape[1:]), dtype=values.dtype)
        result[where] = values
        rows = values.shape[1] if values.ndim == 2 else 1
        return np.ascontiguousarray(np.moveaxis(result.reshape(chunks, CHUNK, rows), 1, 2))

    return {
        "dtype": np.float64,
        "chunk_triangle": triangle[run_start][chunk_run],
        "vertex": padded(vertex, slot, n_chunks).ravel(),  # the padding adds zeros to vertex 0
        "soffd": padded(soffd, slot, n_chunks),
        "bones": padded(bones, slot, n_chunks),
        "images": np.empty((3, n_chunks, CHUNK)),
        "n_apex_chunks": n_apex_chunks,
        "apex_rows": padded(apex_rows, apex_slot, n_apex_chunks),
        "apex_squares": padded(a * a + b * b, apex_slot, n_apex_chunks)[:, 0],
        "apex_cross": padded(2.0 * a * b, apex_slot, n_apex_chunks)[:, 0],
        "apex_group": padded(triangle[apex] * 3 + apex_j, apex_slot, n_apex_chunks)[:, 0],
        "apex_scale": padded(apex_scale, apex_slot, n_apex_chunks)[:, 0],
        "apex_ratio": np.empty((n_apex_chunks, CHUNK)),
        "static": pairs["static"],
    }


_PER_PAIR = (  # the arrays `_evaluation_arrays_for` keeps a float32 copy of
    "soffd",
    "bones",
    "apex_rows",
    "apex_squares",
    "apex_cross",
    "apex_scale",
)
_SCRATCH = ("images", "apex_ratio")  # per-frame work buffers: allocated, never copied


def _fused_layout(binding: Binding, mode: str, dtype: type) -> fused.Layout:
    """The compiled kernel's layout for this binding, mode and output dtype, built on first use."""
    key = ("fused", mode, np.dtype(dtype).name)
    if key not in binding._evaluation:
        binding._evaluation[key] = fused.build_layout(
            mode=mode,
            dtype=dtype,
            control_rest=binding.control_rest,
            triangles=binding.triangles,
            pair_vertex=binding.pair_vertex,
            pair_triangle=binding.pair_triangle,
            pair_region=binding.pair_region,
            pair_weight=binding.pair_weight,
            pair_face_local=binding.pair_face_local,
            pair_region_local=binding.pair_region_local,
            pair_apex_distance=binding.pair_apex_distance,
            # Eq. 1-14 give the identity at rest (every region's frame rebuilds its vertex exactly), so the
            # kernel's base is the rest shape itself; the reference differs from it only by the binding's
            # local coordinates rounded to float32 (3e-9 m on the sample faces, tests/core/test_fused.py), and
            # summing it pair by pair cost 0.08 s (0.2 s on fresh memory) of Set Up Face at 68k vertices.
            base=binding.rest_vertices,
        )
    return binding._evaluation[key]


def _evaluation_arrays_for(binding: Binding, dtype: type | None) -> dict:
    """The numpy path's float64 arrays, or a float32 copy of the per-pair arrays, made on first use."""
    if "numpy" not in binding._evaluation:
        binding._evaluation["numpy"] = _evaluation_arrays(binding)
    arrays = binding._evaluation["numpy"]
    if dtype is None:
        return arrays
    if "float32" not in arrays:
        single = {name: arrays[name].astype(np.float32) for name in _PER_PAIR}
        single.update({name: np.empty(arrays[name].shape, dtype=np.float32) for name in _SCRATCH})
        arrays["float32"] = dict(arrays, dtype=np.float32, **single)
    return arrays["float32"]


def _chunks(run_key: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cut each run of equal keys into chunks of `CHUNK` pairs.

    Returns the run of each chunk, the first pair of each run, and each pair's slot in the padded
    (chunks × CHUNK) layout.
    """
    if len(run_key) == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, np.intp)
    run_start = np.flatnonzero(np.r_[True, run_key[1:] != run_key[:-1]])
    run_length = np.diff(np.r_[run_start, len(run_key)])
    run_chunks = -(-run_length // CHUNK)
    run_of_pair = np.repeat(np.arange(len(run_start)), run_length)
    offset = np.arange(len(run_key)) - run_start[run_of_pair]
    first_chunk = np.cumsum(run_chunks) - run_chunks
    slot = (first_chunk[run_of_pair] + offset // CHUNK) * CHUNK + offset % CHUNK
    return np.repeat(np.arange(len(run_start)), run_chunks), run_start, slot


def _radius_fractions(radius_fraction: float | np.ndarray, n_triangles: int) -> float | np.ndarray:
    """`bind`'s ``radius_fraction``: one positive number, or (T,) one per triangle."""
    if np.ndim(radius_fraction) == 0:
        return check_positive(radius_fraction, "radius_fraction")
    fractions = np.asarray(radius_fraction, dtype=np.float64)
    if fractions.shape != (n_triangles,) or not (np.isfinite(fractions).all() and (fractions > 0.0).all()):
        raise DeformError(f"radius_fraction must be one positive number or {n_triangles} of them")
    return fractions


def _initial_radius(
    frames: TriangleFrames,
    control: np.ndarray,
    tris: np.ndarray,
    used: np.ndarray,
    active: np.ndarray,
    tolerance: float,
) -> np.ndarray:
    """Distance from each triangle to the nearest control-mesh vertex that is not (at) a corner (§3)."""
    separation = np.linalg.norm(control[used, None, :] - control[None, used, :], axis=-1)
    same = np.zeros((len(control), len(control)), dtype=bool)
    same[np.ix_(used, used)] = separation <= tolerance
    radius = np.zeros(len(tris))
    for t in np.flatnonzero(active):
        others = used[~same[np.ix_(used, tris[t])].any(axis=1)]
        if len(others):
            radius[t] = locate(frames, t, control[others]).distance.min()
    return radius


def _raised_radius(
    located: _Regions,
    rest: np.ndarray,
    uncovered: np.ndarray,
    radius: np.ndarray,
    active_ids: np.ndarray,
    mask_values: list[np.ndarray | None],
    tolerance: float,
    factor: float,
) -> np.ndarray:
    """Radii raised so each uncovered vertex lies inside its nearest allowed triangle's volume (§3), at
    `factor` times its distance.

    Every triangle within `TIE` (relative) of the nearest distance counts as nearest and is raised, so the
    result does not depend on the order of the triangles: on a mirror-symmetric face a vertex on the
    mid-line raises both mirror-image triangles, not whichever comes first.
    """
    raised = radius.copy()
    if len(uncovered) == 0 or len(active_ids) == 0:
        return raised
    points = rest[uncovered]

    def allowed(t: int) -> np.ndarray:
        where = np.arange(len(uncovered))
        return where if mask_values[t] is None else where[mask_values[t][uncovered] > 0.0]

    nearest_distance = np.full(len(uncovered), np.inf)
    for t in active_ids:
        candidates = allowed(t)
        bound = located.bound(t, points[candidates])
        near = candidates[bound < nearest_distance[candidates] * (1.0 + BOUND_SLACK)]  # the others cannot be closer
        np.minimum.at(nearest_distance, near, located.locate(t, points[near]).distance)
    limit = nearest_distance * (1.0 + TIE) + tolerance
    for t in active_ids:
        candidates = allowed(t)
        candidates = candidates[located.bound(t, points[candidates]) <= limit[candidates]]
        distance = located.locate(t, points[candidates]).distance
        tied = distance <= limit[candidates]
        if tied.any():
            raised[t] = max(raised[t], float(distance[tied].max()) * factor + tolerance)
    return raised


def _bounding_spheres(frames: TriangleFrames) -> tuple[np.ndarray, np.ndarray]:
    centre = frames.corners.mean(axis=1)
    return centre, np.linalg.norm(frames.corners - centre[:, None, :], axis=-1).max(axis=1)


def _triangle_mask_values(
    vertex_masks: Mapping[str, np.ndarray] | None,
    triangle_masks: Sequence[str | None] | None,
    n_triangles: int,
    n_vertices: int,
) -> list[np.ndarray | None]:
    """Per triangle, the (N,) mask weights that multiply its eq. 9 weights, or None."""
    if triangle_masks is None:
        return [None] * n_triangles
    if len(triangle_masks) != n_triangles:
        raise DeformError(f"triangle_masks has {len(triangle_masks)} entries for {n_triangles} triangles")
    masks = dict(vertex_masks or {})
    checked = {}
    for name in {m for m in triangle_masks if m is not None}:
        if name not in masks:
            raise DeformError(f"triangle mask {name!r} is not among vertex_masks {sorted(masks)}")
        values = np.asarray(masks[name], dtype=np.float64)
        if values.shape != (n_vertices,):
            raise DeformError(f"vertex mask {name!r} has shape {values.shape}, expected ({n_vertices},)")
        if not (np.isfinite(values).all() and values.min() >= 0.0 and values.max() <= 1.0):
            raise DeformError(f"vertex mask {name!r} must hold finite values in [0, 1]")
        checked[name] = values
    return [None if name is None else checked[name] for name in triangle_masks]


def _fade(total: np.ndarray, fade_below: float) -> np.ndarray:
    """Per vertex, the factor that turns raw eq. 9 weights adding up to ``total`` into eq. 8 weights: 1 / Σw
    where Σw ≥ fade_below, and below it 1 / Σw times a smoothstep of Σw / fade_below, so the rest position's
    share grows from 0 to 1 with no kink where it starts."""
    total = np.asarray(total, dtype=np.float64)
    s = np.minimum(total / fade_below, 1.0) if fade_below > 0.0 else np.ones_like(total)
    return np.divide(s * s * (3.0 - 2.0 * s), total, out=np.zeros_like(total), where=total > 0.0)


def _cover(cover: np.ndarray | None, n_vertices: int) -> np.ndarray:
    if cover is None:
        return np.ones(n_vertices, dtype=bool)
    flags = np.asarray(cover)
    if flags.shape != (n_vertices,) or flags.dtype != bool:
        raise DeformError(f"cover must be a bool array of shape ({n_vertices},)")
    return flags
