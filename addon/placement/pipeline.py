"""Place the 84 feature points on a user's mesh: the placement path end to end.

    mesh (world vertices, triangles) -> skin and loose parts -> orientation, scale, position (rigid.align)
    -> template registered to the skin (nicp.register) -> FPs carried over and snapped to the skin
    -> pupils from eyeballs, teeth and tongue points from those parts -> head check -> confidences.

`placement_steps` is a generator: it yields the fraction done between steps (so a modal operator can show
progress and stop on Esc with nothing changed) and returns the `Placement`; `place_feature_points` runs it
to the end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mpeg4.feature_points import FEATURE_POINTS, fp_index
from ..progress import scaled
from .body import head_region
from .errors import PlacementError
from .features import FeatureMatcher, local_height
from .landmarks import ear_tops, refine
from .mouth_parts import READ_CONFIDENCE, mouth_ends
from .nicp import border_vertices, register
from .openings import boundary_loops, refine_openings
from .parts import find_eyeballs, pupil_on_eyeball
from .rigid import TEMPLATE_AXES, Similarity, align
from .scipy_modules import cKDTree
from .shape import fit_shape
from .skull import head_frame, read_skull
from .slit import read_slit
from .subnasale import subnasale
from .surface import Surface, area_samples, loose_parts, triangle_areas
from .symmetry import MidPlane, surface_mid_plane, symmetrise
from .template import load_template

BODY_SAMPLES = 20000  # surface samples of the whole mesh for finding a head on a body
SAMPLES = 4000  # surface samples of the mesh for the rigid fit
SKIN_SHARE = 0.2  # a loose piece with at least this share of the largest one's area is skin (head, body)
CROP = 0.25  # the skin kept around the fitted template: its bounding box grown by this share
PART_REACH = 0.006  # template metres: a teeth or tongue point snaps onto a part this near
CONFIDENCE_RESIDUAL = 0.0015  # template metres: the fit residual at which confidence falls to 1/e
NEIGHBOURS = 8  # template vertices around an FP whose fit says how well it is placed
INSIDE_REACH = 0.01  # template metres: the least fall-off radius of the map carrying an inside point
FEATURE_SAMPLES = 12000  # area samples of the template skin for local heights (about 2.5 mm apart)
FEATURE_RADIUS = 0.008  # template metres
FEATURE_WEIGHT = 3.0  # 1 mm of local height difference counts as 3 mm of distance
FIT_LIMIT = 0.02  # template metres: the development heads' rigid fit scores 11-14 mm, a sphere or box 26-28
LOW_CONFIDENCE = 0.5
RECESS_SHARE = 0.5  # an eye socket at least half as deep as the template's
ESTIMATE_CONFIDENCE = 0.3
MIN_VERTICES = 100


@dataclass(frozen=True)
class Placement:
    positions: np.ndarray  # (84, 3) world
    confidence: np.ndarray  # (84,) in [0, 1]
    estimated: tuple[str, ...]  # FP ids placed without the part they belong on (no eyeball, teeth, tongue)
    axes: np.ndarray  # (3, 3) rows: the face's left, up and forward in the world
    scale: float  # world units per template metre

    def low_confidence(self, threshold: float = LOW_CONFIDENCE) -> list[str]:
        return [fp.id for fp, c in zip(FEATURE_POINTS, self.confidence, strict=True) if c < threshold]


def place_feature_points(vertices: np.ndarray, triangles: np.ndarray) -> Placement:
    steps = placement_steps(vertices, triangles)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def _validate(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if len(vertices) < MIN_VERTICES or not len(triangles):
        raise PlacementError(
            f"this mesh does not look like a human head: it has {len(vertices)} vertices and {len(triangles)} "
            f"triangles, too few for eyes and a mouth (at least {MIN_VERTICES} vertices); nothing was placed"
        )
    if not np.all(np.isfinite(vertices)):
        raise PlacementError("the mesh has vertices at infinite or undefined positions")
    if triangles.min() < 0 or triangles.max() >= len(vertices):
        raise PlacementError("the mesh's faces use vertices it does not have")
    return vertices, triangles


def placement_steps(vertices: np.ndarray, triangles: np.ndarray):
    """Generator: yields the fraction done (0..1), returns the Placement (see the module's doc)."""
    vertices, triangles = _validate(vertices, triangles)
    template = load_template()
    triangles = _head_of_body(vertices, triangles)
    labels = loose_parts(len(vertices), triangles)
    area = np.bincount(labels[triangles[:, 0]], weights=triangle_areas(vertices, triangles), minlength=labels.max() + 1)
    if area.max() <= 0:
        raise PlacementError("the mesh has no area: its faces are all flat slivers")
    skin_labels = np.flatnonzero(area >= SKIN_SHARE * area.max())
    on_skin = np.isin(labels[triangles[:, 0]], skin_labels)
    skin_triangles = triangles[on_skin]
    yield 0.02

    points, normals = area_samples(vertices, skin_triangles, SAMPLES)
    similarity, score = yield from scaled(
        align(template.coarse_vertices, template.coarse_normals, points, normals), 0.02, 0.3
    )

    similarity = _on_mid_plane(template, similarity, points, normals)
    # the skin in the template's frame, cut to the head the template covers
    local = similarity.inverse_apply(vertices)
    lo, hi = template.vertices.min(axis=0), template.vertices.max(axis=0)
    grow = CROP * (hi - lo)
    inside = np.all((local >= lo - grow) & (local <= hi + grow), axis=1)
    kept = skin_triangles[inside[skin_triangles].all(axis=1)]
    if len(kept) < MIN_VERTICES:
        raise PlacementError("no head was found: the mesh has no part shaped like the template head")
    surface = Surface(local, kept)
    features = _features(template, local, kept)
    yield 0.35

    shaped, coefficients = fit_shape(
        template.coarse_vertices,
        template.coarse_triangles,
        template.shape_basis,
        surface,
        border_vertices(template.coarse_triangles, len(template.coarse_vertices)),
    )
    yield 0.4
    coarse, _affine = yield from scaled(
        register(shaped, template.coarse_triangles, surface, features=features), 0.4, 0.9
    )

    placed, confidence, estimated = _transfer(template, shaped, coefficients, coarse, surface)
    placed, plane = _symmetric(template, placed, surface)
    parts = _parts(local, triangles, labels, skin_labels)
    placed, confidence, estimated = _on_parts(template, placed, confidence, estimated, parts, plane)
    _check_head(template, placed, score)
    yield 1.0
    return Placement(
        positions=similarity.apply(placed),
        confidence=confidence,
        estimated=tuple(estimated),
        axes=TEMPLATE_AXES @ similarity.rotation.T,
        scale=similarity.scale,
    )


def _on_mid_plane(template, similarity: Similarity, points: np.ndarray, normals: np.ndarray) -> Similarity:
    """The rigid fit turned and moved so that the template's mid-plane is the skin's own plane of symmetry
    (`symmetry.surface_mid_plane`, from the skin samples in the fitted template's box): a face is nearly
    symmetric whatever its shape, so its mid-plane does not depend on how like the template it is, where
    the fit's yaw and roll can be pulled by what the template lacks (shoulders, hair, a bust's base)."""
    local = similarity.inverse_apply(points)
    local_normals = normals @ similarity.rotation
    lo, hi = template.vertices.min(axis=0), template.vertices.max(axis=0)
    inside = np.all((local >= lo) & (local <= hi), axis=1)
    left = TEMPLATE_AXES[0]
    plane = surface_mid_plane(local[inside], local_normals[inside], MidPlane(left, 0.0))
    turn = _turn(left, plane.normal)
    centre = local[inside].mean(axis=0)
    before = centre - (centre @ left) * left
    after = plane.project(centre)
    # template -> local: x -> turn @ (x - before) + after, then local -> world by the fit
    rotation = similarity.rotation @ turn
    translation = similarity.apply(after) - similarity.scale * rotation @ before
    return Similarity(rotation, similarity.scale, translation)


def _turn(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least rotation taking unit vector `a` to unit vector `b` (not opposite)."""
    axis = np.cross(a, b)
    sine, cosine = np.linalg.norm(axis), float(a @ b)
    if sine < 1e-15:
        return np.eye(3)
    k = axis / sine
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + sine * cross + (1.0 - cosine) * cross @ cross


def _head_of_body(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The triangles of the head and neck when the mesh is a whole body (`body.head_region`), else all."""
    points, _normals = area_samples(vertices, triangles, BODY_SAMPLES)
    region = head_region(points)
    if region is None:
        return triangles
    return triangles[region.contains(vertices)[triangles].all(axis=1)]


def carry_on_surface(points: np.ndarray, rest: Surface, deformed: np.ndarray) -> np.ndarray:
    """Points on or near the template's skin moved with the registration: each is embedded in the decimated
    template (closest triangle, barycentric weights, offset along the normal) and rebuilt on the same
    triangle of the `deformed` vertices."""
    on_rest, triangle, weights = rest.locate(points)
    corners = rest.triangles[triangle]
    offset = ((points - on_rest) * _triangle_normals(rest.vertices, corners)).sum(1)
    moved = np.einsum("kj,kjd->kd", weights, deformed[corners])
    return moved + offset[:, None] * _triangle_normals(deformed, corners)


def _triangle_normals(vertices: np.ndarray, corners: np.ndarray) -> np.ndarray:
    a, b, c = (vertices[corners[:, j]] for j in range(3))
    normals = np.cross(b - a, c - a)
    return normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)


def carry_inside(points: np.ndarray, rest: np.ndarray, deformed: np.ndarray) -> np.ndarray:
    """Points away from the skin (7.1, the pupils, teeth and tongue) moved by the affine map that best takes
    the template's vertices around them to their registered places (weighted least squares, the weights
    falling off over twice the point's distance to the skin), not by any one vertex's transform."""
    tree = cKDTree(rest)
    moved = np.empty_like(points)
    homogeneous = np.hstack([rest, np.ones((len(rest), 1))])
    for k, point in enumerate(points):
        depth, _i = tree.query(point)
        sigma = max(2.0 * depth, INSIDE_REACH)
        weights = np.sqrt(np.exp(-((rest - point) ** 2).sum(1) / (2.0 * sigma * sigma)))
        affine, *_rest = np.linalg.lstsq(homogeneous * weights[:, None], deformed * weights[:, None], rcond=None)
        moved[k] = np.append(point, 1.0) @ affine
    return moved


def _features(template, local: np.ndarray, kept: np.ndarray):
    """Local heights of the template's decimated vertices and of the user's skin, both over area samples
    of the same density, and the matcher that pairs them (see `features`)."""
    template_samples, _n = area_samples(template.vertices, template.triangles, FEATURE_SAMPLES)
    template_heights = local_height(template.coarse_vertices, template.coarse_normals, template_samples, FEATURE_RADIUS)
    area = triangle_areas(local, kept).sum()
    template_area = triangle_areas(template.vertices, template.triangles).sum()
    count = int(np.clip(FEATURE_SAMPLES * area / template_area, FEATURE_SAMPLES // 4, 4 * FEATURE_SAMPLES))
    samples, normals = area_samples(local, kept, count, seed=1)
    heights = local_height(samples, normals, samples, FEATURE_RADIUS)
    return template_heights, FeatureMatcher(samples, normals, heights, FEATURE_WEIGHT)


def _transfer(template, shaped, coefficients, coarse, surface):
    """Skin FPs: their template vertex carried by the registration and snapped onto the skin; the others
    (7.1, pupils, teeth, tongue) first moved by the shape prior as the skin was (`template.fp_basis` with
    the fit's `coefficients`), then carried from the `shaped` template by the registration. Confidence from
    how well the skin around each FP was fitted (the residual distance of the decimated template's vertices
    around it)."""
    on_vertex = template.fp_vertices >= 0
    placed = np.empty_like(template.fp_positions)
    rest = Surface(template.coarse_vertices, template.coarse_triangles)
    carried = carry_on_surface(template.fp_positions[on_vertex], rest, coarse)
    placed[on_vertex], _normals = surface.closest(carried)
    k = len(template.fp_basis)
    prior = template.fp_positions + np.tensordot(coefficients[:k], template.fp_basis, axes=1) + coefficients[k:]
    placed[~on_vertex] = carry_inside(prior[~on_vertex], shaped, coarse)
    on_surface, _n = surface.closest(coarse)
    residual = np.linalg.norm(on_surface - coarse, axis=1)
    _d, around = cKDTree(template.coarse_vertices).query(template.fp_positions, k=NEIGHBOURS)
    confidence = np.exp(-((residual[around].mean(axis=1) / CONFIDENCE_RESIDUAL) ** 2))
    return placed, confidence, []


def _symmetric(template, placed, surface):
    """The carried points made mirror-symmetric across the face's own mid-plane (`symmetry`), the skin
    points snapped back onto the skin; and that mid-plane."""
    placed, plane = symmetrise(placed, np.arange(len(placed)))
    on_skin = template.fp_vertices >= 0
    placed[on_skin], _normals = surface.closest(placed[on_skin])
    placed = refine(placed, surface, TEMPLATE_AXES[2], plane)
    loops = boundary_loops(len(surface.vertices), surface.triangles)
    moved = []
    if loops:
        skin, _normals = area_samples(surface.vertices, surface.triangles, FEATURE_SAMPLES)
        moved = refine_openings(placed, surface.vertices, surface.triangles, loops, TEMPLATE_AXES, skin)
    if "2.2" not in moved:  # no opening between the lips: where they meet, if they meet along a slit
        outer = [fp_index(fp_id) for fp_id in read_slit(placed, surface, TEMPLATE_AXES)]
        outer = [row for row in outer if template.fp_vertices[row] >= 0]
        if outer:
            placed[outer], _normals = surface.closest(placed[outer])
    reference = (template.fp_positions, TEMPLATE_AXES)
    placed = subnasale(surface.vertices, surface.triangles, placed, plane.normal)
    axes = head_frame(placed, plane.normal, TEMPLATE_AXES[1], *reference)
    placed = ear_tops(surface, placed, plane, axes[1])
    placed = read_skull(surface.vertices, surface.triangles, placed, plane.normal, TEMPLATE_AXES[1], *reference)
    return placed, plane


def _parts(local, triangles, labels, skin_labels):
    """The loose pieces that are not skin, each as (vertices, triangles) in the template's frame."""
    parts = []
    for label in np.setdiff1d(np.unique(labels[triangles[:, 0]]), skin_labels):
        own = triangles[labels[triangles[:, 0]] == label]
        used, renumbered = np.unique(own, return_inverse=True)
        parts.append((local[used], renumbered.reshape(-1, 3)))
    return parts


def _on_parts(template, placed, confidence, estimated, parts, plane: MidPlane):
    """Pupils onto eyeballs, teeth and tongue points onto the pieces in the mouth and their ends
    (`mouth_parts`, whose definitions then give those points' confidence); where there is no such piece the
    carried estimate stays, with a low confidence, and is named in `estimated`."""
    forward = TEMPLATE_AXES[2]
    eyeballs = find_eyeballs(parts, placed[[fp_index("3.5"), fp_index("3.6")]])
    for fp_id, eyeball in zip(("3.5", "3.6"), eyeballs, strict=True):
        row = fp_index(fp_id)
        if eyeball is None:
            estimated.append(fp_id)
            confidence[row] = min(confidence[row], ESTIMATE_CONFIDENCE)
        else:
            placed[row] = pupil_on_eyeball(eyeball, placed[row], forward)
    used = {id(e) for e in eyeballs if e is not None}
    mouth_parts = [p for p in parts if id(p) not in used]
    reached = {}  # FP id -> the mouth part its estimate snapped onto
    estimates = placed.copy()
    for fp in FEATURE_POINTS:
        if fp.surface not in ("teeth", "tongue"):
            continue
        row = fp_index(fp.id)
        best = None
        for index, (vertices, triangles) in enumerate(mouth_parts):
            q, _n = Surface(vertices, triangles).closest(placed[row : row + 1])
            distance = float(np.linalg.norm(q[0] - placed[row]))
            if distance < PART_REACH and (best is None or distance < best[0]):
                best = (distance, q[0], index)
        if best is not None:
            placed[row] = best[1]
            reached[fp.id] = best[2]
    on_piece, read = mouth_ends(placed, estimates, reached, mouth_parts, plane, TEMPLATE_AXES)
    for fp_id in read:
        confidence[fp_index(fp_id)] = READ_CONFIDENCE[fp_id]
    for fp in FEATURE_POINTS:
        if fp.surface in ("teeth", "tongue") and fp.id not in on_piece:
            estimated.append(fp.id)
            confidence[fp_index(fp.id)] = min(confidence[fp_index(fp.id)], ESTIMATE_CONFIDENCE)
    row = fp_index("7.1")
    confidence[row] = min(confidence[row], 0.6)  # inside the neck: no surface says where it is
    return placed, confidence, estimated


def _recesses(points: np.ndarray) -> dict[str, float]:
    """How far (template metres, along forward) each inner eye corner lies behind the inner end of its brow
    (the eye socket: 11 mm on the template, 13 to 17 mm on the development heads, 4 mm on a sphere)."""
    depth = points @ TEMPLATE_AXES[2]

    def d(fp_id):
        return depth[fp_index(fp_id)]

    return {
        "left eye": d("4.1") - d("3.11"),
        "right eye": d("4.2") - d("3.8"),
    }


def _check_head(template, placed: np.ndarray, fit_score: float) -> None:
    """Refuse what is not a head, saying what was not found: a shape far from any head's (a sphere, a box),
    or no eye socket below the brow where the registered template has them."""
    if fit_score > FIT_LIMIT:
        raise PlacementError(
            "this mesh does not look like a human head: no nose, eyes or mouth were found (its shape stays "
            f"{1000 * fit_score:.0f} mm from the template head's after the best fit; heads fit within "
            f"{1000 * FIT_LIMIT:.0f} mm); nothing was placed"
        )
    reference = _recesses(template.fp_positions)
    found = _recesses(placed)
    missing = [name for name, depth in found.items() if depth < RECESS_SHARE * reference[name]]
    if missing:
        raise PlacementError(
            "this mesh does not look like a human head: no "
            + " and no ".join(f"{name} (socket below the brow)" for name in missing)
            + " was found where the template head has them; nothing was placed"
        )
