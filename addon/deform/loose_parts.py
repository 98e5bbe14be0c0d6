"""Face parts inside the face's own mesh (eyeballs, teeth, tongue joined in, as downloaded characters come),
found at set-up and moved rigidly, as the separate part objects are (followers.py), never as skin (no bpy).

Finding them (`find_parts`): the mesh's loose parts (connected by no edge to the rest) other than the largest
(the skin), and other than a part that carries the face's own skin FPs (SKIN_FPS: the chin, brows, cheeks and
nose tip; the mesh vertex nearest one is on that part), are taken for
- an eyeball: a part close to a sphere (no vertex farther than SPHERE_TOLERANCE x its radius off the fitted
  sphere) whose centre lies within EYE_REACH radii of a pupil FP (3.5 left, 3.6 right);
- the tongue: of the parts in the mouth (centre within MOUTH_REACH x the mouth's width of the inner lips'
  middle, 2.2/2.3), the one with a vertex nearest FP 6.2 (the tongue's body);
- upper or lower teeth: the other parts in the mouth, above or below the line between the teeth (9.10/9.11,
  else the inner lips);
- lashes or brows: thin parts near the lids (3.1-3.4) or the brows (4.1-4.6), which ride on the skin as the
  deformer moves it (listed, not moved rigidly);
anything else stays skin. (A downloaded character's head mesh may hold its face as a loose part of its own, sewn
to the scalp and neck by coincident vertices: the Rocketbox male's 5,567-vertex face, in front of its mouth, was
taken for the upper teeth and held rigid, so it never moved.)

Moving them (`move_parts`) as followers.py moves the separate objects: an eyeball turns about its fitted
centre by the yaw and pitch of its pupil FP seen from there (MPEG-4 yaw + toward the face's left, about its
up axis; pitch + down, about its left axis), the lower teeth go with 9.11, the tongue with 6.2, the upper
teeth stay with the skull.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.pieces import connected_pieces
from ..geometry.sphere_fit import SphereFitError, fit_sphere
from ..mpeg4.feature_points import fp_index

RIGID_ROLES = ("left_eye", "right_eye", "upper_teeth", "lower_teeth", "tongue")
SKIN_ROLES = ("lashes", "brows")
DRIVERS = {"left_eye": "3.5", "right_eye": "3.6", "lower_teeth": "9.11", "tongue": "6.2"}
SPHERE_TOLERANCE = 0.15
EYE_REACH = 1.5
MOUTH_REACH = 1.5
NEAR_LIDS = 0.5  # x eye width: a part's centre this near the lid FPs may be lashes
NEAR_BROWS = 0.5
SKIN_FPS = ("2.1", "4.1", "4.2", "4.3", "4.4", "4.5", "4.6", "5.1", "5.2", "5.3", "5.4", "9.15")


def _rows(neutral: np.ndarray, ids) -> np.ndarray:
    points = np.array([neutral[fp_index(fp_id)] for fp_id in ids])
    return points[np.all(np.isfinite(points), axis=1)]


def loose_parts(n_vertices: int, edges: np.ndarray) -> np.ndarray:
    """(N,) each vertex's loose part, numbered from the largest (0, the skin) down."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    labels = connected_pieces(n_vertices, edges)
    order = np.argsort(-np.bincount(labels), kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[labels]


def _eye_side(points: np.ndarray, neutral: np.ndarray) -> str | None:
    try:
        centre, radius = fit_sphere(points)
    except SphereFitError:
        return None
    if np.abs(np.linalg.norm(points - centre, axis=1) - radius).max() > SPHERE_TOLERANCE * radius:
        return None
    for role, fp_id in (("left_eye", "3.5"), ("right_eye", "3.6")):
        pupil = neutral[fp_index(fp_id)]
        if np.all(np.isfinite(pupil)) and np.linalg.norm(pupil - centre) <= EYE_REACH * radius:
            return role
    return None


def find_parts(rest: np.ndarray, edges: np.ndarray, neutral: np.ndarray, axes: np.ndarray) -> dict[str, np.ndarray]:
    """Role -> (K,) vertex indices of the loose parts taken for it (`RIGID_ROLES`, `SKIN_ROLES`); roles with no
    part are left out. `rest` (N, 3), `edges` (E, 2), `neutral` (84, 3) FP rows (NaN where missing) and the
    face frame `axes` (rows x left, y up, z forward), all in mesh coordinates."""
    rest = np.asarray(rest, dtype=np.float64)
    labels = loose_parts(len(rest), edges)
    found: dict[str, list[np.ndarray]] = {}
    lips = _rows(neutral, ("2.2", "2.3"))
    corners = _rows(neutral, ("2.4", "2.5"))
    mouth_width = float(np.linalg.norm(corners[0] - corners[1])) if len(corners) == 2 else 0.0
    between_teeth = _rows(neutral, ("9.10", "9.11"))
    seam = between_teeth if len(between_teeth) else lips
    lids = _rows(neutral, ("3.1", "3.2", "3.3", "3.4"))
    brows = _rows(neutral, ("4.1", "4.2", "4.3", "4.4", "4.5", "4.6"))
    eye_corners = _rows(neutral, ("3.7", "3.11"))
    eye_width = float(np.linalg.norm(eye_corners[0] - eye_corners[1])) if len(eye_corners) == 2 else 0.0
    in_mouth = []
    on_skin = _rows(neutral, SKIN_FPS)
    skin = {int(labels[np.argmin(((rest - fp) ** 2).sum(axis=1))]) for fp in on_skin} if len(rest) else set()
    for part in range(1, labels.max(initial=0) + 1):
        if part in skin:
            continue
        members = np.flatnonzero(labels == part)
        points = rest[members]
        centre = points.mean(axis=0)
        role = _eye_side(points, neutral) if len(points) >= 4 else None
        if role is None and len(lips) and mouth_width > 0:
            if np.linalg.norm(centre - lips.mean(axis=0)) <= MOUTH_REACH * mouth_width:
                in_mouth.append(members)
                continue
        if role is None and eye_width > 0:
            thin = np.ptp(points @ np.asarray(axes).T, axis=0).min() < 0.25 * eye_width
            if thin and len(lids) and np.linalg.norm(lids - centre, axis=1).min() <= NEAR_LIDS * eye_width:
                role = "lashes"
            elif thin and len(brows) and np.linalg.norm(brows - centre, axis=1).min() <= NEAR_BROWS * eye_width:
                role = "brows"
        if role is not None:
            found.setdefault(role, []).append(members)
    tongue_fp = neutral[fp_index("6.2")]
    if in_mouth and np.all(np.isfinite(tongue_fp)):
        nearest = min(range(len(in_mouth)), key=lambda k: np.linalg.norm(rest[in_mouth[k]] - tongue_fp, axis=1).min())
        found["tongue"] = [in_mouth.pop(nearest)]
    up = np.asarray(axes, dtype=np.float64)[1]
    for members in in_mouth:
        role = "upper_teeth" if rest[members].mean(axis=0) @ up > seam.mean(axis=0) @ up else "lower_teeth"
        found.setdefault(role, []).append(members)
    return {role: np.sort(np.concatenate(parts)) for role, parts in found.items()}


@dataclass
class RigidParts:
    """The face's rigid parts as `move_parts` moves them."""

    vertices: dict[str, np.ndarray]  # role -> vertex indices (RIGID_ROLES only)
    rest: np.ndarray  # (N, 3) the face's rest positions
    centres: dict[str, np.ndarray]  # eye role -> fitted eyeball centre
    neutral: np.ndarray  # (84, 3) the FPs at rest
    axes: np.ndarray

    @property
    def all_vertices(self) -> np.ndarray:
        return np.concatenate(list(self.vertices.values())) if self.vertices else np.zeros(0, np.intp)


def bind_parts(rest: np.ndarray, vertices: dict[str, np.ndarray], neutral: np.ndarray, axes: np.ndarray):
    """The rigid parts among `vertices` (role -> indices) that have what drives them; None when there are none."""
    rest = np.asarray(rest, dtype=np.float64)
    kept, centres = {}, {}
    for role in RIGID_ROLES:
        members = np.asarray(vertices.get(role, ()), dtype=np.intp)
        driver = DRIVERS.get(role)
        if len(members) == 0 or (driver is not None and not np.all(np.isfinite(neutral[fp_index(driver)]))):
            continue
        if role.endswith("_eye"):
            try:
                centres[role] = fit_sphere(rest[members])[0]
            except SphereFitError:
                continue
        kept[role] = members
    if not kept:
        return None
    return RigidParts(kept, rest, centres, np.asarray(neutral, dtype=np.float64), np.asarray(axes, dtype=np.float64))


def _gaze(axes: np.ndarray, pupil: np.ndarray, centre: np.ndarray) -> tuple[float, float]:
    """Yaw and pitch of the pupil seen from the centre, in the face frame (followers.follow_gaze's angles)."""
    x, y, z = axes @ (pupil - centre)
    return float(np.arctan2(x, z)), float(np.arctan2(-y, np.hypot(x, z)))


def eye_turn(axes: np.ndarray, yaw: float, pitch: float) -> np.ndarray:
    """(3, 3) the eyeball's turn in mesh coordinates: pitch about the face's left axis, then yaw about its up."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    about_up = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    about_left = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    return axes.T @ about_up @ about_left @ axes


def move_parts(parts: RigidParts, out: np.ndarray, fps: np.ndarray) -> None:
    """Write each rigid part's position for the FPs `fps` (84, 3) into the deformed positions `out`, in place."""
    for role, members in parts.vertices.items():
        rest = parts.rest[members]
        driver = DRIVERS.get(role)
        if driver is None:
            out[members] = rest
            continue
        row = fp_index(driver)
        now = fps[row] if np.all(np.isfinite(fps[row])) else parts.neutral[row]
        if role in parts.centres:
            centre = parts.centres[role]
            yaw, pitch = _gaze(parts.axes, now, centre)
            yaw0, pitch0 = _gaze(parts.axes, parts.neutral[row], centre)
            turn = eye_turn(parts.axes, yaw - yaw0, pitch - pitch0)
            out[members] = (rest - centre) @ turn.T + centre
        else:
            out[members] = rest + (now - parts.neutral[row])
