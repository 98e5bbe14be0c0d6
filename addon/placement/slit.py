"""A mouth with no opening in the mesh whose lips meet along a slit (a scan: the lips touch along a crease, a
pocket of skin behind them): the inner lip points on the crease, each on its own lip, the corners where the slit
ends. Read off the skin in planes across the face, so no constant is fitted to any head.

In a plane across the face (normal the face's left) the skin's section seen from in front (per band of height
the most forward point of the section: what a viewer in front of the face sees) has between the two lip bulges
a notch, the crease where the lips meet: the seen point lying deepest below the lower of the most forward points
above and below it (the lips' fronts; `crease`). The section's points are told apart by lip: nearer over the
skin to the upper lip's front than to the lower's, or the other way (`Lips`). The two lips' section points
nearest the crease are a slit's two walls when the section joins them only the long way round (through the
pocket, or not at all: more than SLIT_DETOUR times their distance, or the reading's resolution); where the skin
is one surface there (lips welded shut, a fold of skin, past a slit's end) the way between them is short.

`read_slit`: when the middle plane holds a slit, planes are cut outward from the middle, each looking for the
crease near the last one's (a crease that jumps further ends the slit); the corners 2.4/2.5 are the crease where
the slit stops, found by halving the step between the last plane with a slit and the first without. An inner
lip pair (2.2/2.3 in the middle plane, 2.6/2.8 and 2.7/2.9 as far along the read slit as the registration had
them along its own) is kept where the registration put each point on its own lip (where on its lip's inner face
the contour runs, the skin does not say); otherwise it is read: each lip's vertex nearest the crease (set-up
reads an FP as its nearest vertex, and where the walls touch that of a point on one wall can be the other's).
The outer lip points stay where they are on their own lips; one on the other lip moves as its lip's inner point
moved, and the outer corners 8.3/8.4 move as the inner ones did. The caller snaps the moved points to the skin.

Nothing changes where the middle plane holds no slit (lips apart, lips welded shut: nothing says where a welded
mouth's corners are): the registration's points stay, as they do where an opening in the mesh gave them
(`openings`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mpeg4.feature_points import fp_index
from .nicp import edges_of
from .scipy_modules import csr_matrix, dijkstra
from .section import chain_graph, front, section
from .surface import NEAR_VERTICES, Surface, closest_on_triangles

BAND = 0.25  # the crease is looked for this share of the carried mouth width above and below the guess
TRACK = 0.1  # in the next plane out, this share of the width above and below the last crease
BANDS = 40  # the seen profile in bands of this share of the looked-at height
STEPS = 40  # planes out from the middle: a step of the carried mouth width over this
HALVINGS = 6  # the corner's plane found to a step / 2**HALVINGS
SLIT_DETOUR = 2.0  # a slit's walls are joined along the section only by a way this many times their distance
REACH = 0.5  # the lips' fronts are reached over the skin within this share of the mouth width

INNER = (("2.2", "2.3", None), ("2.6", "2.8", "2.4"), ("2.7", "2.9", "2.5"))  # upper, lower, the corner they lie to
# an outer lip point not on its own lip moves with an inner one of its lip (0 upper, 1 lower); the outer corners
# move with the inner ones
OUTER = {
    "8.1": ("2.2", 0),
    "8.9": ("2.2", 0),
    "8.10": ("2.2", 0),
    "8.5": ("2.6", 0),
    "8.6": ("2.7", 0),
    "8.2": ("2.3", 1),
    "8.7": ("2.8", 1),
    "8.8": ("2.9", 1),
}
OUTER_CORNERS = {"8.3": "2.4", "8.4": "2.5"}


def _seen(crossings: np.ndarray, segments: np.ndarray, centre: float, half: float, axes: np.ndarray):
    """The section seen from in front within `half` of height `centre` (along up): per band (BANDS of
    2 * half) the most forward sample of the segments; returns (points (B, 3), depths (B,)) in order of
    height."""
    points, _heights, depths = front(crossings[segments], axes[1], axes[2], centre, half, 2.0 * half / BANDS)
    # what lies further behind the most forward than the looked-at height is not the lips (a hole in the
    # section shows the head's far side)
    keep = depths >= depths.max(initial=-np.inf) - 2.0 * half
    return points[keep], depths[keep]


def crease(points: np.ndarray, depths: np.ndarray):
    """The seen profile's deepest notch (`points`, `depths` in order of height): the index of the point lying
    deepest below the lower of the most forward points above and below it, with those two indices; None
    when no point lies below both."""
    if len(depths) < 3:
        return None
    below = np.maximum.accumulate(depths)  # the most forward at or below each
    above = np.maximum.accumulate(depths[::-1])[::-1]
    valley = np.minimum(below, above) - depths
    notch = int(np.argmax(valley))
    if valley[notch] <= 0.0:
        return None
    lower = int(np.argmax(depths[: notch + 1]))
    upper = notch + int(np.argmax(depths[notch:]))
    return notch, upper, lower


@dataclass(frozen=True)
class Reading:
    upper: np.ndarray  # the upper lip's vertex nearest the crease
    lower: np.ndarray  # the lower lip's
    crease: np.ndarray
    slit: bool  # the two are a slit's walls
    paths: np.ndarray  # (2, V) over the skin from the upper and the lower lip's front (inf beyond reach)
    resolution: float  # the seen profile's band: nearer than this, the two walls are one place to the reading


class Lips:
    """The skin's edge graph, to tell a section's points on the upper lip from those on the lower (nearer
    over the skin to the upper lip's front than to the lower's) and to read the slit in a plane."""

    def __init__(self, surface: Surface, axes: np.ndarray, width: float):
        self.surface, self.axes, self.width = surface, axes, width
        self.vertices, self.triangles = surface.vertices, surface.triangles
        edges = edges_of(self.triangles)
        length = np.linalg.norm(self.vertices[edges[:, 0]] - self.vertices[edges[:, 1]], axis=1)
        n = len(self.vertices)
        self.graph = csr_matrix((length, (edges[:, 0], edges[:, 1])), shape=(n, n))

    @staticmethod
    def _over_skin(paths: np.ndarray, points: np.ndarray, corners: np.ndarray, vertices: np.ndarray) -> np.ndarray:
        """(2, K) the way over the skin from each lip's front to `points` (K, 3), each through the nearest
        of its `corners` (K, C: the edge's or triangle's vertices it lies on)."""
        step = np.linalg.norm(vertices[corners] - points[:, None], axis=2)
        return (paths[:, corners] + step[None]).min(axis=2)

    def read(self, level: float, centre: float, half: float):
        """In the plane left . x = `level`, looking within `half` of height `centre`: (upper lip's point,
        lower lip's point, crease, whether they are a slit's walls), or None when no crease is seen."""
        crossings, edges, segments = section(self.vertices, self.triangles, self.axes[0], level)
        if not len(segments):
            return None
        points, depths = _seen(crossings, segments, centre, half, self.axes)
        found = crease(points, depths)
        if found is None:
            return None
        notch, upper, lower = (points[k] for k in found)
        _d, sources = self.surface.tree.query(np.stack([upper, lower]))
        paths = dijkstra(self.graph, directed=False, indices=sources, limit=REACH * self.width)
        to_upper, to_lower = self._over_skin(paths, crossings, edges, self.vertices)
        reached = np.isfinite(to_upper) | np.isfinite(to_lower)
        distance = np.linalg.norm(crossings - notch, axis=1)
        on_upper = reached & (to_upper < to_lower)
        on_lower = reached & (to_lower <= to_upper)
        if not on_upper.any() or not on_lower.any():
            return None
        u = int(np.flatnonzero(on_upper)[np.argmin(distance[on_upper])])
        lo = int(np.flatnonzero(on_lower)[np.argmin(distance[on_lower])])
        gap = float(np.linalg.norm(crossings[u] - crossings[lo]))
        along = self._along(crossings, segments, u, lo)
        # walls nearer than the seen profile's bands are one point to this reading
        resolution = 2.0 * half / BANDS
        slit = along > SLIT_DETOUR * max(gap, resolution)
        # each lip's point is its own vertex nearest the crease (of the cut edges' ends): set-up reads an FP as
        # the vertex nearest it, and where the walls touch that of a point on one wall can be the other's
        ends = np.unique(edges)
        ends = ends[np.isfinite(paths[:, ends]).any(axis=0)]
        own = [ends[paths[0, ends] < paths[1, ends]], ends[paths[1, ends] < paths[0, ends]]]
        if not len(own[0]) or not len(own[1]):
            return None
        at = [self.vertices[k[np.argmin(np.linalg.norm(self.vertices[k] - notch, axis=1))]] for k in own]
        return Reading(at[0], at[1], notch, slit, paths, resolution)

    def on_own_lips(self, reading: Reading, upper: np.ndarray, lower: np.ndarray) -> bool:
        """Whether `upper` is on the upper lip and `lower` on the lower one, as `reading` tells them apart."""
        return self.on_lip(reading, upper, 0) and self.on_lip(reading, lower, 1)

    def on_lip(self, reading: Reading, point: np.ndarray, lip: int) -> bool:
        """Whether `point` is on the upper (`lip` 0) or lower (1) lip as `reading` tells them apart: skin of that
        lip lies within the reading's resolution of it, or is the nearest skin (a point on the slit's edge, where
        the walls touch, is on both). A triangle is the lip's when the way over the skin from that lip's front
        through its corners is shorter than from the other's."""
        surface = self.surface
        _d, nearest = surface.tree.query(point, k=min(2 * NEAR_VERTICES, len(self.vertices)))
        triangles = np.unique(surface.vertex_triangles[np.atleast_1d(nearest)])
        triangles = triangles[triangles >= 0]
        corners = self.triangles[triangles]
        q = closest_on_triangles(
            np.repeat(point[None], len(corners), axis=0), *(self.vertices[corners[:, j]] for j in range(3))
        )
        distance = np.linalg.norm(q - point, axis=1)
        ways = (reading.paths[:, corners] + np.linalg.norm(self.vertices[corners] - point, axis=2)).min(axis=2)
        own = ways[lip] < ways[1 - lip]  # (T,): through the nearer of its corners
        return bool(own[np.argmin(distance)] or np.any(own & (distance <= reading.resolution)))

    @staticmethod
    def _along(crossings: np.ndarray, segments: np.ndarray, a: int, b: int) -> float:
        """The shortest way from crossing `a` to `b` along the section's segments (inf when none)."""
        if a == b:
            return 0.0
        return float(dijkstra(chain_graph(crossings, segments), directed=False, indices=a)[b])


def _continues(reading: Reading | None, last: Reading, reach: float) -> bool:
    """Whether `reading` is a slit that goes on from `last`'s: its crease no further from the last one than the
    height the next plane looks within."""
    return reading is not None and reading.slit and float(np.linalg.norm(reading.crease - last.crease)) <= reach


def read_slit(placed: np.ndarray, surface: Surface, axes: np.ndarray) -> list[str]:
    """Move the mouth's points of `placed` (84, 3; changed in place) onto the slit where the lips meet, when
    the middle plane holds one (see the module's doc). Returns the FP ids moved."""
    left, up = axes[0], axes[1]
    corner_left, corner_right = placed[fp_index("2.4")], placed[fp_index("2.5")]
    width = abs((corner_left - corner_right) @ left)
    if width <= 0.0:
        return []
    lips = Lips(surface, axes, width)
    middle = 0.5 * (placed[fp_index("2.2")] + placed[fp_index("2.3")])
    level = float(middle @ left)
    first = lips.read(level, float(middle @ up), BAND * width)
    if first is None or not first.slit:
        return []
    ends = []
    step = width / STEPS
    track = {level: float(first.crease @ up)}  # the crease's height in each plane along the slit
    for direction in (1.0, -1.0):
        last, height, at = first, float(first.crease @ up), level
        while True:
            nxt = lips.read(at + direction * step, height, TRACK * width)
            if not _continues(nxt, last, TRACK * width):
                break
            last, height, at = nxt, float(nxt.crease @ up), at + direction * step
            track[at] = height
            if abs(at - level) > width:
                break
        lo_level, span = at, step
        for _ in range(HALVINGS):
            span *= 0.5
            mid = lo_level + direction * span
            probe = lips.read(mid, height, TRACK * width)
            if _continues(probe, last, TRACK * width):
                last, height, lo_level = probe, float(probe.crease @ up), mid
        ends.append((lo_level, last))
    (left_level, left_end), (right_level, right_end) = ends
    levels = sorted(track)

    def height_at(at: float) -> float:
        return float(np.interp(at, levels, [track[k] for k in levels]))

    moved = []
    old = placed.copy()
    placed[fp_index("2.4")], placed[fp_index("2.5")] = left_end.crease, right_end.crease
    moved += ["2.4", "2.5"]
    for upper, lower, corner in INNER:
        if corner is None:
            reading = first
        else:  # as far along the read slit as the registration had the pair along its own
            read = left_level if corner == "2.4" else right_level
            carried = 0.5 * (old[fp_index(upper)] + old[fp_index(lower)]) @ left
            at = level + (carried - level) / ((old[fp_index(corner)] @ left) - level) * (read - level)
            reading = lips.read(at, height_at(at), TRACK * width)
        if reading is None or lips.on_own_lips(reading, old[fp_index(upper)], old[fp_index(lower)]):
            continue  # the registration's points are on their own lips: where on them, the skin does not say
        placed[fp_index(upper)], placed[fp_index(lower)] = reading.upper, reading.lower
        moved += [upper, lower]
    for fp_id, (inner, lip) in OUTER.items():
        if inner not in moved:  # its lip's inner point stayed: so does it, and no plane need be read for it
            continue
        point = old[fp_index(fp_id)]
        reading = lips.read(float(point @ left), height_at(float(point @ left)), TRACK * width)
        if reading is not None and reading.slit and not lips.on_lip(reading, point, lip):
            placed[fp_index(fp_id)] = point + placed[fp_index(inner)] - old[fp_index(inner)]
            moved.append(fp_id)
    for fp_id, inner in OUTER_CORNERS.items():
        placed[fp_index(fp_id)] = old[fp_index(fp_id)] + placed[fp_index(inner)] - old[fp_index(inner)]
        moved.append(fp_id)
    return moved
