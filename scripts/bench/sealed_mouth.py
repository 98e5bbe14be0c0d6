"""The sample with its lips welded shut (a mesh that seals its mouth), and the same after Open Sealed Mouth, for
`scripts.bench.variant_playback` and `scripts.docs.render_variant_mouth`.

    .venv/bin/python -m scripts.bench.sealed_mouth OUT_DIR
    .venv/bin/python -m scripts.bench.variant_playback OUT_DIR/sealed.blend OUT_DIR/sealed_cut.blend --every 4
    .venv/bin/python -m scripts.docs.render_variant_mouth OUT_DIR/sealed.blend OUT_DIR/sealed_cut.blend \
        --frames 0 24 75 121 --crossings

`weld_lips(face)` merges the sample's upper inner lip rim (FP 2.4-2.2-2.5) into its lower one (2.4-2.3-2.5), each
rim given a vertex where the other has one first (the faces that got more than 4 corners so are triangulated); its
lip mask groups are deleted (a mesh that seals its mouth
has none painted to part the lips: set-up makes them from the FPs). `sealed.blend` is that face, not set up;
`sealed_cut.blend` the same after `bpy.ops.mpeg4.open_sealed_mouth()`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bpy
import numpy as np

import addon
from addon.blender import face_data
from scripts import convert
from scripts.bench.variants import HEAD, SAMPLE

LIP_MASKS = ("upper_lip", "lower_lip")


def _positions(mesh) -> np.ndarray:
    out = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", out)
    return out.reshape(-1, 3)


def _rim(vertices, neighbours, start: int, direction, stop: int) -> list[int]:
    """An inner lip rim as an edge loop: from `start` on, always the edge straightest ahead, to `stop`."""
    chain, ahead = [start], np.asarray(direction, dtype=np.float64)
    while chain[-1] != stop and len(chain) < 100:
        options = [n for n in neighbours[chain[-1]] if n not in chain]
        steps = [vertices[n] - vertices[chain[-1]] for n in options]
        steps = [step / np.linalg.norm(step) for step in steps]
        best = int(np.argmax([step @ ahead for step in steps]))
        chain.append(options[best])
        ahead = steps[best]
    assert chain[-1] == stop
    return chain


def _along(vertices, chain) -> np.ndarray:
    x = np.abs(vertices[chain, 0] - vertices[chain[0], 0])
    return x / x[-1]


def weld_lips(head) -> int:
    """Weld the sample's upper inner lip rim (2.4-2.2-2.5) to its lower one (2.4-2.3-2.5): each rim gets a vertex
    where the other has one (the upper rim has 12 edges a side, the lower 7), then they are merged pairwise onto
    the upper rim. Returns how many vertices the mesh lost."""
    import bmesh  # after bpy, which provides it

    mesh = head.data
    before = len(mesh.vertices)
    vertices = _positions(mesh)
    fps = face_data.local_positions(head, face_data.fp_empties(head))
    nearest = {k: int(np.argmin(np.linalg.norm(vertices - fps[k], axis=1))) for k in ("2.2", "2.3", "2.4", "2.5")}
    neighbours = [[] for _ in vertices]
    for a, b in face_data.mesh_edges(mesh).tolist():
        neighbours[a].append(b)
        neighbours[b].append(a)
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bm.verts.ensure_lookup_table()
    targets = {}
    halves = []
    for corner, x in (("2.4", 1.0), ("2.5", -1.0)):
        rims = [_rim(vertices, neighbours, nearest[m], (x, 0, 0), nearest[corner]) for m in ("2.2", "2.3")]
        halves.append(([_along(vertices, rim) for rim in rims], [[bm.verts[v] for v in rim] for rim in rims]))
    for params, rims in halves:
        filled = []
        for k, (verts, t) in enumerate(zip(rims, params, strict=True)):
            other = params[1 - k]
            chain = [(float(tv), vert) for tv, vert in zip(t, verts, strict=True)]
            for t_new in sorted(other[1:-1]):
                if np.isclose(t, t_new).any():
                    continue
                i = int(np.searchsorted([tc for tc, _v in chain], t_new)) - 1
                (t0, v0), (t1, v1) = chain[i], chain[i + 1]
                _edge, vert = bmesh.utils.edge_split(bm.edges.get((v0, v1)), v0, (t_new - t0) / (t1 - t0))
                chain.insert(i + 1, (float(t_new), vert))
            filled.append([vert for _t, vert in chain])
        upper, lower = filled
        assert len(upper) == len(lower)
        targets.update({lo: up for up, lo in zip(upper[1:-1], lower[1:-1], strict=True)})
        targets[lower[0]] = upper[0]  # the middle (2.3's vertex onto 2.2's), met from both sides
    bmesh.ops.weld_verts(bm, targetmap=targets)
    # the faces along the rims got the other rim's vertices: triangulated, as a fan of their n corners would fold
    bmesh.ops.triangulate(
        bm, faces=[f for f in bm.faces if len(f.verts) > 4], quad_method="BEAUTY", ngon_method="BEAUTY"
    )
    bm.to_mesh(mesh)
    bm.free()
    mesh.update()
    return before - len(mesh.vertices)


def seal(face) -> None:
    """`weld_lips`, and the lip mask groups deleted."""
    if weld_lips(face) <= 0:
        raise RuntimeError("nothing was welded")
    for name in LIP_MASKS:
        group = face.vertex_groups.get(name)
        if group is not None:
            face.vertex_groups.remove(group)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    addon.register()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(SAMPLE))
        face = bpy.data.objects[HEAD]
        convert.select_only(face)
        bpy.ops.mpeg4.remove_face()
        seal(face)
        bpy.ops.wm.save_as_mainfile(filepath=str(args.out / "sealed.blend"))
        bpy.ops.mpeg4.open_sealed_mouth()
        bpy.ops.wm.save_as_mainfile(filepath=str(args.out / "sealed_cut.blend"))
    finally:
        addon.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
