"""Baseline deformers driven by feature-point displacements, for comparison with Planar Bones.

* RBF (Noh, Fidaleo & Neumann 2000): displacement field u(x) = Σ_j c_j φ_j(‖x − p_j‖) + a·[1, x] with
  Hardy's multiquadric φ_j(r) = √(r² + s_j²), s_j the distance from p_j to its nearest other control
  point, and side conditions Σ c_j = 0, Σ c_j p_j = 0. The system matrix depends only on the rest
  control points, so `bind_rbf` folds its inverse into one (N, K) matrix and a frame is one product.
* Feature-point weighted displacement (Kshirsagar, Garchery & Magnenat-Thalmann 2000). Each feature
  point FP_1 influences a vertex P up to an extent d interpolated between the distances d_12, d_13 to
  the two control-mesh neighbours FP_2, FP_3 flanking the direction FP_1 → P (the two with the smallest
  angles θ_2, θ_3): d = (d_12 sin θ_3 + d_13 sin θ_2) / (sin θ_2 + sin θ_3), so d = d_12 along FP_1 → FP_2.
  Weight W = sin(π/2 (1 − d_1P / d)) inside the extent (the paper's eq. 4). A vertex reached by several
  feature points moves by Σ W_j² ΔFP_j / Σ W_j: recalled, not checked against the paper's eq. 5; it keeps a
  lone influence attenuated (W ΔFP) and moves a vertex at FP_j by exactly ΔFP_j. Euclidean distances
  stand in for the paper's surface distances (no mesh connectivity is needed).

Both use the vertices of the control mesh (the points the triangles reference) as control points.
"""

from dataclasses import dataclass

import numpy as np

from .inputs import COINCIDENCE, DeformError, check_points, check_triangles


@dataclass(frozen=True, eq=False)
class RbfBinding:
    """RBF deformation: ``rest_vertices + vertex_weights @ ΔFP`` over the control points ``control_index``."""

    rest_vertices: np.ndarray
    control_rest: np.ndarray
    control_index: np.ndarray
    vertex_weights: np.ndarray  # (N, K)

    def evaluate(self, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        return evaluate_rbf(self, control_positions, out)


def bind_rbf(rest_vertices: np.ndarray, control_rest: np.ndarray, triangles: np.ndarray | None = None) -> RbfBinding:
    """Solve the multiquadric system once; coincident or coplanar control points raise `DeformError`."""
    rest = check_points(rest_vertices, "rest_vertices")
    control = check_points(control_rest, "control_rest")
    index = _control_index(control, triangles)
    points = control[index]
    k = len(points)
    if k < 5:
        raise DeformError(f"RBF needs at least 5 control points, got {k}")
    separation = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=-1)
    np.fill_diagonal(separation, np.inf)
    tolerance = COINCIDENCE * float(np.ptp(points, axis=0).max())
    i, j = np.unravel_index(np.argmin(separation), separation.shape)
    if separation[i, j] <= tolerance:
        raise DeformError(
            f"control points {index[i]} and {index[j]} coincide: the RBF system is singular "
            "(merge them or give them distinct rest positions)"
        )
    shape = separation.min(axis=0)  # s_j
    np.fill_diagonal(separation, 0.0)

    system = np.zeros((k + 4, k + 4))
    system[:k, :k] = np.sqrt(separation**2 + shape**2)
    system[:k, k] = system[k, :k] = 1.0
    system[:k, k + 1 :] = points
    system[k + 1 :, :k] = points.T
    try:
        inverse = np.linalg.solve(system, np.eye(k + 4)[:, :k])
    except np.linalg.LinAlgError as error:
        raise DeformError("control points are coplanar: the RBF linear term is undetermined") from error
    if not np.allclose(system @ inverse, np.eye(k + 4)[:, :k], atol=1e-6):
        raise DeformError("the RBF system is ill-conditioned (control points nearly coplanar?)")

    distance = np.linalg.norm(rest[:, None, :] - points[None, :, :], axis=-1)
    basis = np.concatenate([np.sqrt(distance**2 + shape**2), np.ones((len(rest), 1)), rest], axis=1)
    return RbfBinding(rest, control, index, basis @ inverse)


def evaluate_rbf(binding: RbfBinding, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    displacement = _displacement(binding.control_rest, binding.control_index, control_positions)
    return _write(binding.rest_vertices + binding.vertex_weights @ displacement, out)


@dataclass(frozen=True, eq=False)
class FpWeightedBinding:
    """Kshirsagar-style weighted displacement: vertex ``pair_vertex`` gets ``pair_coefficient`` × ΔFP."""

    rest_vertices: np.ndarray
    control_rest: np.ndarray
    pair_vertex: np.ndarray
    pair_point: np.ndarray
    pair_coefficient: np.ndarray

    def evaluate(self, control_positions: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        return evaluate_fp_weighted(self, control_positions, out)


def bind_fp_weighted(rest_vertices: np.ndarray, control_rest: np.ndarray, triangles: np.ndarray) -> FpWeightedBinding:
    """Weights of each feature point on the vertices within its extent (see the module docstring)."""
    rest = check_points(rest_vertices, "rest_vertices")
    control = check_points(control_rest, "control_rest")
    tris = check_triangles(triangles, len(control))
    edges = np.unique(np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1), axis=0)
    edges = edges[edges[:, 0] != edges[:, 1]]
    vertices, points, weights = [], [], []
    for fp in np.unique(tris):
        neighbours = np.concatenate([edges[edges[:, 0] == fp, 1], edges[edges[:, 1] == fp, 0]])
        offsets = control[neighbours] - control[fp]
        lengths = np.linalg.norm(offsets, axis=1)
        neighbours, offsets, lengths = neighbours[lengths > 0], offsets[lengths > 0], lengths[lengths > 0]
        if len(neighbours) == 0:
            continue
        relative = rest - control[fp]
        distance = np.linalg.norm(relative, axis=1)
        near = np.flatnonzero(distance < lengths.max())  # the extent never exceeds the farthest neighbour
        cosine = (relative[near] @ (offsets / lengths[:, None]).T) / np.maximum(distance[near], 1e-300)[:, None]
        order = np.argsort(-cosine, axis=1)[:, :2]
        if len(neighbours) == 1:
            order = np.zeros((len(near), 2), dtype=np.intp)
        rows = np.arange(len(near))[:, None]
        sine = np.sqrt(np.clip(1.0 - np.clip(cosine[rows, order], -1.0, 1.0) ** 2, 0.0, None))
        sine_sum = sine.sum(axis=1)
        flank = lengths[order]
        extent = np.where(
            sine_sum > 0.0,
            (flank[:, 0] * sine[:, 1] + flank[:, 1] * sine[:, 0]) / np.where(sine_sum > 0.0, sine_sum, 1.0),
            flank[:, 0],
        )
        inside = distance[near] < extent
        weight = np.sin(0.5 * np.pi * (1.0 - distance[near][inside] / extent[inside]))  # eq. 4
        vertices.append(near[inside])
        points.append(np.full(inside.sum(), fp))
        weights.append(weight)
    vertex = np.concatenate(vertices) if vertices else np.zeros(0, np.intp)
    weight = np.concatenate(weights) if weights else np.zeros(0)
    total = np.bincount(vertex, weight, minlength=len(rest))
    return FpWeightedBinding(
        rest_vertices=rest,
        control_rest=control,
        pair_vertex=vertex,
        pair_point=np.concatenate(points) if points else np.zeros(0, np.intp),
        pair_coefficient=weight**2 / total[vertex],
    )


def evaluate_fp_weighted(
    binding: FpWeightedBinding, control_positions: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    displacement = _displacement(binding.control_rest, np.arange(len(binding.control_rest)), control_positions)
    moved = displacement[binding.pair_point] * binding.pair_coefficient[:, None]
    n = len(binding.rest_vertices)
    result = binding.rest_vertices + np.stack(
        [np.bincount(binding.pair_vertex, moved[:, axis], minlength=n) for axis in range(3)], axis=1
    )
    return _write(result, out)


def _control_index(control: np.ndarray, triangles: np.ndarray | None) -> np.ndarray:
    if triangles is None:
        return np.arange(len(control))
    return np.unique(check_triangles(triangles, len(control)))


def _displacement(control_rest: np.ndarray, index: np.ndarray, control_positions: np.ndarray) -> np.ndarray:
    control = check_points(control_positions, "control_positions")
    if control.shape != control_rest.shape:
        raise DeformError(f"control_positions has shape {control.shape}, the binding expects {control_rest.shape}")
    return control[index] - control_rest[index]


def _write(result: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    if out is None:
        return result
    if out.shape != result.shape:
        raise DeformError(f"out must have shape {result.shape}, got {out.shape}")
    out[...] = result
    return out
