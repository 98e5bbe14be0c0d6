"""Lip crossing, measured and guarded, on a hand-made mouth of two flat lips (face frame: x left, y up)."""

import numpy as np
import pytest

from addon.deform.folds import count_inverted
from addon.deform.lips import MEET_GAP, bind_lip_guard, guard_lips, lip_penetration, mouth_sides, press_apart
from addon.deform.overlaps import crossing_pairs, crossings
from addon.mpeg4.feature_points import FP_IDS as ALL_FP_IDS
from addon.mpeg4.feature_points import fp_index

FACE = np.eye(3)  # the test mesh is built in the face frame
XS = np.linspace(-0.025, 0.025, 11)  # 5 mm apart, mirror-symmetric about x = 0
ZS = np.array([0.0, 0.004, 0.008])
GAP = 0.0005  # each lip's surface lies this far from y = 0 at rest
FP_IDS = ("2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9")


def sheet(y: float, faces_up: bool) -> tuple[np.ndarray, np.ndarray]:
    """A flat grid at height y over XS x ZS: (vertices, triangles facing up or down), mirror-symmetric in x."""
    x, z = np.meshgrid(XS, ZS, indexing="ij")
    vertices = np.stack([x.ravel(), np.full(x.size, y), z.ravel()], axis=1)
    tris = []
    for i in range(len(XS) - 1):
        for j in range(len(ZS) - 1):
            a, b, c, d = i * len(ZS) + j, i * len(ZS) + j + 1, (i + 1) * len(ZS) + j, (i + 1) * len(ZS) + j + 1
            if XS[i + 1] > 0.0:
                tris += [(a, b, c), (c, b, d)] if faces_up else [(a, c, b), (c, d, b)]
            else:  # the mirror image's diagonal: the mesh is mirror-symmetric (the guard's carry follows its edges)
                tris += [(a, b, d), (a, d, c)] if faces_up else [(a, d, b), (a, c, d)]
    return vertices, np.array(tris)


def mouth():
    """Rest vertices, triangles, upper and lower masks, and the inner-lip FPs of the hand-made mouth."""
    top, top_tris = sheet(GAP, faces_up=False)
    bottom, bottom_tris = sheet(-GAP, faces_up=True)
    rest = np.concatenate([top, bottom])
    triangles = np.concatenate([top_tris, bottom_tris + len(top)])
    upper = np.arange(len(rest)) < len(top)
    fps = np.array([
        [0.0, GAP, 0.004], [0.0, -GAP, 0.004], [0.025, 0.0, 0.004], [-0.025, 0.0, 0.004],
        [0.0125, GAP, 0.004], [-0.0125, GAP, 0.004], [0.0125, -GAP, 0.004], [-0.0125, -GAP, 0.004],
    ])  # fmt: skip
    return rest, triangles, upper, ~upper, fps


def pressed(rest, upper, fps, amount):
    """The upper lip pushed down by `amount` x a bump that is 2 mm at the mid line; 2.2 meets 2.3."""
    deformed = rest.copy()
    bump = np.cos(np.pi * rest[:, 0] / 0.05) ** 2
    deformed[upper, 1] -= amount * 0.002 * bump[upper]
    points = fps.copy()
    points[0, 1] = -GAP
    return deformed, points


def depth(positions, triangles, upper, lower):
    into_lower, into_upper = lip_penetration(positions, triangles, upper, lower, axes=FACE)
    return max(np.nanmax(into_lower), np.nanmax(into_upper))


def test_penetration_of_two_flat_lips_by_hand():
    rest, triangles, upper, lower, _ = mouth()
    into_lower, into_upper = lip_penetration(rest, triangles, upper, lower, axes=FACE)
    np.testing.assert_allclose(into_lower[upper], -2 * GAP)  # 1 mm of clearance everywhere
    np.testing.assert_allclose(into_upper[lower], -2 * GAP)
    assert np.all(np.isnan(into_lower[lower])) and np.all(np.isnan(into_upper[upper]))
    sunk = rest.copy()
    sunk[upper, 1] -= 3 * GAP  # the upper lip 0.5 mm into the lower one
    into_lower, into_upper = lip_penetration(sunk, triangles, upper, lower, axes=FACE)
    np.testing.assert_allclose(into_lower[upper], GAP)
    np.testing.assert_allclose(into_upper[lower], GAP)


def test_the_guard_keeps_the_rest_mesh_and_a_mouth_apart_unchanged():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    out = rest.copy()
    guard_lips(guard, out, fps)
    np.testing.assert_array_equal(out, rest)
    opened = rest.copy()
    opened[lower, 1] -= 0.01
    out = opened.copy()
    guard_lips(guard, out, fps)
    np.testing.assert_array_equal(out, opened)


@pytest.mark.parametrize("amount", [0.75, 1.0])
def test_a_lip_pushed_into_the_other_stops_at_contact(amount):
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    deformed, points = pressed(rest, upper, fps, amount)
    before = depth(deformed, triangles, upper, lower)
    assert before == pytest.approx(amount * 0.002 - 2 * GAP)  # 0.5 mm and 1 mm into the lower lip
    guard_lips(guard, deformed, points)
    assert depth(deformed, triangles, upper, lower) <= 1e-12
    assert depth(deformed, triangles, upper, lower) > -1e-4  # the lips touch: no gap opened
    np.testing.assert_array_equal(deformed[:, [0, 2]], rest[:, [0, 2]])  # moved up and down only


def test_the_guard_is_mirror_symmetric():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    flip = np.array([-1.0, 1.0, 1.0])
    mirror = np.array([np.argmin(np.linalg.norm(rest - v * flip, axis=1)) for v in rest])
    rng = np.random.default_rng(2)
    deformed = rest + rng.normal(0.0, 0.0008, rest.shape) * [0.0, 1.0, 0.0]
    deformed[upper, 1] -= 0.001  # the upper lip into the lower one, unevenly
    out = deformed.copy()
    guard_lips(guard, out, fps)
    out_mirrored = deformed[mirror] * flip
    guard_lips(guard, out_mirrored, fps[[0, 1, 3, 2, 5, 4, 7, 6]] * flip)
    np.testing.assert_allclose(out_mirrored, out[mirror] * flip, atol=1e-15)


def test_the_guard_is_continuous():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    amounts = np.linspace(0.0, 1.5, 1501)
    outs = []
    for amount in amounts:
        deformed, points = pressed(rest, upper, fps, amount)
        guard_lips(guard, deformed, points)
        outs.append(deformed)
    step = np.abs(np.diff(np.array(outs), axis=0)).max()
    assert step <= 0.002 * (amounts[1] - amounts[0]) + 1e-15  # never more than the press itself moves


def test_the_guard_writes_into_any_memory_layout_alike():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    deformed, points = pressed(rest, upper, fps, 1.0)
    rows, columns = deformed.copy(), np.asfortranarray(deformed)
    guard_lips(guard, rows, points)
    guard_lips(guard, columns, points)
    assert not np.array_equal(rows, deformed)
    np.testing.assert_array_equal(columns, rows)


def mouth_with_skin():
    """The hand-made mouth whose upper lip's front edge (z = 8 mm) turns up into the skin above it: a row of
    faces standing 2 mm tall. Also the front edge's and the skin row's vertices, x ascending."""
    rest, triangles, upper, lower, fps = mouth()
    n = len(XS)
    edge = np.flatnonzero(upper & np.isclose(rest[:, 2], ZS[-1]))
    skin = rest[edge] + [0.0, 0.002, 0.001]
    rest = np.concatenate([rest, skin])
    above = len(rest) - n + np.arange(n)
    wall = [(edge[i], above[i], edge[i + 1]) for i in range(n - 1) if XS[i + 1] > 0.0]
    wall += [(edge[i], above[i], above[i + 1]) for i in range(n - 1) if XS[i + 1] <= 0.0]
    wall += [(edge[i + 1], above[i], above[i + 1]) for i in range(n - 1) if XS[i + 1] > 0.0]
    wall += [(edge[i], above[i + 1], edge[i + 1]) for i in range(n - 1) if XS[i + 1] <= 0.0]
    triangles = np.concatenate([triangles, wall])
    upper, lower = np.r_[upper, np.zeros(n, bool)], np.r_[lower, np.zeros(n, bool)]
    return rest, triangles, upper, lower, fps, edge, above


def test_the_skin_beside_a_pushed_lip_follows_it_and_no_face_turns_over():
    """The deformer takes lip and skin 4 mm down at the mid line; the guard lifts the lip back onto the
    seam. Moving the lip alone (the old guard) would put its edge above the skin row and turn those faces
    over; the skin carried along keeps them standing."""
    rest, triangles, upper, lower, fps, edge, above = mouth_with_skin()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    deformed, points = pressed(rest, upper | ~lower, fps, 2.0)
    assert count_inverted(rest, deformed, triangles) == 0
    old = deformed.copy()
    old[upper, 1] = np.maximum(old[upper, 1], -GAP)  # the lip alone lifted onto the seam (here at most -GAP)
    assert count_inverted(rest, old, triangles) > 0
    guard_lips(guard, deformed, points)
    assert depth(deformed, triangles, upper, lower) <= 1e-12
    assert count_inverted(rest, deformed, triangles) == 0
    assert np.all(deformed[above, 1] > deformed[edge, 1])  # the skin still stands above the lip's edge


def test_a_fold_of_a_lip_moves_as_one():
    """A flap of the lower lip's skin over a lower-lip vertex v, joined to it (as where the lip's skin turns up into a
    mouth corner): v has its own lip straight above it, so it is carried with the skin around it, not guarded (the old
    guard pushed each layer of such a fold onto the seam by its own amount, through each other). The deformer raises v
    and the flap alike 0.8 mm, past the seam (y = 0) by 0.3 and 0.5 mm: the flap goes back onto the seam (MEET_GAP / 2
    on its side) and v is carried down by the flap's push times the falloff of its nearest guarded vertex's distance, 1
    - smoothstep(d / 8 mm), and, as a corner of the triangles straight behind the flap's vertices, by their mean push on
    top (`_shadowed`'s pairs): at least as far as the flap, so it stays under it."""
    rest, triangles, upper, lower, fps = mouth()
    v = int(np.flatnonzero(lower & np.isclose(rest[:, 0], 0.0) & np.isclose(rest[:, 2], ZS[1]))[0])
    flap = rest[v] + np.array([[-0.001, 0.0002, -0.001], [0.001, 0.0002, -0.001], [0.0, 0.0002, 0.001]])
    f1, f2, f3 = len(rest) + np.arange(3)
    rest = np.concatenate([rest, flap])
    triangles = np.concatenate([triangles, [(v, f2, f1), (f1, f2, f3)]])
    upper, lower = np.r_[upper, False, False, False], np.r_[lower, True, True, True]
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert v not in guard.vertices and v in guard.skin
    assert np.isin([f1, f2, f3], guard.vertices).all()
    deformed = rest.copy()
    deformed[[v, f1, f2, f3], 1] += 0.0008
    guard_lips(guard, deformed, fps)
    np.testing.assert_allclose(deformed[[f1, f2, f3], 1], -MEET_GAP / 2, atol=1e-15)  # onto the seam, a hair below
    t = np.linalg.norm(flap[0] - rest[v]) / 0.008
    push = 0.0005 + MEET_GAP / 2
    assert deformed[v, 1] == pytest.approx(0.0003 - push * (2.0 - t * t * (3.0 - 2.0 * t)), abs=1e-15)
    assert deformed[v, 1] < 0.0


def test_a_lip_vertex_folded_over_its_own_lip_takes_the_triangle_behind_along():
    """A quad of the lower lip folded onto itself (a jittered subdivision's): its fourth corner u lies 0.1 mm straight
    over its other triangle ABC, inside it and over none of its corners. The seam bends down to 2.2-2.3 met at x = 0
    (-0.5 mm, -0.34 at A and B's x = 4 mm) under the upper lip pressed down to it: ABC's corners lie below it, u
    0.18 mm above it. The old guard pushed u alone onto the seam, below ABC's plane there (-0.42 mm at rest):
    through it. Now ABC's corners, behind u, take u's push too, and u stays over ABC."""
    rest, triangles, upper, lower, fps = mouth()
    mm = 0.001
    quad = np.array([[-4, -0.36, 10], [4, -0.36, 10], [0, -0.52, 14], [0, -0.32, 11.5]]) * mm  # A, B, C, u
    a, b, c, u = len(rest) + np.arange(4)
    rest = np.concatenate([rest, quad])
    triangles = np.concatenate([triangles, [(a, b, c), (a, u, b)]])
    upper, lower = np.r_[upper, [False] * 4], np.r_[lower, [True] * 4]
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert np.isin([a, b, c, u], guard.vertices).all()
    deformed, points = pressed(rest, upper, fps, 0.5)  # the upper lip down to -0.5 mm at x = 0; 2.2 meets 2.3
    guard_lips(guard, deformed, points)
    assert deformed[u, 1] <= -GAP + 1e-12  # onto the seam (or below, under the upper lip's triangles)
    below = 0.625 * deformed[[a, b], 1].mean() + 0.375 * deformed[c, 1]  # ABC's plane under u (x = 0, z = 11.5 mm)
    assert deformed[u, 1] > below


def tucked_mouth(slope: float = 1.0, apart: float = 2 * GAP):
    """The hand-made mouth with its lips on a sloping contact: both sheets rise by `slope` x how far they lie behind
    the front (z = 8 mm), the upper lip 1 mm over the lower one (GAP each side of the contact), so going back the
    lower lip stands up to 8 mm higher than the upper lip's front edge, behind it (a closed mouth whose lower lip tucks
    in behind the upper one, as the Rocketbox's does by 2 mm). The FPs stay at the front, where the lips meet."""
    rest, triangles, upper, lower, fps = mouth()
    rest = rest.copy()
    rest[:, 1] += slope * (ZS[-1] - rest[:, 2]) + np.where(upper, 0.5, -0.5) * (apart - 2 * GAP)
    return rest, triangles, upper, lower, fps


@pytest.mark.parametrize(("apart", "kept", "crossed"), [(0.001, 0.0, 14), (0.0002, 0.0002, 12)])
def test_lips_sliding_on_a_sloping_contact_are_kept_out_of_each_other(apart, kept, crossed):
    """The lower lip slid forward on the sloping contact by 2 mm x a bump along the mouth (cos^2, 0 at the ends; the
    Rocketbox's and the scan's lips in speech): at the mid line each lower vertex goes into the upper lip as the upper
    lip stands in its column, toward the ends the lips stay apart, and triangle pairs cross between. The seam (between
    2.2 and 2.3 at the front) is passed at rest by every lower vertex behind the front, which keeps that as slack: the
    seam's guard leaves the pairs crossed. `press_apart` takes those vertices, the seam's contact, down out of the
    upper lip, and where the lips touch at rest (0.2 mm apart, under TOUCH_GAP) as far from it as at rest: no pair
    crossing, and only straight down. 1 mm apart at rest they may come closer (the seam lets lips press)."""
    rest, triangles, upper, lower, fps = tucked_mouth(apart=apart)
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert np.all(guard.slack[guard.side < 0][rest[guard.vertices[guard.side < 0], 2] < ZS[-1]] < 0.0)
    assert guard.contact is not None  # every seam knot has lower vertices past it: every lip vertex is in the contact
    np.testing.assert_array_equal(np.sort(guard.contact.rows), np.arange(len(guard.vertices)))
    contact = guard.contact
    z = rest[contact.vertices][contact.ends].mean(axis=1)[:, 2]  # the samples': vertices, edges' middles
    behind = (z > ZS[0]) & (z < ZS[-1])
    square = max(kept / np.sqrt(2.0), MEET_GAP)  # square to the contact; lips farther apart may come MEET_GAP close
    np.testing.assert_allclose(contact.keep[behind], -square, atol=1e-15)
    assert np.all(contact.keep[~behind] <= 0.0)  # at the edges the other lip may not be behind: nothing kept then
    out = rest.copy()
    guard_lips(guard, out, fps)
    press_apart(guard, out)
    np.testing.assert_allclose(out, rest, rtol=0.0, atol=1e-15)  # the mouth at rest is left as it is (to rounding)
    slid = rest.copy()
    slid[lower, 2] += 0.002 * np.cos(np.pi * rest[lower, 0] / 0.05) ** 2
    out = slid.copy()
    guard_lips(guard, out, fps)
    assert crossings(out, triangles) == crossed  # the seam's guard leaves them crossed
    seamed = out.copy()
    assert press_apart(guard, out)
    assert crossings(out, triangles) == 0
    assert depth(out, triangles, upper, lower) <= -kept + 1e-12  # out of it, and a touch kept
    moved = out - seamed  # square to the contact, into each one's own lip: the upper up and forward, the lower down
    np.testing.assert_array_equal(moved[:, 0], 0.0)  # and back
    np.testing.assert_allclose(moved[:, 1], moved[:, 2], rtol=1e-9, atol=1e-15)
    assert np.all(moved[lower, 1] <= 0.0) and np.all(moved[upper, 1] >= 0.0) and moved[lower, 1].min() < 0.0


def test_a_mouth_whose_seam_parts_its_lips_at_rest_has_no_contact():
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert guard.contact is None
    out = rest.copy()
    out[upper, 1] -= 0.003
    assert not press_apart(guard, out)


def test_lips_overlapping_at_rest_by_less_than_a_touch_are_parted_as_they_slide():
    """The sloping contact with the lips passing 0.1 mm into each other at rest (under TOUCH_GAP: the Rocketbox's
    corners; parallel, no pair crosses), the lower lip slid forward as above. Kept as deep as at rest (the vertical
    depth, its allowance), the contact pushed the lips into 20 crossing pairs; parted to touching, square to the
    contact, none."""
    rest, triangles, upper, lower, fps = tucked_mouth(apart=-0.0001)
    at_rest = crossing_pairs(rest, triangles)  # none: each sheet lies in the other's flesh, parallel to it
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    assert guard.contact is not None and np.all(guard.contact.keep <= 0.0)  # no depth allowed
    slid = rest.copy()
    slid[lower, 2] += 0.002 * np.cos(np.pi * rest[lower, 0] / 0.05) ** 2
    out = slid.copy()
    guard_lips(guard, out, fps)
    assert press_apart(guard, out)
    assert crossings(out, triangles, None, at_rest) == 0
    assert depth(out, triangles, upper, lower) <= 1e-12


def cornered_mouth():
    """The hand-made mouth with its corners' FPs 1 mm in front of its back row (z = 0): that row is the crease behind
    the corners where the lips are one (both masks 1/2, as ICT's inner mouth corners), the upper sheet's row facing
    down onto the lower sheet's, facing up. Rest, triangles, the masks and the (84, 3) neutral FPs (8.1, 8.2 5 mm
    above and below the lips)."""
    rest, triangles, upper, lower, fps = mouth()
    fps = fps + [0.0, 0.0, -0.003]
    neutral = np.zeros((len(ALL_FP_IDS), 3))
    for fp_id, point in zip(FP_IDS, fps, strict=True):
        neutral[fp_index(fp_id)] = point
    neutral[fp_index("8.1")], neutral[fp_index("8.2")] = [0.0, 0.005, 0.001], [0.0, -0.005, 0.001]
    crease = rest[:, 2] < fps[0, 2]
    masks = [np.where(crease, 0.5, side.astype(float)) for side in (upper, lower)]
    return rest, triangles, masks, fps, neutral, crease


def test_the_crease_behind_the_mouth_corners_is_guarded_by_the_way_its_skin_faces():
    """Behind the corners' FPs the box once ended (`mouth_sides`): the crease there, whose masks say both lips, was
    only carried, and where the deformer put its lower wall up through the upper one (ICT's inner corners in the
    smile: 12 crossing pairs, 10 of them made by the carry shearing the crease) nothing parted them. Now the skin up
    to the box's margin behind the corners is in, its side the way it faces: the upper wall faces down, the lower up."""
    rest, triangles, masks, fps, neutral, crease = cornered_mouth()
    upper, lower = mouth_sides(rest, *masks, neutral, axes=FACE, triangles=triangles)
    top = np.arange(len(rest)) < len(rest) // 2
    np.testing.assert_array_equal(upper, top)
    np.testing.assert_array_equal(lower, ~top)
    old_upper, old_lower = mouth_sides(rest, *masks, neutral, axes=FACE)
    np.testing.assert_array_equal(old_upper | old_lower, ~crease)  # without the faces: the crease is in neither
    deformed = rest.copy()
    wall = ~top & crease
    deformed[wall] += [0.0, 0.0015, 0.001] * np.cos(np.pi * rest[wall, :1] / 0.05) ** 2  # up through the upper wall
    assert crossings(deformed, triangles) > 0
    for sides, crossed in (((old_upper, old_lower), True), ((upper, lower), False)):
        guard = bind_lip_guard(rest, fps, FP_IDS, triangles, *sides, axes=FACE)
        out = deformed.copy()
        guard_lips(guard, out, fps)
        assert (crossings(out, triangles) > 0) == crossed
    assert depth(out, triangles, upper, lower) <= 1e-12
    assert count_inverted(rest, out, triangles) == 0


def test_lips_pressed_onto_each_other_are_kept_a_hair_apart():
    """Pressed onto the one seam, both lips lay exactly on it, on each other: two faceted sheets whose crossing was
    decided by rounding (ICT's demo frame 84: 19 pairs in the middle of its mouth, where the lips are parted at rest).
    Now each stays half of MEET_GAP on its side of the seam: pressed, they are MEET_GAP apart, and a mouth apart at rest
    is still left as it is."""
    rest, triangles, upper, lower, fps = mouth()
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    out = rest.copy()
    guard_lips(guard, out, fps)
    np.testing.assert_array_equal(out, rest)
    deformed, points = pressed(rest, upper, fps, 1.0)
    deformed[lower, 1] += 0.001 * np.cos(np.pi * rest[lower, 0] / 0.05) ** 2  # the lower lip up into it as well
    guard_lips(guard, deformed, points)
    into_lower, into_upper = lip_penetration(deformed, triangles, upper, lower, axes=FACE)
    assert max(np.nanmax(into_lower), np.nanmax(into_upper)) == pytest.approx(-MEET_GAP, abs=1e-12)


def deep_crease_mouth():
    """`cornered_mouth` with its corners' FPs 0.5 mm behind its front row: the two rows behind, 3.5 and 7.5 mm behind
    the corners, are the crease where the lips meet inside the mouth (as the scan's slit runs on 5-7 mm behind its
    corners), and 100 mm behind, at the lips' height, a patch of two triangles whose masks say lips (made masks reaching
    the back of a head), joined to nothing."""
    rest, triangles, masks, fps, neutral, _ = cornered_mouth()
    shift = [0.0, 0.0, 0.0065]
    fps, neutral = fps + shift, neutral + shift
    crease = rest[:, 2] < fps[0, 2]
    masks = [np.where(crease, 0.5, side > 0.5) for side in masks]
    patch = np.array([[0.001, 0.0002, -0.1], [-0.001, 0.0002, -0.1], [0.0, -0.0002, -0.102], [0.0, 0.0002, -0.102]])
    n = len(rest)
    rest = np.concatenate([rest, patch])
    triangles = np.concatenate([triangles, [(n, n + 1, n + 2), (n + 1, n, n + 3)]])
    masks = [np.r_[m, [0.5] * 4] for m in masks]
    return rest, triangles, masks, fps, neutral, crease


def test_the_crease_is_guarded_as_deep_as_it_runs_on_from_the_lips():
    """The crease behind the corners was taken BOX_MARGIN deep (`mouth_sides`): a crease running deeper (the scan's
    slit, its walls sheared by the carry at its left end, 9-12 crossing pairs in most demo frames) was left to the
    carry. Now it is taken as far as it runs on from the lips along the mesh, and a patch of lip mask joined to no lip
    is not."""
    rest, triangles, masks, fps, neutral, crease = deep_crease_mouth()
    upper, lower = mouth_sides(rest, *masks, neutral, axes=FACE, triangles=triangles)
    n = len(crease)
    top = np.arange(n) < n // 2
    np.testing.assert_array_equal(upper[:n], top)
    np.testing.assert_array_equal(lower[:n], ~top)
    assert not (upper[n:] | lower[n:]).any()  # the patch at the back joins no lip
    deformed = rest.copy()
    wall = np.r_[~top & crease, [False] * 4]
    deformed[wall] += [0.0, 0.0015, 0.001] * np.cos(np.pi * rest[wall, :1] / 0.05) ** 2  # up through the upper wall
    guard = bind_lip_guard(rest, fps, FP_IDS, triangles, upper, lower, axes=FACE)
    out = deformed.copy()
    guard_lips(guard, out, fps)
    assert crossings(out, triangles) == 0
    assert count_inverted(rest, out, triangles) == 0


def test_the_crease_joined_to_the_lips_is_found_along_edges_through_the_crease_alone():
    """A strip of triangles 0-1-2-3-4-5 (each joined to the next): from the lip vertex 0, the candidates 1 and 2 are
    reached; 4 and 5 only through 3, which is no candidate, so not; and that with numpy alone (no scipy)."""
    from addon.deform.lips import _joined

    triangles = np.array([[0, 1, 2], [1, 2, 3], [2, 3, 4], [3, 4, 5]])
    lips = np.array([True, False, False, False, False, False])
    candidates = np.array([False, True, False, False, True, True])
    assert _joined(triangles, candidates, lips).tolist() == [False, True, False, False, False, False]
    candidates[2] = True  # 2 joins 1 to 4 (triangle 2-3-4), and 4 to 5 (3-4-5 has the edge 4-5)
    assert _joined(triangles, candidates, lips).tolist() == [False, True, True, False, True, True]


def folded_corner_mouth(h: float = 2e-5):
    """The hand-made mouth with its lips going on past the left corner (x 25 mm) for two more columns, where each lip's
    skin turns onto the other's: the upper sheet there (x 26, 29, 36 mm) `h` above y = 0 facing down, the lower (x
    25.5, 30, 35 mm) `h` below it facing up, both masks 1 on their own lip (as the Rocketbox's commissures, whose two
    layers lie 0-0.12 mm apart on one plane, in front of its inner corners). Rest, triangles, masks, the eight
    inner-lip FPs, the (84, 3) neutral FPs (8.1, 8.2 5 mm above and below) and each sheet's fold vertices."""
    sheets, folds, n = [], [], 0
    for y, faces_up, xs in (
        (GAP, False, np.r_[XS, 0.026, 0.029, 0.036]),
        (-GAP, True, np.r_[XS, 0.0255, 0.030, 0.035]),
    ):
        x, z = np.meshgrid(xs, ZS, indexing="ij")
        heights = np.where(x > XS[-1], -h if faces_up else h, y)
        vertices = np.stack([x.ravel(), heights.ravel(), z.ravel()], axis=1)
        tris = []
        for i in range(len(xs) - 1):
            for j in range(len(ZS) - 1):
                a, b, c, d = i * len(ZS) + j, i * len(ZS) + j + 1, (i + 1) * len(ZS) + j, (i + 1) * len(ZS) + j + 1
                tris += [(a, b, c), (c, b, d)] if faces_up else [(a, c, b), (c, d, b)]
        sheets.append((vertices, np.array(tris) + n))
        folds.append(n + np.flatnonzero(vertices[:, 0] > XS[-1]))
        n += len(vertices)
    rest = np.concatenate([v for v, _ in sheets])
    triangles = np.concatenate([t for _, t in sheets])
    top = np.arange(len(rest)) < len(sheets[0][0])
    _, _, _, _, fps = mouth()
    neutral = np.zeros((len(ALL_FP_IDS), 3))
    for fp_id, point in zip(FP_IDS, fps, strict=True):
        neutral[fp_index(fp_id)] = point
    neutral[fp_index("8.1")], neutral[fp_index("8.2")] = [0.0, 0.005, 0.004], [0.0, -0.005, 0.004]
    return rest, triangles, (top.astype(float), (~top).astype(float)), fps, neutral, folds


def test_the_lips_skin_folded_onto_itself_past_a_corner_is_kept_apart_by_the_contact():
    """Past the mouth's corners across the box ended (`mouth_sides`): where the lips' skin there lies in two layers on
    each other (the Rocketbox's commissures), both were only carried, each with its own mix of the two lips' pushes,
    and nothing kept one layer out of the other (its carried corner skin at 8.3 / 8.4: 1-5 crossing pairs a frame).
    Now that skin, touching a layer that faces the other way, is taken into the lips by the way it faces, held to no
    seam (the seam runs from corner to corner) and kept out of the other layer by the contact: the lower layer put up
    through the upper one is put back under it."""
    rest, triangles, masks, fps, neutral, (upper_fold, lower_fold) = folded_corner_mouth()
    upper, lower = mouth_sides(rest, *masks, neutral, axes=FACE, triangles=triangles)
    # the fold: each layer's vertices over the other layer's triangles past the corner (not over the ramp from the lips
    # in the box: the upper layer's last column has nothing under it, the lower's first lies under the upper's ramp)
    assert upper[upper_fold[:6]].all() and lower[lower_fold[3:]].all()
    assert not upper[upper_fold[6:]].any() and not lower[lower_fold[:3]].any()
    old_upper, old_lower = (m > 0.5 for m in masks)
    old_upper[upper_fold] = old_lower[lower_fold] = False  # the box across as it was: the corners' x
    deformed = rest.copy()
    lifted = lower_fold[np.isclose(rest[lower_fold, 0], 0.030)]
    deformed[lifted, 1] += 1e-4  # 0.1 mm up, through the upper layer 0.04 mm above
    assert crossings(deformed, triangles) > 0
    for sides, crossed in (((old_upper, old_lower), True), ((upper, lower), False)):
        guard = bind_lip_guard(rest, fps, FP_IDS, triangles, *sides, axes=FACE)
        out = deformed.copy()
        guard_lips(guard, out, fps)
        press_apart(guard, out, native=False)
        assert (crossings(out, triangles) > 0) == crossed
    assert count_inverted(rest, out, triangles) == 0
    np.testing.assert_array_less(out[lifted, 1], 2e-5)  # under the upper layer again
    np.testing.assert_array_less(np.abs(out[upper_fold, 1] - rest[upper_fold, 1]), 1e-4)  # which is not flung away
    rested = rest.copy()
    guard_lips(guard, rested, fps)
    press_apart(guard, rested, native=False)
    np.testing.assert_allclose(rested, rest, rtol=0.0, atol=1e-15)  # at rest nothing moves (but by rounding)
