"""From bone transforms relative to rest (`pose`) to the channels of an armature's pose bones; bpy-free.

`pose` gives each bone's D_b = T_b T̂_b⁻¹ of eq. 1 in armature (= face mesh) space. A pose bone of an
armature whose bones inherit their parent's rotation and scale (Blender's default, and what the builder
makes) ends up at

    P_b = P_parent · M_parent⁻¹ · M_b · B_b        (P_root = M_root · B_root)

with M_b the bone's rest matrix in armature space (`Bone.matrix_local`) and B_b its own channels
(`PoseBone.matrix_basis` = translation · rotation · scale). Skinning applies P_b M_b⁻¹ to the vertices, so
asking P_b M_b⁻¹ = D_b for every bone gives, from the root down,

    B_b = M_b⁻¹ · D_parent⁻¹ · D_b · M_b

(for the root D_parent = I). The transforms are rigid, so each B_b is a location and a unit quaternion.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def rigid_inverse(m: np.ndarray) -> np.ndarray:
    """(..., 4, 4) inverses of rigid transforms (rotation and translation): [Rᵀ, −Rᵀ t]."""
    m = np.asarray(m, dtype=np.float64)
    out = np.zeros_like(m)
    rt = np.swapaxes(m[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rt, m[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def bone_basis(rest: np.ndarray, parents: Sequence[int], transforms: np.ndarray) -> np.ndarray:
    """(B, 4, 4) each bone's own channels B_b from its rest matrix M_b (B, 4, 4), its parent's row (-1 for
    a root, parents before children) and its transform relative to rest D_b (B, 4, 4), all in armature space
    and rigid (inverted as such: a handful of 4x4 solves per frame cost more than the whole product)."""
    rest = np.asarray(rest, dtype=np.float64)
    transforms = np.asarray(transforms, dtype=np.float64)
    parents = np.asarray(parents, dtype=np.intp)
    relative = transforms.copy()
    children = parents >= 0
    relative[children] = rigid_inverse(transforms[parents[children]]) @ transforms[children]  # D_p⁻¹ D_b
    return rigid_inverse(rest) @ relative @ rest


def quaternions(rotations: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """(B, 4) unit quaternions (w, x, y, z) of (B, 3, 3) rotation matrices; with `previous` (B, 4), each
    takes the sign nearer its previous one, so keys in a row interpolate the short way round."""
    r = np.asarray(rotations, dtype=np.float64)
    # the largest of 4w², 4x², 4y², 4z² is computed directly and the others from it (Shepperd's method)
    diagonal = np.stack(
        [
            1.0 + r[:, 0, 0] + r[:, 1, 1] + r[:, 2, 2],
            1.0 + r[:, 0, 0] - r[:, 1, 1] - r[:, 2, 2],
            1.0 - r[:, 0, 0] + r[:, 1, 1] - r[:, 2, 2],
            1.0 - r[:, 0, 0] - r[:, 1, 1] + r[:, 2, 2],
        ],
        axis=1,
    )
    pick = np.argmax(diagonal, axis=1)
    s = 2.0 * np.sqrt(np.maximum(diagonal[np.arange(len(r)), pick], 1e-300))
    wx, wy, wz = r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]
    xy, xz, yz = r[:, 0, 1] + r[:, 1, 0], r[:, 0, 2] + r[:, 2, 0], r[:, 1, 2] + r[:, 2, 1]
    candidates = np.stack(
        [
            np.stack([s / 4, wx / s, wy / s, wz / s], axis=1),
            np.stack([wx / s, s / 4, xy / s, xz / s], axis=1),
            np.stack([wy / s, xy / s, s / 4, yz / s], axis=1),
            np.stack([wz / s, xz / s, yz / s, s / 4], axis=1),
        ],
        axis=1,
    )
    q = candidates[np.arange(len(r)), pick]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    if previous is not None:
        q[np.einsum("bi,bi->b", q, previous) < 0.0] *= -1.0
    else:
        q[q[:, 0] < 0.0] *= -1.0
    return q
