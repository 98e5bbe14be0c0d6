"""Recipes whose FAP values are read from the development units' own FP motion (session 17, the fifteenth pass).

    .venv/bin/python -m scripts.bench.arkit_read_units [--units DIR] [--json OUT]      (development: decide here)
    .venv/bin/python -m scripts.bench.arkit_read_units --check DIR [--json OUT]       (and a check set, measured once)

For every ARKit shape that has a MakeHuman unit (`evaluate_arkit.MAKEHUMAN_UNITS` and `MORE_UNITS`), the FAP values
(FAPU; each FAP moves its FP, and open_jaw's riders, along its own axis as `mpeg4.decode.translation_basis`
defines it) whose FP motion on the sample head best reproduces the unit's, by bounded least squares over all the
pairs at once (`read_recipes`): a pair's shapes add their FP motions as their keys add, so a unit that shows two
shapes (mouth-depression-retraction: mouthLowerDown + mouthUpperUp) is split by the pairs that show one of them
alone. A Right shape is the mirror of its Left one (`recipes.mirror_faps`), a shape with neither side is its own
mirror, so the recipes read keep the table's mirror symmetry; a Left shape shown only together with its Right one
(the bilateral units) reads only its own side's and the midline's FAPs (the other side's stay as the table has
them). Bounds: the standard's range of each FAP (`fap_tables.FAP_RANGE`), unidirectional FAPs not below 0. A
small ridge toward the table's values (`RIDGE` of a FAP's own FP motion) settles what no pair determines, so a
FAP no unit constrains keeps the table's value. The FAPs read are the skin's translations (`READABLE_FAPS`): not
the eyeballs', the tongue's, the ears' or the head's.

Variants, each made into keys by the face's engine as Make ARKit Shape Keys makes them (Planar Bones; the
table's dedicated deformations kept):

- (a) the table as it is;
- (b) every FAP of every shape with a unit read from the units;
- (c) only the FAPs whose FPs (and riders) the table's key holds (moves under `HELD_MM`; `arkit_spread`'s
  reading) read, the FAPs on the FPs it moves kept: the recipe counterpart of `arkit_spread --fp-split`'s "the
  sculpt's motion on the FPs the keys hold".
- (d) every FAP read as (b), but about the keys' own FP motion (`about_keys`): what the table's keys move their
  FPs beyond their FAPs' own motion (the dedicated deformations, the soft limits) taken off the unit's motion
  first, so it is not read again as FAP values (read plainly, the mouth-open unit's lip swinging back with the
  turning jaw becomes push_b_lip, which `jaw_hinge` then turns again).

On the development set E of (b) and (c) is in-sample (each unit scores recipes read from itself); the fairer
estimate reads the recipes again with each pair held out (`held_out_tables`) and scores the pair with those: a
Left unit's shape is then read from its Right twin mirrored, a shape some other pair shows from that pair, and a
shape only its own unit shows falls back to the table's values (listed: those units have no estimate of their
own). `--check DIR` then measures (a)-(d) on a check set once, per shape and per region (docs/arkit.md, the
fifteenth pass: none kept).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sparse
from scipy.optimize import lsq_linear

from addon.arkit.recipes import mirror_faps, mirror_name
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.decode import translation_basis
from addon.mpeg4.fap_tables import FAP_RANGE
from addon.mpeg4.faps import FAPS, LEFT_RIGHT_PAIRS, N_FAPS, fap
from addon.mpeg4.fapu import Fapu
from addon.mpeg4.feature_points import fp_index

# the skin's translational FAPs: the jaw and lips (2), the lids (19-22), the brows (4), the cheeks (5), the outer
# lips (8), the nose (9); not the eyeballs' thrust (27, 28: the eyeball, not skin), the tongue's (6), the ears'
# (10: no ARKit shape moves the ears), nor rotations (eyeballs, tongue roll, head) or the high-level FAPs
READABLE_FAPS = tuple(
    f.number for f in FAPS if f.axis is not None and f.group in (2, 3, 4, 5, 8, 9) and f.number not in (27, 28)
)
RIDGE = 1e-3  # weight of the pull toward the table's values, against a FAP's own FP motion (metres per metre)
HELD_MM = 0.5  # a control FP the table's key moves less than this is held (`arkit_spread.HELD_MM`)
RIGHT_SIDE = frozenset(right for _left, right in LEFT_RIGHT_PAIRS)
LEFT_SIDE = frozenset(left for left, _right in LEFT_RIGHT_PAIRS)
MIRROR = mirror_faps(np.eye(N_FAPS))  # (68, 68): mirror_faps(v) == v @ MIRROR


def fap_motion_basis(
    fapu: Fapu, fp_ids: tuple[str, ...], faps=READABLE_FAPS, axes: np.ndarray = BLENDER_FACE_AXES
) -> np.ndarray:
    """(68, M, 3) each FP of `fp_ids`' motion (mesh coordinates) per unit of each FAP in `faps` (0 for the rest):
    its FP along its axis times its FAPU, and open_jaw's and the jaw's slides' riders (`decode.translation_basis`)."""
    every = translation_basis(fapu)[:, [fp_index(f) for f in fp_ids]] @ np.asarray(axes, dtype=np.float64)
    keep = np.zeros(N_FAPS, bool)
    keep[[n - 1 for n in faps]] = True
    return np.where(keep[:, None, None], every, 0.0)


def fap_bounds() -> tuple[np.ndarray, np.ndarray]:
    """(68,) lower and upper bounds: the standard's range, unidirectional FAPs from 0."""
    lower = np.array([0.0 if not f.bidirectional else -FAP_RANGE[f.number - 1] for f in FAPS])
    return lower, np.array(FAP_RANGE, dtype=np.float64)


def root_of(name: str) -> tuple[str, np.ndarray]:
    """The shape whose values are read for `name`, and the (68, 68) map from those values to `name`'s (row
    vector convention, values @ map): a Left or two-sided name itself (the identity; a two-sided name's values
    made symmetric), a Right name its Left twin mirrored."""
    twin = mirror_name(name)
    if twin == name:
        return name, 0.5 * (np.eye(N_FAPS) + MIRROR)
    if name.endswith("Right"):
        return twin, MIRROR
    return name, np.eye(N_FAPS)


def free_faps(pairs, basis: np.ndarray) -> dict[str, np.ndarray]:
    """root name -> (68,) bool: the FAPs read for it. All the basis moves, but a Left shape shown only with its
    Right twin in every pair (a bilateral unit) reads its own side's and the midline's FAPs only."""
    moves = np.abs(basis).reshape(N_FAPS, -1).max(axis=1) > 0.0
    out = {}
    for names, _motion in pairs:
        for name in names:
            root = root_of(name)[0]
            if root in out:
                continue
            twin = mirror_name(root)
            bilateral = twin != root and all((root in n) == (twin in n) for n, _m in pairs if root in n or twin in n)
            side = moves.copy()
            if bilateral:
                side[[n - 1 for n in RIGHT_SIDE]] = False
            out[root] = side
    return out


def held_faps(key_fp_motion: np.ndarray, basis: np.ndarray, held_mm: float = HELD_MM) -> np.ndarray:
    """(68,) bool: the FAPs every FP of which (its own and its riders, as `basis` moves them) the key moves less
    than `held_mm`; `key_fp_motion` (M, 3) the key's motion at the control FPs, metres."""
    held = np.linalg.norm(key_fp_motion, axis=1) < 1e-3 * held_mm
    touches = np.linalg.norm(basis, axis=2) > 0.0  # (68, M)
    return np.array([bool(np.all(held[row])) if row.any() else False for row in touches])


def read_recipes(
    pairs,
    basis: np.ndarray,
    prior: dict[str, np.ndarray],
    free: dict[str, np.ndarray] | None = None,
    ridge: float = RIDGE,
) -> dict[str, np.ndarray]:
    """name -> (68,) FAP values read from the pairs' FP motion, for every name in `pairs` and its mirror twin.

    `pairs`: (names, (M, 3) FP motion in metres) each, the names' recipes adding up to the motion; `basis`
    (68, M, 3) from `fap_motion_basis`; `prior` name -> (68,) the table's values (the values kept where a FAP is
    not read, and the ridge's pull); `free` root -> (68,) bool the FAPs read (default `free_faps`), intersected
    with what the basis moves. Bounded least squares (`fap_bounds`), `ridge` times each FAP's own FP motion
    (its basis column's norm) pulling toward the prior."""
    free = free_faps(pairs, basis) if free is None else free
    moves = np.abs(basis).reshape(N_FAPS, -1).max(axis=1) > 0.0
    roots = sorted({root_of(n)[0] for names, _m in pairs for n in names})
    columns = [(root, k) for root in roots for k in np.flatnonzero(free[root] & moves)]
    index = {c: j for j, c in enumerate(columns)}
    flat = basis.reshape(N_FAPS, -1)  # (68, 3M)
    rows = []
    targets = []
    for names, motion in pairs:
        block = np.zeros((flat.shape[1], len(columns)))
        fixed = np.zeros(flat.shape[1])
        for name in names:
            root, to_name = root_of(name)
            moved = to_name @ flat  # (68, 3M): the motion of `name` per unit of each of its root's values
            for k in range(N_FAPS):
                if (root, k) in index:
                    block[:, index[root, k]] += moved[k]
                else:
                    fixed += prior[root][k] * moved[k]
        rows.append(block)
        targets.append(np.asarray(motion, dtype=np.float64).ravel() - fixed)
    size = np.linalg.norm(flat, axis=1)  # each FAP's own FP motion per unit
    pull = np.zeros((len(columns), len(columns)))
    pull[np.arange(len(columns)), np.arange(len(columns))] = [ridge * size[k] for _root, k in columns]
    start = np.array([prior[root][k] for root, k in columns])
    data = np.vstack(rows)
    used = np.any(data != 0.0, axis=1)  # a coordinate no read FAP moves adds the same residual to every reading
    matrix = np.vstack([data[used], pull])
    rhs = np.concatenate([np.concatenate(targets)[used], pull.diagonal() * start])
    lower, upper = fap_bounds()
    lo = np.array([lower[k] for _r, k in columns])
    hi = np.array([upper[k] for _r, k in columns])
    if not columns:
        solved = np.zeros(0)
    else:  # sparse: most rows touch one FAP or a few
        result = lsq_linear(
            sparse.csr_matrix(matrix), rhs, (lo, hi), method="trf", lsq_solver="lsmr", tol=1e-12, max_iter=1000
        )
        if result.status == 0:
            raise RuntimeError("read_recipes: the bounded least squares did not converge")
        solved = result.x
    read = {root: np.array(prior[root], dtype=np.float64) for root in roots}
    for (root, k), value in zip(columns, solved, strict=True):
        read[root][k] = value
    out = {}
    for root in roots:
        for name in {root, mirror_name(root)}:
            out[name] = read[root] @ root_of(name)[1] if name != root or mirror_name(root) == root else read[root]
    return out


def about_keys(pairs, key_fp_motion: dict[str, np.ndarray], basis: np.ndarray, prior: dict[str, np.ndarray]):
    """`pairs` with each motion less what the table's keys move their FPs beyond their FAPs' own motion (the
    dedicated deformations, the soft limits, the closures: key FP motion - basis @ prior, summed over the pair's
    names), so `read_recipes` reads values whose FP motion, added to that, reproduces the unit's: the keys' FP
    motion taken as linear in the values about the table's (`key_fp_motion` name -> (M, 3), metres)."""
    out = []
    for names, motion in pairs:
        beyond = sum(key_fp_motion[n] - np.einsum("k,kmc->mc", prior[n], basis) for n in names)
        out.append((names, np.asarray(motion, dtype=np.float64) - beyond))
    return out


def held_out_tables(pairs, basis, prior, free=None) -> list[dict[str, np.ndarray]]:
    """For each pair, the recipes of its names read from all the other pairs (`read_recipes` without it); a name
    no other pair (nor its twin's) shows keeps its prior."""
    out = []
    for i, (names, _motion) in enumerate(pairs):
        rest = [p for j, p in enumerate(pairs) if j != i]
        shown = {root_of(n)[0] for ns, _m in rest for n in ns}
        read = read_recipes(rest, basis, prior, free) if rest else {}
        out.append({n: read[n] if root_of(n)[0] in shown else np.array(prior[n]) for n in names})
    return out


def disjoint_groups(name_sets: list[tuple[str, ...]]) -> list[list[int]]:
    """Indices of `name_sets` in groups whose sets share no name (greedy, in order): one table can hold every
    held-out recipe of a group at once."""
    groups: list[tuple[list[int], set[str]]] = []
    for i, names in enumerate(name_sets):
        for members, used in groups:
            if not used & set(names):
                members.append(i)
                used.update(names)
                break
        else:
            groups.append(([i], set(names)))
    return [members for members, _used in groups]


def describe(values: np.ndarray, before: np.ndarray, minimum: float = 0.5) -> str:
    """The FAPs whose values changed by at least `minimum` FAPU: 'name before -> after', comma separated."""
    changed = np.flatnonzero(np.abs(values - before) >= minimum)
    return ", ".join(f"{fap(int(k) + 1).name} {before[k]:+.0f} -> {values[k]:+.0f}" for k in changed)


# ---------------------------------------------------------------------------------------------------- the bench


def _keys_with(targets: np.ndarray, face_path: Path) -> tuple[object, dict[str, np.ndarray]]:
    """The sample head's 52 keys made by the add-on with the recipe table's values replaced by `targets`."""
    from scripts.bench import evaluate, evaluate_arkit

    keys_modules = [m for n, m in sys.modules.items() if n.endswith("blender.arkit_keys")]
    recipes_modules = [m for n, m in sys.modules.items() if n.endswith("arkit.recipes")]
    table = recipes_modules[0].load_recipes()
    frozen = np.array(targets, dtype=np.float64)
    frozen.flags.writeable = False
    swapped = dataclasses.replace(table, targets=frozen)
    originals = [m.load_recipes for m in keys_modules]
    for m in keys_modules:
        m.load_recipes = lambda path=None: swapped
    try:
        face = evaluate.load_face(face_path)
        return face, evaluate_arkit.made_keys(face, "planar")
    finally:
        for m, original in zip(keys_modules, originals, strict=True):
            m.load_recipes = original


def _table_with(base: np.ndarray, recipes: dict[str, np.ndarray]) -> np.ndarray:
    from addon.arkit.recipes import ARKIT_INDEX

    out = np.array(base, dtype=np.float64)
    for name, values in recipes.items():
        out[ARKIT_INDEX[name]] = np.round(values)  # whole FAP units, as the table holds them
    return out


def _fp_motion(face, key: np.ndarray) -> np.ndarray:
    """(M, 3) a key's motion at the control FPs, read at each FP's vertices as the sculpts' is."""
    from scripts.sample.makehuman.fp_table import FP_TABLE

    head_vertex = {int(b): i for i, b in enumerate(face.mh_index)}
    return np.array([key[[head_vertex[int(b)] for b in FP_TABLE[f][1]]].mean(axis=0) for f in face.fp_ids])


def _pooled(rows) -> tuple[float, int]:
    errors = [float(np.linalg.norm(g - s, axis=1).sum()) for g, s in rows]
    motions = [float(np.linalg.norm(s, axis=1).sum()) for _g, s in rows]
    return sum(errors) / sum(motions), sum(e < m for e, m in zip(errors, motions, strict=True))


def _regions(rows, region: np.ndarray) -> dict[str, float]:
    """E per region (`evaluate.REGION_NAMES`), pooled over (generated, sculpted) rows, as `evaluate.region_e`."""
    from scripts.bench.evaluate import REGION_NAMES

    out = {}
    for index, name in enumerate(REGION_NAMES):
        inside = region == index
        error = sum(float(np.linalg.norm(g - s, axis=1)[inside].sum()) for g, s in rows)
        out[name] = error / sum(float(np.linalg.norm(s, axis=1)[inside].sum()) for _g, s in rows)
    return out


VARIANTS = {
    "a": "the table as it is",
    "b": "every FAP of the shapes with a unit read from the units",
    "c": "only the FAPs on FPs the table's key holds read (the FAPs on FPs it moves kept)",
    "d": "every FAP read as (b), about the keys' own FP motion (`about_keys`)",
}


def main(argv=None) -> int:
    import bpy  # noqa: F401 (the bench runs in Blender's Python)

    from addon.arkit.recipes import ARKIT_NAMES, load_recipes
    from addon.blender import fap_io
    from scripts import convert
    from scripts.bench import evaluate, evaluate_arkit

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=Path, default=evaluate_arkit.UNITS, help="the development units' folder")
    parser.add_argument("--check", type=Path, help="a check set's folder (NAME.target per ARKit name): measured once")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    convert.addon_package()
    table = load_recipes()
    prior = {name: np.array(table.recipe(name)) for name in ARKIT_NAMES}
    face, keys = _keys_with(table.targets, evaluate.DEFAULT_FACE)
    fapu = fap_io.face_fapu(face.head)
    basis = fap_motion_basis(fapu, face.fp_ids)
    unit_pairs = evaluate_arkit.pairs_from_units(args.units)
    sculpts = []
    for names, paths in unit_pairs:
        motions = [evaluate.target_motion(p, face) for p in paths]
        sculpts.append((names, sum(m[0] for m in motions), sum(m[1] for m in motions)))
    pairs = [(names, fps) for names, _v, fps in sculpts]
    key_fps = {name: _fp_motion(face, keys[name]) for name in ARKIT_NAMES}
    free_b = free_faps(pairs, basis)
    free_c = {}
    for root, mask in free_b.items():
        held = held_faps(key_fps[root], basis)
        held &= held @ np.abs(MIRROR) > 0.5  # held on both sides (so the mirror keeps it)
        free_c[root] = mask & held
    readings = {"b": (pairs, free_b), "c": (pairs, free_c), "d": (about_keys(pairs, key_fps, basis, prior), free_b)}
    read = {v: read_recipes(p, basis, prior, f) for v, (p, f) in readings.items()}
    report: dict = {"variants": VARIANTS, "readable_faps": [fap(n).name for n in READABLE_FAPS], "recipes": {}}
    for variant, recipes in read.items():
        report["recipes"][variant] = {n: describe(np.round(v), prior[n]) for n, v in sorted(recipes.items())}
        print(f"\n({variant}) the values read, against the table's:")
        for name, text in report["recipes"][variant].items():
            print(f"  {name}: {text or 'unchanged'}")
    tables = {"a": np.array(table.targets)} | {v: _table_with(table.targets, r) for v, r in read.items()}
    labels = [f"{'+'.join(n)} ({'+'.join(p.name.split('.')[0] for p in ps)})" for n, ps in unit_pairs]
    dev: dict = {}
    for variant, targets in tables.items():
        made = keys if variant == "a" else _keys_with(targets, evaluate.DEFAULT_FACE)[1]
        rows = [(sum(made[n] for n in names), s) for names, s, _f in sculpts]
        e, below = _pooled(rows)
        dev[variant] = {
            "e_pooled": e,
            "below_1": below,
            "regions": _regions(rows, face.region),
            "per_pair": [_pooled([r])[0] for r in rows],
        }
    fallback = {}
    for variant, (variant_pairs, free) in readings.items():
        held_out = held_out_tables(variant_pairs, basis, prior, free)
        per_pair = [None] * len(pairs)
        for group in disjoint_groups([names for names, _m in pairs]):
            merged = {n: v for i in group for n, v in held_out[i].items()}
            made = _keys_with(_table_with(table.targets, merged), evaluate.DEFAULT_FACE)[1]
            for i in group:
                per_pair[i] = (sum(made[n] for n in pairs[i][0]), sculpts[i][1])
        e, below = _pooled(per_pair)
        shown = [{root_of(n)[0] for j, (ns, _m) in enumerate(pairs) if j != i for n in ns} for i in range(len(pairs))]
        fallback[variant] = [
            labels[i] for i, (names, _m) in enumerate(pairs) if not any(root_of(n)[0] in shown[i] for n in names)
        ]
        dev[variant]["held_out"] = {
            "e_pooled": e,
            "below_1": below,
            "regions": _regions(per_pair, face.region),
            "per_pair": [_pooled([r])[0] for r in per_pair],
        }
    report["development"] = dev
    report["no_held_out_estimate"] = fallback["b"]
    print("\nthe development set (28 pairs), pooled E (below 1); regions " + " / ".join(dev["a"]["regions"]))
    for variant, row in dev.items():
        regions = " / ".join(f"{v:.3f}" for v in row["regions"].values())
        print(f"({variant}) {VARIANTS[variant]}: in-sample {row['e_pooled']:.4f} ({row['below_1']}); {regions}")
        if "held_out" in row:
            out = row["held_out"]
            regions = " / ".join(f"{v:.3f}" for v in out["regions"].values())
            print(f"    each pair held out {out['e_pooled']:.4f} ({out['below_1']}); {regions}")
    print(f"pairs no other pair shows (held out, the table's values kept): {', '.join(fallback['b'])}")
    columns = ["a"] + [f"{v}{how}" for v in "bcd" for how in ("", " held out")]
    print("\n| pair | " + " | ".join(columns) + " |\n|---|" + "---:|" * len(columns))
    for i, label in enumerate(labels):
        cells = [dev["a"]["per_pair"][i]]
        for v in "bcd":
            cells += [dev[v]["per_pair"][i], dev[v]["held_out"]["per_pair"][i]]
        print(f"| {label} | " + " | ".join(f"{c:.3f}" for c in cells) + " |")
    if args.check is not None:  # a check set: measured once per variant, nothing decided on it
        check = evaluate_arkit.pairs_from_folder(args.check)
        report["check"] = {}
        per_shape = {}
        for variant, targets in tables.items():
            check_face, made = (face, keys) if variant == "a" else _keys_with(targets, evaluate.DEFAULT_FACE)
            summary = evaluate_arkit.summary(check_face, evaluate_arkit.scores(check_face, made, check))
            report["check"][variant] = {k: summary[k] for k in ("e_pooled", "below_1", "count", "regions")}
            per_shape[variant] = {n: r["e"] for n, r in summary["per_shape"].items()}
            regions = " / ".join(f"{v:.3f}" for v in summary["regions"].values())
            print(
                f"check set ({variant}): pooled E {summary['e_pooled']:.4f}, {summary['below_1']} of "
                f"{summary['count']} below 1; regions ({' / '.join(summary['regions'])}) {regions}"
            )
        report["check_per_shape"] = per_shape
        print("\n| shape | " + " | ".join(tables) + " |\n|---|" + "---:|" * len(tables))
        for name in per_shape["a"]:
            print(f"| {name} | " + " | ".join(f"{per_shape[v][name]:.3f}" for v in tables) + " |")
    report["command"] = " ".join(["python -m scripts.bench.arkit_read_units", *(argv or sys.argv[1:])])
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
