"""The head on a body: a character's whole body in one mesh (T-pose, A-pose, any rotation) cut to the head
and neck before the template is fitted, so its arms or legs are never taken for the head's width.

Along each of the mesh's principal axes, both ways, the surface is cut into slabs from that end inwards and
each slab's cross-section measured (its extent along the other two principal axes). A head seen from the
top of a body widens to its widest, narrows to the neck, and below the neck the shoulders (or arms) are far
wider than the head: that narrowest slab between the head's widest and the first slab much wider than it is
the neck. A hand or a foot at the other ends narrows at the wrist or ankle too, but it is flat (one extent
of its widest slab less than half the other) where a head is round (its depth about its width), and a head
is about as tall as it is deep (a bump such as an ear is not); of the ends that pass, the roundest is the
head. What is kept: the head, and half a head height below its neck within one head width of the head's
axis (not the arms of a T-pose at shoulder height). A mesh with no end like that (a head alone, with its
neck and perhaps shoulders) is left whole.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SLABS = 100  # slabs across the mesh's whole length along an axis (a 1.8 m body: 18 mm each)
REACH = 0.4  # only the top share of the length is searched for a head and neck
SHOULDERS = 1.5  # below the neck the body is at least this many head widths wide
NARROWED = 0.9  # the profile has passed the head's widest once a slab is this much narrower
ROUND = 0.5  # a head's widest slab: its smaller extent at least this share of its larger
TALL = 0.6  # a head from its top to the neck is at least this share of its widest extent (an ear is not)
KEEP_BELOW_NECK = 0.5  # head heights of neck and shoulders kept below the neck, within a head width of its axis
BODY_LENGTH = 2.5  # a mesh at least this many head heights long along the head's axis is a body


def _profile(points: np.ndarray, axes: np.ndarray, up: np.ndarray):
    """Per slab from the `up` end: (its two extents across (k, 2), slab thickness, top height)."""
    height = points @ up
    top, length = height.max(), np.ptp(height)
    step = length / SLABS
    across = points @ axes.T
    extents = np.zeros((int(REACH * SLABS), 2))
    for k in range(len(extents)):
        inside = (height <= top - k * step) & (height > top - (k + 1) * step)
        if inside.sum() >= 3:
            extents[k] = np.percentile(across[inside], 98, axis=0) - np.percentile(across[inside], 2, axis=0)
    return extents, step, top


def _neck(widths: np.ndarray) -> tuple[int, int] | None:
    """(the head's widest slab, the neck's slab) in a width profile from the top, or None when nothing below
    is much wider than the top's widest (no shoulders: not a body). The widest is frozen once the profile
    has narrowed by a tenth (past the head, into the neck)."""
    widest, frozen = 0, False
    for k in range(1, len(widths)):
        if frozen and widths[k] > SHOULDERS * widths[widest]:
            return widest, widest + int(np.argmin(widths[widest:k]))
        if not frozen:
            if widths[k] > widths[widest]:
                widest = k
            elif widths[k] < NARROWED * widths[widest]:
                frozen = True
    return None


@dataclass(frozen=True)
class HeadRegion:
    up: np.ndarray  # (3,) unit: the head's up
    bottom: float  # height along `up` below which the mesh is cut away
    centre: np.ndarray  # (3,) a point on the head's vertical axis
    radius: float  # distance from that axis beyond which the mesh is cut away (arms, hands)

    def contains(self, points: np.ndarray) -> np.ndarray:
        offset = points - self.centre
        height = offset @ self.up
        across = np.linalg.norm(offset - height[:, None] * self.up, axis=1)
        return (points @ self.up >= self.bottom) & (across <= self.radius)


def head_region(points: np.ndarray) -> HeadRegion | None:
    """For area samples `points` (K, 3) of a mesh: where its head and neck are when the mesh is a body
    with a head on a neck, else None."""
    centred = points - points.mean(axis=0)
    _s, _v, principal = np.linalg.svd(centred, full_matrices=False)
    best = None
    for i in range(3):
        others = principal[[j for j in range(3) if j != i]]
        for sign in (1.0, -1.0):
            up = sign * principal[i]
            extents, step, top = _profile(points, others, up)
            found = _neck(extents.max(axis=1))
            if found is None:
                continue
            widest, neck = found
            roundness = extents[widest].min() / max(extents[widest].max(), 1e-300)
            head_height = (neck + 1) * step
            tall = head_height >= TALL * extents[widest].max()
            if roundness < ROUND or not tall or np.ptp(points @ up) < BODY_LENGTH * head_height:
                continue
            if best is None or roundness > best[0]:
                head = points[points @ up >= top - head_height]
                region = HeadRegion(
                    up, top - (1.0 + KEEP_BELOW_NECK) * head_height, np.median(head, axis=0), extents[widest].max()
                )
                best = (roundness, region)
    return None if best is None else best[1]
