"""Where Elastic Bones turns faces over on the development units (shipped weights and trained parameters).

    .venv/bin/python -m scripts.bench.elastic_folds --targets DIR [--face FACE.blend]

Per unit and FP-motion scale (`evaluate.FOLD_SCALES`, the engine driven as `evaluate --method elastic_bones`
drives it): the faces turned over, how many of them the sculpt scaled alike turns over too, and where: each
face under the bone with the largest mean weight on its corners (`head` where the face bones have faded),
"lining" when it lies on the mouth's lining (`elastic.skinning.mouth_lining`).
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np

from addon.blender.face_data import mesh_edges
from addon.deform.folds import inverted_faces
from addon.elastic.skinning import mouth_lining
from scripts.bench import evaluate
from scripts.bench.elastic_bones import ElasticBonesMethod


def fold_places(method: ElasticBonesMethod, fans: tuple, folded: np.ndarray, lining: np.ndarray) -> Counter:
    """Where the (F,) `folded` faces are: the bone with the largest mean weight on each face's corners, with
    " (lining)" for a face whose corners lie on the mouth's lining on average."""
    triangles, owner = fans
    places = Counter()
    for polygon in np.flatnonzero(folded):
        corners = np.unique(triangles[owner == polygon])
        bone = method.skeleton.names[int(np.argmax(method.weights[corners].mean(axis=0)))]
        places[bone + (" (lining)" if lining[corners].mean() >= 0.5 else "")] += 1
    return places


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", required=True, help="folder of MakeHuman .target(.gz) files")
    parser.add_argument("--face", default=str(evaluate.DEFAULT_FACE))
    args = parser.parse_args()
    face = evaluate.load_face(Path(args.face))
    method = ElasticBonesMethod(face, unfold_skin=False)  # where the skinning turns faces over
    lining = mouth_lining(face.rest, np.asarray(mesh_edges(face.head.data)).reshape(-1, 2), method.skeleton)
    print(f"`.venv/bin/python -m scripts.bench.elastic_folds {' '.join(sys.argv[1:])}`\n")
    print("| unit | FP motion times | faces turned over | the sculpt turns over too | where (largest weight) |")
    print("|---|---:|---:|---:|---|")
    totals = {scale: [0, 0] for scale in evaluate.FOLD_SCALES}
    for path in evaluate.target_files(Path(args.targets)):
        offsets, fp_offsets = evaluate.target_motion(path, face)
        for scale in evaluate.FOLD_SCALES:
            folded = inverted_faces(face.rest, method.evaluate(face.control_rest + scale * fp_offsets), *face.fans)
            if not folded.any():
                continue
            shared = int((folded & inverted_faces(face.rest, face.rest + scale * offsets, *face.fans)).sum())
            totals[scale][0] += int(folded.sum())
            totals[scale][1] += shared
            places = ", ".join(f"{p} {n}" for p, n in fold_places(method, face.fans, folded, lining).most_common())
            print(f"| {evaluate.target_name(path)} | {scale} | {folded.sum()} | {shared} | {places} |")
    for scale, (count, shared) in totals.items():
        print(f"| all units | {scale} | {count} | {shared} | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
