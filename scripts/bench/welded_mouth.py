"""A welded mouth's corners read off the skin's pits, measured against the truth before any goes into placement
(docs/auto_placement.md, "Head 4's mouth: not the Y-up path; its height from the corners' pits, measured and not
kept").

    .venv/bin/python -m scripts.bench.evaluate_placement --heads /tmp/devheads --template NPZ --dump DIR
    .venv/bin/python -m scripts.bench.welded_mouth DIR

DIR holds what `evaluate_placement --dump` saved per head (its mesh, truth, placement and the face's axes: left,
up, forward). Pure numpy, no Blender. A mouth is taken as welded when `slit.read_slit` reads no slit between
the lips (the development heads have no opening at the mouth). For each such head, printed in millimetres
of the head as made (left, up, forward): beside each placed corner 2.4/2.5, the skin's most concave point (the
least local height, `features.local_height`, over a RADIUS ball, within REACH of the corner) against the truth's
corner, and the placed corner against it. A pit at the truth's height would put a mouth slid up or down back at
its height; the spread of "pit - truth" along up over the heads says whether it does.
"""

from __future__ import annotations

import sys

import numpy as np

from addon.mpeg4.feature_points import fp_index
from addon.placement.features import local_height
from addon.placement.pipeline import SKIN_SHARE
from addon.placement.slit import read_slit
from addon.placement.surface import Surface, area_samples, loose_parts, triangle_areas
from scripts.bench.placement_readings import dumped_heads

REACH = 0.006  # m of the head as made: the pit is looked for this near the placed corner
RADIUS = 0.006  # m: the local height's ball, about a lip's height
SAMPLES = 6000  # area samples of the skin round a corner


def skin(vertices: np.ndarray, triangles: np.ndarray) -> Surface:
    """The loose pieces at least SKIN_SHARE of the largest one's area, as the placement takes the skin."""
    labels = loose_parts(len(vertices), triangles)
    area = np.bincount(labels[triangles[:, 0]], weights=triangle_areas(vertices, triangles), minlength=labels.max() + 1)
    keep = np.isin(labels[triangles[:, 0]], np.flatnonzero(area >= SKIN_SHARE * area.max()))
    return Surface(vertices, triangles[keep])


def pit(surface: Surface, guess: np.ndarray, size: float) -> np.ndarray:
    """The skin's sample of least local height (ball RADIUS) within REACH of `guess` (`size`: world units per m)."""
    reach, radius = REACH * size, RADIUS * size
    near = np.linalg.norm(surface.vertices - guess, axis=1) < reach + radius
    samples, normals = area_samples(surface.vertices, surface.triangles[near[surface.triangles].all(axis=1)], SAMPLES)
    looked = np.linalg.norm(samples - guess, axis=1) < reach
    heights = local_height(samples[looked], normals[looked], samples, radius)
    return samples[looked][np.argmin(heights)]


def main(argv: list[str] | None = None) -> int:
    paths = dumped_heads(argv, __doc__.splitlines()[0], "welded_mouth")
    if not paths:
        return 1
    ups = []
    for path in paths:
        data = np.load(path)
        vertices, triangles = data["vertices"], data["triangles"].astype(np.int64)
        truth, placed, axes, size = data["truth"], data["placed"], data["axes"], float(data["factor"])
        surface = skin(vertices, triangles)
        if read_slit(placed.copy(), surface, axes):
            print(f"{path.stem:28s} the lips meet along a slit: not read")
            continue
        mm = 1000.0 / size
        for fp_id in ("2.4", "2.5"):
            k = fp_index(fp_id)
            read = pit(surface, placed[k], size)
            ups.append((read - truth[k]) @ axes[1] * mm)
            print(
                f"{path.stem:28s} {fp_id}: pit - truth {np.round((read - truth[k]) @ axes.T * mm, 1)}, "
                f"placed - truth {np.round((placed[k] - truth[k]) @ axes.T * mm, 1)} (left, up, forward mm)"
            )
    if ups:
        print(f"pit - truth along up over the welded corners: {min(ups):.1f} to {max(ups):.1f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
