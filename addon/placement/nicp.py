"""Optimal-step non-rigid ICP (Amberg, Romdhani and Vetter, CVPR 2007), on scipy's sparse solver.

Each template vertex v_i gets its own affine transform X_i (4 x 3). For a stiffness alpha the cost

    E(X) = || W (D X - U) ||^2 + alpha^2 || (M (x) G) X ||^2                 (eq. 11-12)

is quadratic: D is the sparse (n x 4n) matrix of the vertices [v_i^T 1], U the closest surface points of
the current deformed template, W their reliability weights, M the template's edge-vertex incidence and
G = diag(1, 1, 1, gamma). For each alpha of a decreasing schedule, the closest points and X are
re-found until X settles (section 3.2); E's normal equations are solved by sparse LU (`_factorised`).

Read here for "until X settles": the stiffnesses whose correspondences pair local heights (`features`) take
INNER_STEPS steps each (their correspondences are samples of the skin, which reach a fixed point or swap between
two within a few steps: they bring the template near, they do not put it on the skin); the last, on the closest
points, runs until a step moves the vertices by less than SETTLED of the template's size (root mean square),
at most MOST_STEPS. On smooth skin that last stiffness converges slowly (the template relaxes along the skin,
0.4 mm rms in its first step, 0.03 mm in its tenth on a development head); stopped after two steps it left the
template 1.00 mm rms short of a plain 5.4 mm move of the surface, now 0.64 (a test), and the placed points with it.

Read here: the template is first put in a unit frame (centred, its size 1), so gamma = 1 weighs a
vertex's translation like its linear part; correspondences get weight 0 where the normals disagree by
more than 60 degrees, the distance is over a tenth of the head, or the template vertex is on its
border (the neck cut), as the paper drops them (section 3.3).
"""

from __future__ import annotations

import numpy as np

from ..geometry.normals import vertex_normals
from .scipy_modules import coo_matrix, csr_matrix, diags, kron, splu
from .surface import Surface

STIFFNESS = (10.0, 5.0, 2.0, 1.0, 0.5)
INNER_STEPS = 2
SETTLED = 1e-4  # of the template's size (0.01-0.02 mm): the last stiffness ends when a step moves less (rms)
MOST_STEPS = 30  # at most this many steps at the last stiffness (the development heads settle in 14-19)
GAMMA = 1.0
NORMAL_AGREEMENT = 0.5  # cos 60 deg
FAR = 0.1  # of the template's size


def _sorted_pairs(triangles: np.ndarray) -> np.ndarray:
    """(3T, 2) the triangles' edges, each as (smaller vertex, larger vertex), in int64."""
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    return np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)


def _unique_pairs(pairs: np.ndarray, return_counts: bool = False):
    """`np.unique(pairs, axis=0)` (the rows sorted, each once) for pairs of non-negative integers, by one
    integer key per row (first * n + second, which sorts as the rows do): a row-wise unique sorts a view of
    the rows as records, several times slower."""
    n = int(pairs.max()) + 1 if len(pairs) else 1
    keys = np.unique(pairs[:, 0] * n + pairs[:, 1], return_counts=return_counts)
    if return_counts:
        keys, counts = keys
    rows = np.stack([keys // n, keys % n], axis=1)
    return (rows, counts) if return_counts else rows


def edges_of(triangles: np.ndarray) -> np.ndarray:
    """(E, 2) unique undirected edges of the triangles, (smaller, larger) vertex, in sorted order."""
    return _unique_pairs(_sorted_pairs(triangles))


def border_edges(triangles: np.ndarray) -> np.ndarray:
    """(B, 2) the open border's edges (each used by one triangle only), (smaller, larger) vertex, in sorted order."""
    unique, counts = _unique_pairs(_sorted_pairs(triangles), return_counts=True)
    return unique[counts == 1]


def border_vertices(triangles: np.ndarray, n_vertices: int) -> np.ndarray:
    """(n,) True for vertices on an open border (an edge used by one triangle only)."""
    border = np.zeros(n_vertices, dtype=bool)
    border[border_edges(triangles).ravel()] = True
    return border


def register(
    vertices: np.ndarray,
    triangles: np.ndarray,
    surface: Surface,
    stiffness=STIFFNESS,
    features=None,
):
    """Generator: yields the fraction done; returns the template `vertices` (n, 3) deformed onto `surface`
    (both in the same frame) and the per-vertex affine transforms (n, 4, 3) that do it, in that frame.

    With `features` ((n,) local heights of the template vertices, a `FeatureMatcher` of the surface), the
    correspondences of all but the last stiffness are found by position and local height; the last uses
    the closest surface points."""
    n = len(vertices)
    centre = vertices.mean(axis=0)
    size = float(np.linalg.norm(vertices - centre, axis=1).max()) or 1.0
    local = (vertices - centre) / size
    homogeneous = np.hstack([local, np.ones((n, 1))])
    rows = np.repeat(np.arange(n), 4)
    d_matrix = csr_matrix((homogeneous.ravel(), (rows, np.arange(4 * n))), shape=(n, 4 * n))
    edges = edges_of(triangles)
    m = len(edges)
    incidence = coo_matrix(
        (np.r_[-np.ones(m), np.ones(m)], (np.r_[np.arange(m), np.arange(m)], np.r_[edges[:, 0], edges[:, 1]])),
        shape=(m, n),
    )
    smoothness = kron(incidence, diags([1.0, 1.0, 1.0, GAMMA])).tocsr()
    smooth_normal = (smoothness.T @ smoothness).tocsc()
    border = border_vertices(triangles, n)
    transforms = np.tile(np.vstack([np.eye(3), np.zeros((1, 3))]), (n, 1))  # (4n, 3): identity
    deformed = local.copy()
    for level, alpha in enumerate(stiffness):
        last = level == len(stiffness) - 1
        kept = None  # the weights the factorisation `solve` was made with, at this stiffness
        for inner in range(MOST_STEPS if last else INNER_STEPS):
            world = deformed * size + centre
            if features is not None and level < len(stiffness) - 1:
                target, target_normals = features[1].match(world, features[0])
            else:
                target, target_normals = surface.closest(world)
            target = (target - centre) / size
            normals = vertex_normals(deformed, triangles)
            agree = (normals * target_normals).sum(1)
            distance = np.linalg.norm(target - deformed, axis=1)
            weights = ((agree > NORMAL_AGREEMENT) & (distance < FAR) & ~border).astype(np.float64)
            wd = diags(weights) @ d_matrix
            if kept is None or not np.array_equal(weights, kept):  # the same weights and stiffness: the same matrix
                solve = _factorised((alpha * alpha * smooth_normal + (wd.T @ wd)).tocsc())
                kept = weights
            rhs = wd.T @ (weights[:, None] * target)
            transforms = solve(np.asarray(rhs))  # the three columns x, y, z at once
            moved = d_matrix @ transforms
            motion = float(np.sqrt(((moved - deformed) ** 2).sum(axis=1).mean()))
            deformed = moved
            yield (level + (inner + 1) / (MOST_STEPS if last else INNER_STEPS)) / len(stiffness)
            if last and motion < SETTLED:
                break
    affine = transforms.reshape(n, 4, 3)
    return deformed * size + centre, _to_frame(affine, centre, size)


def _factorised(matrix):
    """The solve of the normal equations' `matrix` by sparse LU in SuperLU's symmetric mode: the matrix is
    symmetric positive definite (a weighted sum of squares), so its diagonal serves as pivots (no pivoting,
    as Cholesky) and a minimum-degree ordering of its symmetric pattern keeps the factors small (0.54M non-zeros
    against 0.75M by the default column ordering on the 1,295-vertex template, and the solves faster with them;
    the registered vertices agree with the default's to 1e-14 of a metre)."""
    return splu(matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}).solve


def _to_frame(affine: np.ndarray, centre: np.ndarray, size: float) -> np.ndarray:
    """Per-vertex affines of the unit frame rewritten for points in the caller's frame:
    x -> ((x - c) / s) A + t, times s, plus c  =  x A + (t s + c - c A)."""
    linear = affine[:, :3, :]
    translation = affine[:, 3, :] * size + centre - centre @ linear
    return np.concatenate([linear, translation[:, None, :]], axis=1)
