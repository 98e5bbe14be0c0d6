"""A full blink on users' meshes: per face and eye, what a viewer sees of the eye, how smooth the lid edge stays, and
whether the lids fold or cross.

    .venv/bin/python -m scripts.bench.variant_blink [FACE.blend|DIR ...]

Each face (the sample, and every .blend in a folder such as `scripts.bench.variants OUT` writes; the sample alone
when none is given) is set up with Set Up Face, and each upper mid-lid FP moved onto the lower one (3.1 onto 3.3,
3.2 onto 3.4, `full_blink`), the whole add-on deforming as in playback. Per eye it prints: the seen gap
(`overlaps.seen_lid_gap`, mm) straight on and from 30 degrees below (the eyeball the rig's, its radius to the
pupil FP), at rest and at the blink; the upper lid edge's largest distance off a smooth curve through its neighbours
(`overlaps.edge_roughness` on `variant_playback.lid_edges`: the vertices nearest the line through the lid FPs), and
the same for the lid's margin as the eye's centre sees it at rest (`variant_playback.lid_margins`: points on the
skin followed through the blink), at rest, at the blink, and in brackets with the lids' turn alone (`lids_alone`:
the rig on the rest face, nothing else moving); the faces turned over (`folds.inverted_faces`) and the crossing
triangle pairs (`overlaps.crossings`, pairs crossing at rest left out) among the faces the eye's lids move.

The roughness is each point's distance from the cubic through its two neighbours on each side, on the positions
given: a lid edge already rough at rest (a remesh's or a decimated mesh's vertices along the lid line) reads as
rough at the blink by as much, so the rest figure is printed beside it and the blink is judged against it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import eyelid_rig, face_data, inner_parts, live
from addon.deform.eyelids import apply_eyelids
from addon.deform.folds import inverted_faces
from addon.deform.overlaps import crossing_pairs, crossings, edge_roughness, seen_lid_gap
from addon.mpeg4.feature_points import fp_index
from scripts.bench.variant_playback import _face, lid_edges, lid_margins, margin_roughness
from scripts.bench.variants import SAMPLE
from scripts.docs.render_eyes_brows import positions

EYES = (("3.11", "3.7", "3.5"), ("3.8", "3.12", "3.6"))  # inner corner, outer corner, pupil
PITCHES = (0.0, -30.0)  # views: straight on, from 30 degrees below


def lids_alone(face) -> np.ndarray:
    """The face's rest positions (N, 3) turned by the lids' rig alone at the full blink (`eyelids.apply_eyelids` with
    3.1 on 3.3 and 3.2 on 3.4; Planar Bones, Keep Lips Apart and Unfold Skin left out): what the lids' weights and
    their stops do, apart from the rest of the path. The rig is the one playback made (`full_blink` first)."""
    rig = eyelid_rig.current(face)
    rest = positions(face.data)
    fps = face_data.neutral_positions(face_data.fp_empties(face))
    for upper, lower in (("3.1", "3.3"), ("3.2", "3.4")):
        fps[fp_index(upper)] = fps[fp_index(lower)]
    apply_eyelids(rig, rest, fps)
    return rest


def full_blink(face) -> np.ndarray:
    """The face's positions (N, 3) with each upper mid-lid FP moved onto the lower one (then put back)."""
    empties = face_data.fp_empties(face)
    rests = {fp_id: empties[fp_id].location.copy() for fp_id in ("3.1", "3.2")}
    empties["3.1"].location = empties["3.3"].location
    empties["3.2"].location = empties["3.4"].location
    bpy.context.view_layer.update()
    live.apply_face(face, force=True)
    closed = positions(face.data)
    for fp_id, location in rests.items():
        empties[fp_id].location = location
    bpy.context.view_layer.update()
    live.apply_face(face, force=True)
    return closed


def seen_gaps(face, points: np.ndarray, triangles: np.ndarray, eye: int) -> list[float]:
    """The seen gap (m) of `eye` (0 left, 1 right) at `points`, from each of `PITCHES`."""
    rig = eyelid_rig.current(face)
    empties = face_data.fp_empties(face)
    inner, outer, pupil = EYES[eye]
    centre = rig.centres[eye] @ rig.axes
    radius = np.linalg.norm(np.array(empties[pupil].location) - centre)
    gaps = []
    for pitch in PITCHES:
        a = np.radians(pitch)
        axes = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]]) @ rig.axes
        corners = tuple((np.array([empties[inner].location, empties[outer].location]) - centre) @ axes[0])
        gaps.append(seen_lid_gap(points, triangles, centre, radius, axes, corners))
    return gaps


def measure(face) -> list[dict]:
    """Per eye of the set-up `face`: the full blink's figures (see the module's text), lengths in mm."""
    rest = positions(face.data)
    triangles = face_data.mesh_fans(face.data)[0]
    parts = np.zeros(len(rest), bool)  # eyeballs, teeth and tongue inside the face are not skin
    for members in inner_parts.group_members(face).values():
        parts[members] = True
    skin = triangles[~parts[triangles].any(axis=1)]
    edges = lid_edges(face, rest, ~parts)
    margins = lid_margins(face, rest, skin)
    closed = full_blink(face)
    rig = eyelid_rig.current(face)
    alone = lids_alone(face)
    turned = inverted_faces(rest, closed, triangles)
    at_rest = crossing_pairs(rest, skin)
    rows = []
    for eye in (0, 1):
        lid = np.zeros(len(rest), bool)
        lid[rig.vertices[rig.eye == eye]] = True
        rows.append(
            {
                "rest_seen": [1e3 * g for g in seen_gaps(face, rest, skin, eye)],
                "seen": [1e3 * g for g in seen_gaps(face, closed, skin, eye)],
                "rest_edge": 1e3 * edge_roughness(rest, edges[eye], closed=False).max(),
                "edge": 1e3 * edge_roughness(closed, edges[eye], closed=False).max(),
                "edge_alone": 1e3 * edge_roughness(alone, edges[eye], closed=False).max(),
                "margin": [1e3 * margin_roughness(p, margins[eye]) for p in (rest, closed, alone)]
                if len(margins) == 2
                else [],
                "folds": int(np.count_nonzero(turned & lid[triangles].any(axis=1))),
                "crossings": crossings(closed, skin, lid & np.any(closed != rest, axis=1), at_rest),
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("faces", nargs="*", type=Path, help=".blend files, or folders of them (the sample first)")
    args = parser.parse_args(argv)
    files = [SAMPLE] + [f for p in args.faces for f in (sorted(p.glob("*.blend")) if p.is_dir() else [p])]
    addon.register()
    print(
        "| face | eye | seen gap straight / 30° below, rest → blink (mm) | lid edge off smooth, rest → blink"
        " (lids alone) (mm) | seen margin off smooth, rest → blink (lids alone) (mm) | faces turned over |"
        " crossing pairs |"
    )
    print("|---|---|---:|---:|---:|---:|---:|")
    for path in files:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        face = _face()
        bpy.ops.mpeg4.setup_face()
        for eye, row in zip(("left", "right"), measure(face), strict=True):
            rest_seen, seen = "/".join(f"{g:.2f}" for g in row["rest_seen"]), "/".join(f"{g:.2f}" for g in row["seen"])
            margin = "-"
            if row["margin"]:
                margin = "{:.2f} → {:.2f} ({:.2f})".format(*row["margin"])
            edge = f"{row['rest_edge']:.2f} → **{row['edge']:.2f}** ({row['edge_alone']:.2f})"
            print(
                f"| {path.stem} | {eye} | {rest_seen} → **{seen}** | {edge} | "
                f"{margin} | {row['folds']} | {row['crossings']} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
