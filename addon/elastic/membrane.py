"""Unfold Skin after Elastic Bones' skinning, carried back under the skinning (issue 27).

Linear blend skinning (eq. 1) is not fold-free: where two bones pull a strip of skin apart faster than it is wide,
its triangles turn over (the sculpted open jaw at 1.5 times turned 64 faces over under the chin and on the mouth's
lining floor, half of them folds the sculpt itself makes). The paper does not treat fold-overs. As after Planar
Bones, the add-on runs Unfold Skin's membrane (`deform.unfold.open_folds`, same budget a frame) on the skinned
positions: only the vertices of turned-over triangles and a few rings around them move, and a frame without folds
is left exactly as skinned.

Blender's Armature modifier skins the mesh's own positions, so the membrane's result is carried under it: each
moved vertex v' gets the rest position r' its own blend of the bone matrices takes to v',

    r' = (Σ_i w_i M_i)⁻¹ v'        (eq. 1 solved for v̂, with the vertex's weights and this frame's M_i),

and skinning r' gives v' (to rounding). A vertex whose blend cannot be inverted (|det| below MIN_DETERMINANT:
bones pulling it flat) keeps its rest and its skinned position; on the development units the moved vertices'
determinants are 0.85 to 1.0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..deform import unfold
from ..deform.inputs import DeformError
from .skinning import apply_blended

MIN_DETERMINANT = 1e-3  # a blend that shrinks volume a thousandfold is not inverted (the vertex keeps its skinning)


@dataclass(frozen=True)
class Corrected:
    """One frame's skinning with its folds opened."""

    deformed: np.ndarray  # (N, 3) the skinned positions, folds opened
    vertices: np.ndarray  # (V,) the vertices whose rest positions changed, ascending
    rest: np.ndarray  # (V, 3) their rest positions under the skinning (`pull_back`)
    left: int  # triangles still turned over (the frame's budget ran out)


def pull_back(matrices: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rest positions r with A r + t = target for (V, 3, 4) matrices [A | t] and (V, 3) targets, and a (V,) mask of
    the rows that could be inverted (|det A| ≥ MIN_DETERMINANT); the other rows are returned as NaN."""
    a, t = matrices[:, :, :3], matrices[:, :, 3]
    ok = np.abs(np.linalg.det(a)) >= MIN_DETERMINANT
    out = np.full((len(matrices), 3), np.nan)
    if ok.any():
        out[ok] = np.linalg.solve(a[ok], (targets[ok] - t[ok])[:, :, None])[:, :, 0]
    return out, ok


def skin_unfolded(mesh: unfold.SkinMesh, matrices: np.ndarray, max_steps: int) -> Corrected:
    """Skin `mesh.rest` by (N, 3, 4) per-vertex blends of the bone matrices (`skinning.blended_matrices`, eq. 1),
    open the folds with Unfold Skin's membrane within `max_steps` Jacobi steps, and carry the moved vertices back
    under the skinning."""
    matrices = np.asarray(matrices, dtype=np.float64)
    if matrices.shape != (mesh.n_vertices, 3, 4):
        raise DeformError(f"blended matrices must be ({mesh.n_vertices}, 3, 4), got {matrices.shape}")
    skinned = apply_blended(matrices, mesh.rest)
    positions = skinned.astype(np.float32)  # as the mesh stores them; the compiled kernel's membrane where it runs
    done = unfold.open_folds(mesh, positions, max_steps=max_steps)
    changed = done.moved[np.any(positions[done.moved] != skinned[done.moved].astype(np.float32), axis=1)]
    rest, ok = pull_back(matrices[changed], positions[changed].astype(np.float64))
    deformed = skinned.copy()  # where the blend cannot be inverted the vertex stays where the skinning puts it
    deformed[changed[ok]] = positions[changed[ok]]
    return Corrected(deformed, changed[ok], rest[ok], done.left)
