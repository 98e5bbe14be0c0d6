"""Readings of the nose's base (9.4/9.5) and the chin (2.10, 2.1) off the skin, measured against the development
heads' truth before any goes into placement (docs/auto_placement.md, "The nose's base and the chin read off the
skin").

    .venv/bin/python -m scripts.bench.evaluate_placement --heads /tmp/devheads --template NPZ --dump DIR
    .venv/bin/python -m scripts.bench.placement_readings DIR

DIR holds what `evaluate_placement --dump` saved per head (its mesh, truth, placement and the face's axes: left,
up, forward). Pure numpy, no Blender. Printed per head, in millimetres of the head as made:

- 9.4/9.5 and the alar crease: in the plane across the face through the point (normal the face's left) the skin
  seen from in front (`section.front`) has a notch where the nose's wing meets the lip (the crease, `slit.crease`);
  the truth's offset from the crease in its own plane (up, forward), the template's own for comparison, and the
  error of the reading "the crease in the carried point's plane plus the template's offset" against the carried
  point's.
- 2.10, the chin boss: the skin's mid-plane section from 8.2 down round the chin (`subnasale.mid_line_chain`);
  the most forward point of it within W mm of the carried 2.10's height, for several W; and on the truth's own
  mesh how far above the truth the chin's most forward point lies and how much further forward it is (a flat
  chin's front: the most forward point slides along it).
- 2.1, the chin's bottom: the point of the same section furthest outside the chord from the labiomental sulcus
  (its deepest notch below the lower lip) to the throat (the point furthest inside the chord from the chin's
  front to the neck).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from addon.mpeg4.feature_points import fp_index
from addon.placement import template
from addon.placement.rigid import TEMPLATE_AXES
from addon.placement.section import front, section
from addon.placement.slit import crease
from addon.placement.subnasale import mid_line_chain

ABOVE, HALF = 0.004, 0.012  # m: the seen profile round the nose's base, centred this far above the point
WINDOWS = (3.0, 4.0, 5.0, 6.0, 8.0)  # mm: the chin boss looked for this far above and below the carried one
NECK = (0.06, 0.03)  # m: the mid-plane section followed to this far below and behind 2.1 (to the throat)


def alar_crease(vertices, triangles, axes, point, size: float) -> np.ndarray | None:
    """The crease between the nose's wing and the lip in the plane across the face through `point`: the seen
    profile's deepest notch within HALF of ABOVE above it (`size` the head's scale against metres)."""
    crossings, _edges, segments = section(vertices, triangles, axes[0], float(point @ axes[0]))
    if not len(segments):
        return None
    points, _heights, depths = front(
        crossings[segments], axes[1], axes[2], float(point @ axes[1]) + ABOVE * size, HALF * size, HALF * size / 20
    )
    found = crease(points, depths)
    return None if found is None else points[found[0]]


def chin_chain(vertices, triangles, axes, points, size: float) -> np.ndarray:
    """The skin's mid-plane section through 2.10 from 8.2 down round the chin to the neck (`points` (84, 3))."""
    boss, bottom = points[fp_index("2.10")], points[fp_index("2.1")]
    end = bottom - (NECK[0] * axes[1] + NECK[1] * axes[2]) * size
    return mid_line_chain(vertices, triangles, axes[0], float(boss @ axes[0]), points[fp_index("8.2")], end)


def _outside(chain: np.ndarray, a: np.ndarray, b: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """How far each chain point lies in front of the chord a-b (in the mid-plane, towards the face's front)."""
    normal = np.cross(axes[0], b - a)
    normal /= np.linalg.norm(normal)
    return (chain - a) @ (normal if normal @ axes[2] > 0 else -normal)


def sulcus_and_throat(chain: np.ndarray, axes: np.ndarray) -> tuple[int, int, int]:
    """Indices of the labiomental sulcus (the chain's deepest notch, seen from in front), the chin's most
    forward point below it, and the throat (furthest inside the chord from that point to the chain's end)."""
    depth = chain @ axes[2]
    valley = np.minimum(np.maximum.accumulate(depth), np.maximum.accumulate(depth[::-1])[::-1]) - depth
    sulcus = int(np.argmax(valley))
    chin = sulcus + int(np.argmax(depth[sulcus:]))
    throat = chin + int(np.argmax(-_outside(chain[chin:], chain[chin], chain[-1], axes)))
    return sulcus, chin, throat


def dumped_heads(argv: list[str] | None, description: str, name: str) -> list[Path]:
    """The .npz files of `evaluate_placement --dump` in the folder the command line names (none: said on stderr)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("dump", type=Path, help="the .npz files of evaluate_placement --dump")
    args = parser.parse_args(argv)
    paths = sorted(args.dump.glob("*.npz"))
    if not paths:
        print(f"{name}: no .npz files in {args.dump}", file=sys.stderr)
    return paths


def main(argv: list[str] | None = None) -> int:
    paths = dumped_heads(argv, __doc__.splitlines()[0], "placement_readings")
    if not paths:
        return 1
    model = template.load_template()
    offsets = {}
    for fp_id in ("9.4", "9.5"):
        point = model.fp_positions[fp_index(fp_id)]
        offsets[fp_id] = (
            point - alar_crease(model.vertices, model.triangles, TEMPLATE_AXES, point, 1.0)
        ) @ TEMPLATE_AXES.T
        print(f"template {fp_id}: truth - crease (up, forward) {np.round(offsets[fp_id][1:] * 1000.0, 1)} mm")
    nose, boss, bottom = [], [], []
    for path in paths:
        data = np.load(path)
        vertices, triangles = data["vertices"], data["triangles"].astype(np.int64)
        truth, placed, axes, size = data["truth"], data["placed"], data["axes"], float(data["factor"])
        mm = 1000.0 / size
        row = []
        for fp_id in ("9.5", "9.4"):
            k = fp_index(fp_id)
            own = alar_crease(vertices, triangles, axes, truth[k], size)
            read = alar_crease(vertices, triangles, axes, placed[k], size) + size * offsets[fp_id] @ axes
            row += [np.linalg.norm(placed[k] - truth[k]) * mm, np.linalg.norm(read - truth[k]) * mm]
            if fp_id == "9.5":
                lead = np.round((truth[k] - own) @ axes[1:].T * mm, 1)
                print(f"{path.stem:28s} 9.5: truth - crease (up, forward) {lead}")
        nose.append(row)
        # the chin boss: the most forward point of the carried section near the carried point
        chain = chin_chain(vertices, triangles, axes, placed, size)
        carried = placed[fp_index("2.10")]
        height = (chain - carried) @ axes[1] * mm
        row = [np.linalg.norm(carried - truth[fp_index("2.10")]) * mm]
        for window in WINDOWS:
            near = np.abs(height) < window
            read = chain[near][np.argmax(chain[near] @ axes[2])]
            row.append(np.linalg.norm(read - truth[fp_index("2.10")]) * mm)
        own = chin_chain(vertices, triangles, axes, truth, size)
        _sulcus, chin, _throat = sulcus_and_throat(own, axes)
        lead = (own[chin] - truth[fp_index("2.10")]) @ axes[1:].T * mm
        print(f"{'':28s} 2.10: the truth's chin most forward {lead[0]:.1f} mm above it, {lead[1]:.1f} mm in front")
        boss.append(row)
        sulcus, _chin, throat = sulcus_and_throat(chain, axes)
        below = sulcus + int(np.argmax(_outside(chain[sulcus : throat + 1], chain[sulcus], chain[throat], axes)))
        bottom.append(
            [
                np.linalg.norm(placed[fp_index("2.1")] - truth[fp_index("2.1")]) * mm,
                np.linalg.norm(chain[below] - truth[fp_index("2.1")]) * mm,
            ]
        )
    nose, boss, bottom = np.array(nose), np.array(boss), np.array(bottom)

    def figure(errors: np.ndarray) -> str:
        return f"{errors.mean():.2f} ({errors.max():.2f})"

    print("\nerrors, mm: mean (max) over the heads")
    for k, fp_id in enumerate(("9.5", "9.4")):
        print(f"{fp_id:4s} carried {figure(nose[:, 2 * k])}  crease + template offset {figure(nose[:, 2 * k + 1])}")
    print(f"2.10 carried {figure(boss[:, 0])}", end="")
    for k, window in enumerate(WINDOWS, start=1):
        print(f"  most forward within {window:g} mm {figure(boss[:, k])}", end="")
    print(f"\n2.1  carried {figure(bottom[:, 0])}  furthest outside sulcus-throat {figure(bottom[:, 1])}")
    print("per head, 2.1 read:", " ".join(f"{e:.2f}" for e in bottom[:, 1]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
