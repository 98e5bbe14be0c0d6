"""Dirichlet free-form deformation of the generic face by its feature points (Escher et al. §3.1).

Every vertex x follows the FPs through its Sibson coordinates with respect to the FP set (Moccozet &
Magnenat-Thalmann's DFFD of degree 1):

    x' = x + sum_i lambda_i(x) (p_i' - p_i)

`bind_dffd` computes the coordinates once per generic face ("performed only once for each generic
head and saved as a data file", §3.1.1); `DffdBinding.to_arrays` / `from_arrays` save and load them.
An FP moved to X lands at X, any affine map of all FPs moves every vertex by that map, and a vertex
moves only with its natural neighbours.

Outside the FPs' convex hull (neck, scalp, the back of the head) Sibson coordinates do not exist. Our
choice: 26 auxiliary sites, a 3 x 3 x 3 grid over the bounding box of the mesh and the FPs grown by a fifth
of its largest size on every side (its centre left out), which move with the robust affine fit of the FPs'
motion (`affine_fit`). Fixed frame points would pin the neck while the face moves (and lose affine
reproduction: scale the FPs and the neck would stay); the least-squares affine map keeps every affine motion
exact but lets a local motion (a chin) drag the sites and everything near them. The robust fit keeps both:
any affine motion of all FPs moves every vertex by that map, and a motion of a few FPs leaves the sites where
they are. A shell close around the head (rather than 8 corners far out) gives the vertices outside the FPs'
hull more of their weight from those sites, so less of a local motion spreads there. On the MakeHuman
development set of `scripts/bench/evaluate_fitting.py` (all FPs given; 135 faces) the median relative error
goes from 1.00 (8 corners half the box's size out, least squares; 59 faces fitted worse than not fitting) to
0.92 (52) with the robust fit and 0.88 (46) with the closer shell; the shell with least squares gives 1.00
(58). Anchors on the head (neck, back of the skull) that follow the robust fit gain nothing overall: they pin
the skull where whole-head changes reshape it.

FPs that coincide on the generic face (the sample head's 11.4 and 11.5) are one site; a target that
gives them apart is refused.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..mpeg4.feature_points import FP_IDS
from .affine_fit import robust_affine_fit
from .errors import BindingError, CoincidentFeaturePointsError, FeaturePointError
from .feature_point_set import (
    COINCIDENT_FRACTION,
    check_vertices,
    coincident_groups,
    extent,
    fp_array,
    require_spatial,
)
from .sibson import Progress, SibsonCoordinates, sibson_coordinates

FORMAT_VERSION = 2
SHELL_MARGIN = 0.2  # of the largest size of the box around mesh and FPs, on every side
AUXILIARY_COUNT = 26  # the 3 x 3 x 3 grid over that box without its centre
ROW_SUM_TOLERANCE = 1e-9  # a loaded binding's coordinates must sum to 1 this closely


@dataclass(frozen=True)
class DffdBinding:
    rest_vertices: np.ndarray  # (N, 3) the generic face
    fp_ids: tuple[str, ...]  # FPs that are sites, table order
    rest_fps: np.ndarray  # (n, 3)
    merged: tuple[tuple[str, str], ...]  # (FP, the site it coincides with on the generic face)
    rest_auxiliary: np.ndarray  # (26, 3) the shell around mesh and FPs, moved by the FPs' robust affine fit
    coordinates: SibsonCoordinates  # over the sites: the FPs, then the auxiliary corners

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays (no objects, no pickling) that `from_arrays` reads back bit for bit."""
        return {
            "format_version": np.array(FORMAT_VERSION, dtype=np.int64),
            "rest_vertices": self.rest_vertices,
            "fp_ids": np.array(self.fp_ids, dtype="U8"),
            "rest_fps": self.rest_fps,
            "merged": np.array(self.merged, dtype="U8").reshape(-1, 2),
            "rest_auxiliary": self.rest_auxiliary,
            "indices": self.coordinates.indices,
            "weights": self.coordinates.weights,
            "counts": self.coordinates.counts,
        }

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> DffdBinding:
        """The binding saved by `to_arrays`, every array checked (kind, shape, range) before use."""
        return _from_arrays(arrays)


def bind_dffd(
    rest_vertices: np.ndarray, rest_fps: Mapping[str, object], progress: Progress | None = None
) -> DffdBinding:
    """Sibson coordinates of every vertex of the generic face w.r.t. its FPs (FP id -> (3,) position).

    `progress(done, total)` reports the vertices done.
    """
    vertices = check_vertices(rest_vertices, "generic face")
    ids, points = fp_array(rest_fps, "generic face")
    merged = tuple((member, group[0]) for group in coincident_groups(ids, points) for member in group[1:])
    absorbed = {member for member, _ in merged}
    keep = [k for k, fp_id in enumerate(ids) if fp_id not in absorbed]
    site_ids, site_points = tuple(ids[k] for k in keep), points[keep]
    require_spatial(site_ids, site_points, "generic face")

    auxiliary = auxiliary_sites(np.vstack([vertices, site_points]))
    coordinates = sibson_coordinates(np.vstack([site_points, auxiliary]), vertices, progress)
    return DffdBinding(vertices, site_ids, site_points, merged, auxiliary, coordinates)


def auxiliary_sites(points: np.ndarray) -> np.ndarray:
    """(26, 3): the 3 x 3 x 3 grid over the bounding box of (n, 3) points grown by SHELL_MARGIN, centre left out."""
    low, high = points.min(axis=0), points.max(axis=0)
    margin = SHELL_MARGIN * float(np.max(high - low))
    steps = np.linspace(low - margin, high + margin, 3)  # (3, 3): rows low, middle, high
    grid = np.array([[steps[i, 0], steps[j, 1], steps[k, 2]] for i in range(3) for j in range(3) for k in range(3)])
    return np.delete(grid, 13, axis=0)  # (1, 1, 1): the middle of the box


def deform_dffd(binding: DffdBinding, fp_positions: Mapping[str, object]) -> np.ndarray:
    """(N, 3) the generic face with its FPs moved to `fp_positions` (every site FP; coincident ones agree)."""
    ids, points = fp_array(fp_positions, "target FPs")
    target = dict(zip(ids, points, strict=True))
    known = set(binding.fp_ids) | {member for member, _ in binding.merged}
    foreign = [fp_id for fp_id in ids if fp_id not in known]
    if foreign:
        raise FeaturePointError(f"target FPs {', '.join(foreign)} are not FPs of the generic face")
    stand_ins = {site: [site] for site in binding.fp_ids}
    for member, site in binding.merged:
        stand_ins[site].append(member)
    tolerance = COINCIDENT_FRACTION * extent(points)
    moved, missing = [], []
    for site in binding.fp_ids:
        given = [fp_id for fp_id in stand_ins[site] if fp_id in target]
        if not given:
            missing.append(site)
            continue
        for fp_id in given[1:]:
            gap = np.linalg.norm(target[fp_id] - target[given[0]])
            if gap > tolerance:
                raise CoincidentFeaturePointsError(
                    f"FPs {given[0]} and {fp_id} are one point on the generic face but the target puts them "
                    f"{1000 * gap:.3g} mm apart; give only one of them"
                )
        moved.append(target[given[0]])
    if missing:
        raise FeaturePointError(f"target FPs missing: {', '.join(missing)} (complete them first)")
    motion = np.array(moved) - binding.rest_fps
    fit = robust_affine_fit(binding.rest_fps, motion)
    auxiliary = binding.rest_auxiliary
    site_motion = np.vstack([motion, np.column_stack([auxiliary, np.ones(len(auxiliary))]) @ fit])
    return binding.rest_vertices + binding.coordinates.interpolate(site_motion)


_FLOAT_ARRAYS = ("rest_vertices", "rest_fps", "rest_auxiliary", "weights")
_ARRAYS = ("format_version", "fp_ids", "merged", "indices", "counts", *_FLOAT_ARRAYS)


def _from_arrays(arrays: Mapping[str, np.ndarray]) -> DffdBinding:
    missing = [name for name in _ARRAYS if name not in arrays]
    if missing:
        raise BindingError(f"DFFD binding lacks {', '.join(missing)}")
    a = {name: np.asarray(arrays[name]) for name in _ARRAYS}
    version = a["format_version"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != FORMAT_VERSION:
        raise BindingError(f"DFFD binding format version {version!r}; this add-on reads {FORMAT_VERSION}")
    for name in _FLOAT_ARRAYS:
        if a[name].dtype != np.float64 or not np.all(np.isfinite(a[name])):
            raise BindingError(f"DFFD binding: {name} must be finite float64, got {a[name].dtype}")
    for name in ("fp_ids", "merged"):
        if a[name].dtype.kind != "U":
            raise BindingError(f"DFFD binding: {name} must be text, got {a[name].dtype}")
    for name in ("indices", "counts"):
        if a[name].dtype != np.int32:
            raise BindingError(f"DFFD binding: {name} must be int32, got {a[name].dtype}")
    fp_ids = tuple(str(f) for f in a["fp_ids"].reshape(-1))
    merged = a["merged"]
    unknown = [f for f in (*fp_ids, *merged.reshape(-1).tolist()) if f not in FP_IDS]
    if unknown or len(set(fp_ids)) != len(fp_ids):
        raise BindingError(f"DFFD binding: unknown or repeated FP ids {unknown or sorted(fp_ids)}")
    n, n_vertices = len(fp_ids), len(a["rest_vertices"])
    shapes = {
        "fp_ids": (n,),
        "rest_fps": (n, 3),
        "rest_auxiliary": (AUXILIARY_COUNT, 3),
        "rest_vertices": (n_vertices, 3),
        "counts": (n_vertices,),
        "indices": (n_vertices, a["weights"].shape[-1] if a["weights"].ndim == 2 else -1),
        "weights": (n_vertices, a["indices"].shape[-1] if a["indices"].ndim == 2 else -1),
    }
    for name, shape in shapes.items():
        if a[name].shape != shape:
            raise BindingError(f"DFFD binding: {name} has shape {a[name].shape}, expected {shape}")
    if merged.ndim != 2 or merged.shape[1] != 2 or not set(merged[:, 1].tolist()) <= set(fp_ids):
        raise BindingError("DFFD binding: merged must pair FPs with site FPs")
    indices, weights, counts = a["indices"], a["weights"], a["counts"]
    width = indices.shape[1]
    used = np.arange(width)[None, :] < counts[:, None]
    if not np.all((counts >= 1) & (counts <= width)):
        raise BindingError(f"DFFD binding: counts must lie in 1..{width}")
    n_sites = n + AUXILIARY_COUNT
    if not np.all((indices >= 0) & (indices < n_sites)) or np.any(weights[~used] != 0.0):
        raise BindingError(f"DFFD binding: site indices must lie in 0..{n_sites - 1} and unused slots be empty")
    sums = weights.sum(axis=1)
    if np.any(np.abs(sums - 1.0) > ROW_SUM_TOLERANCE):
        worst = int(np.argmax(np.abs(sums - 1.0)))
        raise BindingError(f"DFFD binding: the coordinates of vertex {worst} sum to {sums[worst]!r}, not 1")
    coordinates = SibsonCoordinates(indices=indices, weights=weights, counts=counts, n_sites=n_sites)
    pairs = tuple((str(m), str(s)) for m, s in merged)
    return DffdBinding(a["rest_vertices"], fp_ids, a["rest_fps"], pairs, a["rest_auxiliary"], coordinates)
