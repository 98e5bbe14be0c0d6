"""The small dedicated deformations the recipe table names where FAPs cannot say an ARKit shape (no bpy).

Each one moves the face further than a recipe's FAPs do, the way the shape moves the face and no FAP does:
most take the feature points where the FAPs put them and move some of them, and the face's engine then
deforms the skin from these points as it plays FAPs; the jaw's turn moves the skin the engine deformed. They
shape Make ARKit Shape Keys only: a capture turned into a FAP stream, and the round trip FAP -> ARKit -> FAP,
stay with the recipes' FAP values (a stream carries FAPs, and a face plays a stream as the standard says).

- `jaw_hinge` (jawOpen) moves the skin: the mandible turns (its condyles turning and gliding forward
  together, a turn about a centre below them) instead of sliding straight down. open_jaw (FAP 3) is the
  vertical displacement of the chin 2.1, and the chin drops exactly that far; the turn also draws it back,
  as the mouth opens on a real jaw (ARKit: "opening of the lower jaw"). The engine deforms the face from the
  straight drop, and each vertex then turns by its own share of the jaw (what the engine's weights gave it of
  the chin's drop), so the skin between the chin and the turn's centre swings with the jaw instead of being
  interpolated straight down between the points.
- `whole_lip_push` (mouthPucker, mouthFunnel, mouthRoll*, cheekPuff: the lips pursed, everted or rolled in by
  orbicularis oris, or pushed by air): a lip pushed forward (or back) moves as a whole. push_b_lip / push_t_lip
  (FAPs 16, 17) are the only forward motions of the lips the standard has, and they move the inner mid-points
  2.3 / 2.2 alone; the lip's other points follow their lip's push, the corners the mean of both lips' on top
  of their `corner_slide` (AU 18/22: orbicularis oris purses and everts the lips all round; ARKit's rolls move
  a lip "toward the inside of the mouth"). Within it, `nose_base_push`: the nose's bottom edge beside each
  nostril (9.5, 9.4), which no FAP moves, lies on the skin between the nostril's border (9.1, 9.2, held by the
  alar cartilage) and the upper lip's outer point (8.5, 8.6), and a pushed lip drags that skin with it: the
  point comes forward (or goes back) by the two points' pushes blended by how far down from the border to the
  lip it lies at rest, as `bow_follow` blends the contour across. No size of its own.
- `mid_lip_push` (mouthShrugLower / Upper: mentalis, AU 17, and the upper lip's shrug push a lip out at its
  middle): the lip's outer edge 8.2 / 8.1 comes out as far as push_b_lip / push_t_lip moved its inner mid-point
  2.3 / 2.2 (ARKit: "outward movement of the lower lip", the lip, not its inner edge); its sides and the corners
  stay, as mentalis lifts the lip from below its middle.
- `corner_slide` (every recipe that moves a lip corner sideways: the smiles, dimples, stretches, and within
  `whole_lip_push` and `whole_lip_shift`): stretch_cornerlip moves a corner straight sideways (the
  standard's horizontal displacement), but the corner lies on the curved front of the teeth, between the lip
  and the cheek, and slides on it: out and back (buccinator's dimple, AU 14; ARKit: "backward movement of the
  left corner of the mouth"), in and forward (the pursed lips' corners, AU 18). Seen from above, the corner
  stays on the line of the face's surface at the corner, from its lip beside it (the mean of 2.6 and 2.8 for
  2.4) to the cheek's centre (5.1, "at the height of 8.3"), as far sideways as the FAPs moved it. No size of
  its own: the sideways distance is the recipe's, the slope the face's.
- `whole_lip_shift` (mouthLeft / Right: "movement of both lips to the left"): the lips slide sideways as a whole,
  but only the corners have a sideways FAP (stretch_cornerlip; no FAP moves 2.2, 2.3, 8.1, 8.2 or the lips' sides
  sideways). After `corner_slide`, every other point of both lips moves sideways as far as the two corners did
  together (their mean): both corners going the same way by the recipe's size, the lips go with them; no size of
  its own. Within it, `nose_base_shift`: the nose's bottom edge (9.5, 9.4 beside the nostrils and the mid-line's
  9.15), which no FAP moves, goes sideways as the skin between the nose (the nostril's border, the tip) and the
  upper lip's outer contour below it, by where it lies between them at rest, as `nose_base_push` does forward.
- `nostril_lift` (noseSneer*): levator labii superioris alaeque nasi lifts the nostril's wing and the upper
  lip beside it together (AU 9; ARKit: "raising of the left side of the nose around the nostril"). The
  nostril's FPs 9.1 / 9.2 have only a sideways FAP (stretch_l/r_nose) and raise_nose moves the midline tip
  9.3: each side's nostril points (9.1 and the nose's bottom edge 9.5 on the left; 9.2, 9.4 on the right)
  rise as far as the recipe lifted the upper lip's outer point beside them (8.5, 8.6), no size of their own.
- `nose_base_lift` (mouthUpperUp*): levator labii superioris lifts the upper lip (AU 10), and the lip's upper
  edge is the nose's bottom edge: where the lip meets the nose beside the nostril (9.5 on the left, 9.4 on the
  right) it rises with the lip, as far as the recipe lifted the lip's outer point below it (8.5, 8.6). No FAP
  moves 9.5 / 9.4, so with the FAPs alone the lifted lip was squeezed against a nose base that stayed. The
  nostril's border 9.1 / 9.2 stays (raising the ala is AU 9's, `nostril_lift`), and so does the midline's 9.15
  (the columella's base, on the nasal spine). No size of its own.
- `bow_follow` (every recipe, after its own deformation): the Cupid's bow's peaks 8.9 / 8.10 lie on the upper
  lip's outer contour between its mid-point 8.1 and the side points 8.5 / 8.6, and no FAP moves them, so with the
  FAPs alone every recipe that moved the upper lip bent its contour to two pinned points (a rolled upper lip
  left the peaks standing: looked at). Each peak moves as the contour does where it lies: the motions of 8.1 and
  of the side point beside it, blended by how far across from 8.1 to that point the peak lies at rest (face x).
  No size of its own; a uniform motion of the lip stays uniform.
- `infraorbital_lift` (every recipe, after its own deformation): FACS describes the upper lip's raiser (AU 10) and
  the lip corner puller (AU 12) as raising the infraorbital triangle, the skin below the lower lid beside the
  nose, which the cheek bone point 5.3 / 5.4 stands in and no FAP but lift_cheek moves. The skin there lies
  between the lower lid's centre 3.3 / 3.4 above, which holds it (a lid's own motion does not carry the cheek),
  and the upper lip below; when a recipe raises the lip (its corner 8.3 or its side point 8.5, whichever rises
  more), the cheek bone point rises by that rise times how far down from the lid to that point it lies at rest
  (0.31 of the corner's rise on the sample head). Not where a FAP moved it (cheekSquint's lift_cheek), not when
  the lip comes down. No size of its own.
- `cheek_puff` (cheekPuff: "outward movement of both cheeks", the air's pressure on the cheeks' walls): puff_cheek
  (FAPs 39, 40) moves the cheek points 5.1 / 5.2 straight sideways, the standard's horizontal displacement, but a
  pressure pushes a wall along its normal, and the cheek there faces forward as much as sideways (on the sample
  head its surface normal at 5.1 lies 38 deg forward of sideways). So each cheek point goes as far as the FAP
  moved it, along the face's outward surface normal at it (`surface_normals`, from the face's mesh at rest), and
  the lips come forward with the air behind them as in `whole_lip_push`. No size of its own: the distance is the
  FAP's, the direction the face's surface; without the mesh's normals the cheeks move sideways as the FAPs say.
- `tongue_forward` (tongueOut) moves a part, not feature points: the Blender layer moves the tongue part forward
  by the tip's thrust beyond the tongue body (arkit_keys), which the tongue part follows.
"""

from __future__ import annotations

import numpy as np

from ..geometry.face_axes import BLENDER_FACE_AXES
from ..mpeg4.feature_points import fp_index

# The jaw's turn (`hinge_axis`): the ear's lower contact points with the face (left, right), at the tragus, and the
# outer eye corners that Beyron's line from the tragus runs to; the pupils give the face's size (ES0).
HINGE_FPS = ("10.3", "10.4")
OUTER_EYE_CORNERS = ("3.7", "3.12")
PUPILS = ("3.5", "3.6")
# Adult sizes in metres, scaled to a face by its ES0 over an adult's:
ADULT_ES0 = 0.063  # the mean adult interpupillary distance (Dodgson 2004, 63 mm)
CONDYLE_BEFORE_TRAGUS = 0.013  # the condyle's centre, Beyron's point: 13 mm in front of the tragus, toward the
# outer eye corner (the arbitrary hinge axis of dentistry; 97-98 % of kinematic axes within 5 mm, Schallhorn)
TURN_BELOW_CONDYLE = 0.0324  # the centre of the mandible's turn over a full opening: 32.4 mm (+-7.4) below the
# condyle's centre and 0.2 mm behind it (Mehl et al. 2025, in vivo, tracked on CT-segmented bone)
# each lip's points that no FAP pushes forward, with the point whose push they follow (the upper lip's outer contour
# includes the Cupid's bow's peaks 8.9 / 8.10, as control_mesh.UPPER_LIP does); the corners follow both lips
LIP_FOLLOWERS = {
    "2.2": ("8.1", "2.6", "2.7", "8.5", "8.6", "8.9", "8.10"),
    "2.3": ("8.2", "2.8", "2.9", "8.7", "8.8"),
}
LIP_CORNERS = ("2.4", "2.5", "8.3", "8.4")
# each lip's outer mid-point, with the inner one whose push it follows in a shrug
LIP_MIDLINE = {"2.2": ("8.1",), "2.3": ("8.2",)}
# each lip corner, with the points whose line gives the face's surface there: its lip's points beside it (upper,
# lower) and the cheek's centre
CORNER_SLIDES = {
    "2.4": ("2.6", "2.8", "5.1"),
    "8.3": ("8.5", "8.7", "5.1"),
    "2.5": ("2.7", "2.9", "5.2"),
    "8.4": ("8.6", "8.8", "5.2"),
}
# each side's nostril points (the ala's border and its base on the nose's bottom edge), with the upper lip's
# outer point beside them that the same muscle lifts
NOSTRILS = {"8.5": ("9.1", "9.5"), "8.6": ("9.2", "9.4")}
# each side's point on the nose's bottom edge, where the upper lip meets the nose, with the lip's outer point below it
NOSE_BASES = {"8.5": ("9.5",), "8.6": ("9.4",)}
# the Cupid's bow's peaks (no FAP moves them), with the upper lip's outer contour points either side of each
BOW_PEAKS = {"8.10": ("8.1", "8.5"), "8.9": ("8.1", "8.6")}
# each side's point on the nose's bottom edge (no FAP moves it), with the nostril's border above it, which the
# alar cartilage holds, and the upper lip's outer point below it, which a lip's push moves (`nose_base_push`)
NOSE_BASE_SKIN = {"9.5": ("9.1", "8.5"), "9.4": ("9.2", "8.6")}
# each cheek bone point (no FAP but lift_cheek moves it), with the lower lid's centre above it, which holds the skin
# there, and the upper lip's points below it whose rise lifts the infraorbital triangle (`infraorbital_lift`)
INFRAORBITAL = {"5.3": ("3.3", ("8.3", "8.5")), "5.4": ("3.4", ("8.4", "8.6"))}
# the same with the mid-line's base 9.15 between the nose's tip and the upper lip's outer mid-point, for a sideways
# shift of the lips (`nose_base_shift`)
NOSE_BASE_SHIFT = {**NOSE_BASE_SKIN, "9.15": ("9.3", "8.1")}
# the cheeks' points puff_cheek moves, whose motion `cheek_puff` turns onto the face's outward surface normal
CHEEKS = ("5.1", "5.2")
# how much skin around a point its surface normal is the mean over (`surface_normals`), per ES0: the cheek's
# direction at 5.1, not a scan's pores (0.1 ES0, about 6 mm on an adult)
NORMAL_RADIUS_PER_ES0 = 0.1
FP_DEFORMATIONS = (
    "whole_lip_push",
    "mid_lip_push",
    "corner_slide",
    "whole_lip_shift",
    "nostril_lift",
    "nose_base_lift",
    "cheek_puff",
)
SKIN_DEFORMATIONS = ("jaw_hinge",)
PART_DEFORMATIONS = ("tongue_forward",)


def hinge_axis(face_neutral: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """A point on the axis the mandible turns about as the jaw opens, and its unit direction (face frame), or None
    without the ear points, the outer eye corners or the pupils.

    The mouth does not open about the jaw joints alone: the condyles turn and glide forward down the articular
    eminence together, and the turn and the glide add up to a turn about a centre below them. Measured over a
    full opening, that centre lies 32.4 mm below the condyle's centre and 0.2 mm behind it (Mehl et al. 2025;
    the 18-20 mm glide and 36-39 deg turn Muto and Kanazawa 1996 measured at full opening put it 28-31 mm
    below). The condyle's centre is Beyron's point, 13 mm in front of the tragus on the line to the outer eye
    corner; MPEG-4 has no FP on it, and the ear's lower contact points 10.3 / 10.4 sit at the tragus (on the
    sample head at its upper end, in front of the ear canal). The axis runs through both sides, along
    10.4 -> 10.3. Sizes are an adult's, scaled by the face's ES0.
    """
    left, right = face_neutral[[fp_index(fp) for fp in HINGE_FPS]]
    corners = face_neutral[[fp_index(fp) for fp in OUTER_EYE_CORNERS]]
    es0 = face_neutral[fp_index(PUPILS[0]), 0] - face_neutral[fp_index(PUPILS[1]), 0]
    direction = left - right
    length = np.linalg.norm(direction)
    if not (np.all(np.isfinite(corners)) and np.isfinite(length) and length > 0.0 and np.isfinite(es0) and es0 > 0):
        return None
    axis = direction / length
    tragus = 0.5 * (left + right)
    forward = corners.mean(axis=0) - tragus
    forward -= (forward @ axis) * axis
    if np.linalg.norm(forward) == 0.0:
        return None
    forward /= np.linalg.norm(forward)
    down = np.array([0.0, -1.0, 0.0]) + axis[1] * axis  # the face's down, square to the axis
    down /= np.linalg.norm(down)
    scale = es0 / ADULT_ES0
    return tragus + scale * (CONDYLE_BEFORE_TRAGUS * forward + TURN_BELOW_CONDYLE * down), axis


def rotate_about(points: np.ndarray, origin: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(K, 3) points each turned by its own angle (K,) about the line through `origin` along unit `axis`
    (right-handed; Rodrigues' formula)."""
    v = points - origin
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    along = (v @ axis)[:, None] * axis
    return origin + v * c + np.cross(axis, v) * s + along * (1.0 - c)


def hinge_angle(chin: np.ndarray, origin: np.ndarray, axis: np.ndarray, drop: float) -> float:
    """The turn about the hinge (radians, about `axis`) that lowers `chin` by `drop` (face frame, y up).

    The chin's height about the axis is h cos(a) + d sin(a) - h for a chin at `h` below and `d` in front of the
    axis (the turn lowers it); solving R sin(a + alpha) = drop + h, R = hypot(h, d), alpha = atan2(h, d). A
    drop beyond R - h (the chin at the bottom of its circle) stops there.
    """
    v = chin - origin
    v = v - (v @ axis) * axis
    down = np.cross(axis, v)[1]  # the chin's height change per radian at rest: -d for a forward chin
    h, d = -v[1], -down
    reach = np.hypot(h, d)
    if reach == 0.0:
        return 0.0
    return float(np.arcsin(np.clip((drop + h) / reach, -1.0, 1.0)) - np.arctan2(h, d))


def jaw_turn(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES):
    """The mandible's turn for FP positions whose chin 2.1 open_jaw has dropped: (a point on the hinge axis, its
    unit direction, the angle in radians), in mesh coordinates; None without the ear points or without a drop."""
    axes = np.asarray(axes, dtype=np.float64)
    face_neutral = np.asarray(neutral, dtype=np.float64) @ axes.T
    chin = fp_index("2.1")
    drop = face_neutral[chin, 1] - (np.asarray(points, dtype=np.float64)[chin] @ axes.T)[1]
    hinge = hinge_axis(face_neutral)
    if hinge is None or not np.isfinite(drop) or drop == 0.0:
        return None
    origin, axis = hinge
    return origin @ axes, axis @ axes, hinge_angle(face_neutral[chin], origin, axis, drop)


def jaw_hinge(
    neutral: np.ndarray,
    points: np.ndarray,
    rest: np.ndarray,
    straight: np.ndarray,
    axes: np.ndarray = BLENDER_FACE_AXES,
) -> np.ndarray:
    """(N, 3) points (mesh coordinates) of a face whose jaw open_jaw dropped straight, turned as the jaw turns
    (`hinge_axis`).

    `neutral` / `points`: the 84 FPs at rest and where the recipe's FAPs put them (the chin 2.1 dropped);
    `rest` / `straight`: any points of the face (its skin's vertices, or the FPs themselves) at rest and as the
    face's engine moved them from `points`. Each point follows the mandible by its own share of the jaw: how
    far it dropped against the chin (0..1; on the FPs decode.JAW_RIDERS: the chin, lower lip and teeth all,
    the lip corners half; on the skin whatever the engine's weights give each vertex). That share of the
    straight drop is taken back and the point turns instead by that share of the angle that lowers the chin
    as far as open_jaw did (`jaw_turn`): a vertex riding on the jaw swings about the hinge, perpendicular to
    its radius, instead of sliding down, and what other FAPs added to it stays. Without the ear points, or
    without a drop, the points stay as the engine put them. A point another FAP brought back up (mouthClose's lower
    lip over jawOpen) is measured where it ended: a lip raised back to the upper lip is left down by nothing of the
    jaw's drop, so it is turned by nothing of the jaw's angle and stays closed, as ARKit's "closure of the lips
    independent of jaw position" has it (measured on the jaw's drop alone, it turned all the way down and back
    with the mandible and kept only the raise on top, the lip left behind and below the upper one).
    """
    moved = np.array(straight, dtype=np.float64)
    turn = jaw_turn(neutral, points, axes)
    if turn is None:
        return moved
    origin, axis, angle = turn
    up = np.asarray(axes, dtype=np.float64)[1]  # the face's up, in mesh coordinates
    chin = fp_index("2.1")
    drop = (np.asarray(neutral, dtype=np.float64)[chin] - np.asarray(points, dtype=np.float64)[chin]) @ up
    rest = np.asarray(rest, dtype=np.float64)
    known = np.all(np.isfinite(rest), axis=1) & np.all(np.isfinite(moved), axis=1)
    share = np.zeros(len(rest))
    share[known] = np.clip(((rest[known] - moved[known]) @ up) / drop, 0.0, 1.0)
    turned = rotate_about(rest[known], origin, axis, share[known] * angle)
    moved[known] += turned - rest[known] + (share[known] * drop)[:, None] * up
    return moved


def _follow_push(
    neutral: np.ndarray, points: np.ndarray, followers: dict, corners: bool, axes: np.ndarray
) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each lip's `followers` pushed forward as far as its mid-point
    (2.2 upper, 2.3 lower: push_t_lip, push_b_lip), and with `corners` the corners by the mean of both."""
    axes = np.asarray(axes, dtype=np.float64)
    face_neutral = np.asarray(neutral, dtype=np.float64) @ axes.T
    moved = np.asarray(points, dtype=np.float64) @ axes.T
    push = {mid: moved[fp_index(mid), 2] - face_neutral[fp_index(mid), 2] for mid in followers}
    if not all(np.isfinite(p) for p in push.values()):
        return np.array(points, dtype=np.float64)
    for mid, follow in followers.items():
        moved[[fp_index(fp) for fp in follow], 2] += push[mid]
    if corners:
        moved[[fp_index(fp) for fp in LIP_CORNERS], 2] += 0.5 * sum(push.values())
    return moved @ axes


def whole_lip_push(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each lip's points pushed forward as far as its mid-point
    (2.2 upper, 2.3 lower: push_t_lip, push_b_lip) and the corners by the mean of both."""
    pushed = _follow_push(neutral, corner_slide(neutral, points, axes), LIP_FOLLOWERS, True, axes)
    return nose_base_push(neutral, pushed, axes)


def nose_base_push(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each side's point on the nose's bottom edge (9.5, 9.4) pushed
    forward (face z) as the skin between the nostril's border above it and the upper lip's outer point below it
    is where it lies: their pushes blended by how far down from the border to the lip's point it lies at rest
    (face y). Its height and its sideways place stay."""
    return _blend_between(neutral, points, axes, NOSE_BASE_SKIN, across=1, only=2)


def _blend_between(neutral, points, axes, between: dict, across: int, only: int | None = None) -> np.ndarray:
    """`points` with each FP `between` names moved as the skin between its two points (a, b) moves where it lies:
    their motions blended by how far across from a to b it lies at rest along face axis `across`; with `only`,
    along that face axis alone (its motion along the others kept)."""
    axes = np.asarray(axes, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    moved = np.array(points, dtype=np.float64)
    for fp, (a_fp, b_fp) in between.items():
        k, a, b = fp_index(fp), fp_index(a_fp), fp_index(b_fp)
        t = _share_between(neutral, k, a, b, axes[across])
        if t is None or not np.all(np.isfinite(moved[[a, b]])):
            continue
        blend = (1.0 - t) * (moved[a] - neutral[a]) + t * (moved[b] - neutral[b])
        if only is None:
            moved[k] = neutral[k] + blend
        else:
            moved[k] += ((blend - (moved[k] - neutral[k])) @ axes[only]) * axes[only]
    return moved


def _share_between(neutral: np.ndarray, k: int, a: int, b: int, along: np.ndarray) -> float | None:
    """How far across from FP `a` to FP `b` FP `k` lies at rest, measured along the unit direction `along`
    (0..1, clipped), or None where a point is unknown or `a` and `b` are level along it."""
    if not np.all(np.isfinite(neutral[[k, a, b]])):
        return None
    across = (neutral[b] - neutral[a]) @ along
    if abs(across) <= 0.0:
        return None
    return float(np.clip((neutral[k] - neutral[a]) @ along / across, 0.0, 1.0))


def mid_lip_push(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each lip's outer mid-point (8.1, 8.2) pushed forward as far as
    its inner one (2.2, 2.3)."""
    return _follow_push(neutral, points, LIP_MIDLINE, False, axes)


def corner_slide(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each lip corner the FAPs moved sideways kept on the face's
    surface: seen from above, it slides along the line from the lip beside it (the mean of its lip's points
    there, 2.6 and 2.8 for 2.4) to the cheek's centre (5.1), the surface's direction at the corner, as far
    sideways as the FAPs moved it: back as it goes out, forward as it comes in. Its lift and any depth the
    FAPs gave it stay."""
    axes = np.asarray(axes, dtype=np.float64)
    face_neutral = np.asarray(neutral, dtype=np.float64) @ axes.T
    moved = np.asarray(points, dtype=np.float64) @ axes.T
    for corner, (upper, lower, cheek) in CORNER_SLIDES.items():
        k = fp_index(corner)
        line = face_neutral[fp_index(cheek)] - 0.5 * (face_neutral[fp_index(upper)] + face_neutral[fp_index(lower)])
        out = moved[k, 0] - face_neutral[k, 0]
        if np.isfinite(out) and np.all(np.isfinite(line)) and line[0] != 0.0:
            moved[k, 2] += out * line[2] / line[0]
    return moved @ axes


def whole_lip_shift(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) after `corner_slide`, with every lip point that is not a corner moved
    sideways (face x) as far as the inner corners 2.4 and 2.5 moved together (the mean of their sideways motion)."""
    axes = np.asarray(axes, dtype=np.float64)
    face_neutral = np.asarray(neutral, dtype=np.float64) @ axes.T
    moved = corner_slide(neutral, points, axes) @ axes.T
    corners = [fp_index(fp) for fp in ("2.4", "2.5")]
    shift = np.mean(moved[corners, 0] - face_neutral[corners, 0])
    if np.isfinite(shift):
        lips = [fp_index(fp) for mid, follow in LIP_FOLLOWERS.items() for fp in (mid, *follow)]
        moved[lips, 0] += shift
    return nose_base_shift(neutral, moved @ axes, axes)


def nose_base_shift(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with the nose's bottom edge (9.5, 9.4 beside the nostrils, 9.15 at
    the mid-line) moved sideways (face x) as the skin between the nose above it and the upper lip's outer contour
    below it is where it lies: the sideways motions of the nostril's border (9.1, 9.2) or the nose's tip (9.3) and
    of the lip's point below (8.5, 8.6, 8.1), blended by how far down from the one to the other it lies at rest
    (face y). Its height and depth stay."""
    return _blend_between(neutral, points, axes, NOSE_BASE_SHIFT, across=1, only=0)


def nostril_lift(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each side's nostril points raised as far as the upper lip's
    outer point beside them rose (not lowered when it came down)."""
    return _rise_with_lip(neutral, points, axes, NOSTRILS)


def nose_base_lift(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each side's point on the nose's bottom edge (9.5, 9.4) raised
    as far as the upper lip's outer point beside it rose (not lowered when it came down); the nostril's border
    9.1 / 9.2 stays."""
    return _rise_with_lip(neutral, points, axes, NOSE_BASES)


def _rise_with_lip(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray, riders) -> np.ndarray:
    """`points` with the FPs `riders` names for each upper lip's outer point raised as far as that point rose."""
    up = np.asarray(axes, dtype=np.float64)[1]
    moved = np.array(points, dtype=np.float64)
    for lip, raised in riders.items():
        rise = (moved[fp_index(lip)] - np.asarray(neutral, dtype=np.float64)[fp_index(lip)]) @ up
        if np.isfinite(rise) and rise > 0.0:
            moved[[fp_index(fp) for fp in raised]] += rise * up
    return moved


def surface_normals(
    neutral: np.ndarray, vertices: np.ndarray, vertex_normals: np.ndarray, fps: tuple[str, ...] = CHEEKS
) -> np.ndarray:
    """(84, 3) the face's unit outward surface normal at each of the `fps` at rest (mesh coordinates; NaN at the
    other FPs, where the FP is missing, the face has no ES0 or no vertex lies near): the mean of the (N, 3)
    `vertex_normals` of the rest `vertices` within NORMAL_RADIUS_PER_ES0 x ES0 of it (the nearest vertex's alone
    when none lies that near). The cheeks' by default: `cheek_puff` uses no other."""
    neutral = np.asarray(neutral, dtype=np.float64)
    vertices = np.asarray(vertices, dtype=np.float64)
    vertex_normals = np.asarray(vertex_normals, dtype=np.float64)
    out = np.full(neutral.shape, np.nan)
    es0 = np.linalg.norm(neutral[fp_index(PUPILS[0])] - neutral[fp_index(PUPILS[1])])
    if not (np.isfinite(es0) and es0 > 0.0) or len(vertices) == 0:
        return out
    for k in (fp_index(fp) for fp in fps):
        if not np.all(np.isfinite(neutral[k])):
            continue
        distance = np.linalg.norm(vertices - neutral[k], axis=1)
        near = distance <= NORMAL_RADIUS_PER_ES0 * es0
        mean = vertex_normals[near].sum(axis=0) if near.any() else vertex_normals[np.argmin(distance)]
        length = np.linalg.norm(mean)
        if length > 0.0:
            out[k] = mean / length
    return out


def cheek_puff(
    neutral: np.ndarray, points: np.ndarray, normals: np.ndarray | None, axes: np.ndarray = BLENDER_FACE_AXES
) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) after `whole_lip_push`, with each cheek point's sideways motion (face
    x, puff_cheek's) turned onto the face's outward surface normal there, its length kept: outward along the
    normal for a puff, inward for a suck. (84, 3) `normals` in mesh coordinates (`surface_normals`); without
    them, or where a normal is unknown or square to the sideways, the cheek moves as the FAPs moved it."""
    axes = np.asarray(axes, dtype=np.float64)
    moved = whole_lip_push(neutral, points, axes) @ axes.T
    if normals is None:
        return moved @ axes
    face_neutral = np.asarray(neutral, dtype=np.float64) @ axes.T
    face_normals = np.asarray(normals, dtype=np.float64) @ axes.T
    for cheek in CHEEKS:
        k = fp_index(cheek)
        out, normal = moved[k, 0] - face_neutral[k, 0], face_normals[k]
        if np.isfinite(out) and np.all(np.isfinite(normal)) and normal[0] != 0.0:
            moved[k, 0] -= out
            moved[k] += out * np.sign(normal[0]) * normal
    return moved @ axes


def bow_follow(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each Cupid's bow peak moved as the upper lip's outer contour
    moves where it lies: the motions of the contour's mid-point 8.1 and the side point beside it (8.5 / 8.6),
    blended by how far across from 8.1 to that point the peak lies at rest (face x)."""
    return _blend_between(neutral, points, axes, BOW_PEAKS, across=0)


def infraorbital_lift(neutral: np.ndarray, points: np.ndarray, axes: np.ndarray = BLENDER_FACE_AXES) -> np.ndarray:
    """(84, 3) FP positions (mesh coordinates) with each cheek bone point (5.3, 5.4) that no FAP moved raised by
    the rise of the upper lip's point below it that rose the most (the corner 8.3 or the lip's side point 8.5 on
    the left), times how far down from the lower lid's centre (3.3), which holds it, to that point it lies at
    rest (face y); not lowered when the lip came down."""
    axes = np.asarray(axes, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    moved = np.array(points, dtype=np.float64)
    for bone, (lid, lips) in INFRAORBITAL.items():
        k = fp_index(bone)
        if not np.all(np.isfinite(moved[k] - neutral[k])) or np.any(moved[k] != neutral[k]):
            continue
        rises = {lip: (moved[fp_index(lip)] - neutral[fp_index(lip)]) @ axes[1] for lip in lips}
        lip = max(rises, key=lambda fp: rises[fp] if np.isfinite(rises[fp]) else -np.inf)
        share = _share_between(neutral, k, fp_index(lid), fp_index(lip), axes[1])
        if share is not None and np.isfinite(rises[lip]) and rises[lip] > 0.0:
            moved[k] += share * rises[lip] * axes[1]
    return moved


def deform_points(
    name: str | None,
    neutral: np.ndarray,
    points: np.ndarray,
    axes=BLENDER_FACE_AXES,
    normals: np.ndarray | None = None,
) -> np.ndarray:
    """The FP positions after the dedicated deformation `name` a recipe names (unchanged for none, or for one
    that moves the skin or a part rather than feature points), the Cupid's bow's peaks then following the upper
    lip's outer contour (`bow_follow`, every recipe) after the cheek bones rise with a raised lip
    (`infraorbital_lift`, every recipe); `normals` (84, 3): the face's outward surface normals at the
    FPs (`surface_normals`), which `cheek_puff` moves the cheeks along."""
    return bow_follow(neutral, infraorbital_lift(neutral, _named(name, neutral, points, axes, normals), axes), axes)


def _named(name, neutral, points, axes, normals) -> np.ndarray:
    if name == "cheek_puff":
        return cheek_puff(neutral, points, normals, axes)
    if name == "whole_lip_push":
        return whole_lip_push(neutral, points, axes)
    if name == "nostril_lift":
        return nostril_lift(neutral, points, axes)
    if name == "nose_base_lift":
        return nose_base_lift(neutral, points, axes)
    if name == "mid_lip_push":
        return mid_lip_push(neutral, points, axes)
    if name == "corner_slide":
        return corner_slide(neutral, points, axes)
    if name == "whole_lip_shift":
        return whole_lip_shift(neutral, points, axes)
    return np.array(points, dtype=np.float64)
