"""Where the head is: its orientation (up, forward), scale and position, found by fitting the template.

A head is fitted by a similarity transform (rotation, one scale, translation) from the template's frame
to the mesh's: `world = scale * rotation @ template + translation`. No axis is trusted: every
axis-aligned frame (6 up directions x 8 forward directions 45 degrees apart: Y-up imports, meshes facing
+Y or sideways) starts a short trimmed ICP (Besl and McKay 1992, with Umeyama's 1991 closed-form
similarity); the best few are refined and the best of those, by distance and normal agreement, wins.
The start scale and position come from the head's width profile seen from above, which a neck and
shoulders below the head do not change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scipy_modules import cKDTree

# The template's own frame: rows left, up, forward in its coordinates (the sample: Z up, facing -Y).
TEMPLATE_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
KEEP = 0.8  # fraction of correspondences kept (the rest: the mesh's other parts, the template's neck)
COARSE_STEPS, FINE_STEPS, REFINED = 10, 30, 3
COARSE_POINTS = 300  # samples of each side in the coarse fits of all frames
SLABS = 20  # height slabs across one head height for the width profile


@dataclass(frozen=True)
class Similarity:
    rotation: np.ndarray  # (3, 3) template -> world
    scale: float
    translation: np.ndarray  # (3,)

    def apply(self, points: np.ndarray) -> np.ndarray:
        return self.scale * points @ self.rotation.T + self.translation

    def inverse_apply(self, points: np.ndarray) -> np.ndarray:
        return (points - self.translation) @ self.rotation / self.scale


def umeyama(source: np.ndarray, target: np.ndarray, weights: np.ndarray | None = None) -> Similarity:
    """The similarity taking `source` nearest to `target` in least squares (Umeyama 1991, eq. 40-42)."""
    w = np.ones(len(source)) if weights is None else weights
    w = w / w.sum()
    mu_s, mu_t = w @ source, w @ target
    s, t = source - mu_s, target - mu_t
    covariance = (t * w[:, None]).T @ s
    u, d, vt = np.linalg.svd(covariance)
    sign = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2] = -1.0
    rotation = u @ np.diag(sign) @ vt
    variance = w @ (s * s).sum(1)
    scale = float((d * sign).sum() / variance) if variance > 0 else 1.0
    return Similarity(rotation, scale, mu_t - scale * rotation @ mu_s)


def candidate_frames() -> list[np.ndarray]:
    """Rotations (template -> world) putting the template's up on each world axis, facing 8 ways around it."""
    frames = []
    for up in np.vstack([np.eye(3), -np.eye(3)]):
        side = np.eye(3)[np.argmin(np.abs(up))]
        side = side - up * (side @ up)
        side /= np.linalg.norm(side)
        other = np.cross(up, side)
        for angle in np.arange(8) * np.pi / 4:
            left = np.cos(angle) * side + np.sin(angle) * other
            forward = np.cross(left, up)
            world_axes = np.stack([left, up, forward])  # rows: the face's left, up, forward in the world
            frames.append(world_axes.T @ TEMPLATE_AXES)
    return frames


@dataclass(frozen=True)
class _TemplateProfile:
    """What the width-profile starts read off the template, the same for every candidate frame."""

    height: float  # its extent along its up
    width: float  # its widest slab (`_widest`)
    centre: np.ndarray  # (3,) the point of it put on the head's top: its top, mid-way left-right and front-back

    @classmethod
    def of(cls, template: np.ndarray) -> _TemplateProfile:
        t_face = template @ TEMPLATE_AXES.T
        height = t_face[:, 1].max() - t_face[:, 1].min()
        width = _widest(t_face[:, 0], t_face[:, 1], height)
        centre = np.array([np.median(t_face[:, 0]), t_face[:, 1].max(), np.median(t_face[:, 2])]) @ TEMPLATE_AXES
        return cls(height, width, centre)


def _width_profile_start(points: np.ndarray, rotation: np.ndarray, profile: _TemplateProfile) -> Similarity:
    """Scale and position from the head's widest slab near the top, seen along the candidate's up."""
    left, up, forward = (rotation @ TEMPLATE_AXES[i] for i in range(3))
    t_height, t_width = profile.height, profile.width
    h = points @ up
    top = h.max()
    extent = np.ptp(points @ left), np.ptp(points @ forward)
    width = _widest(points @ left, h, max(max(extent) * t_height / max(t_width, 1e-12), 1e-12))
    scale = width / t_width if t_width > 0 else 1.0
    head = points[h > top - scale * t_height]
    centre = np.median(head, axis=0)
    centre = centre - up * (centre @ up) + up * top
    return Similarity(rotation, scale, centre - scale * rotation @ profile.centre)


def _widest(across: np.ndarray, height: np.ndarray, head_height: float) -> float:
    """The head's width: the widest slab from the top down to where the profile narrows to a neck."""
    top = height.max()
    step = head_height / SLABS
    order = np.argsort(height, kind="stable")
    rising, across = height[order], across[order]  # a slab is then one run of them
    widest = 0.0
    for k in range(2 * SLABS):
        # the slab top - (k + 1) step < height <= top - k step
        first = np.searchsorted(rising, top - (k + 1) * step, side="right")
        end = np.searchsorted(rising, top - k * step, side="right")
        if end - first < 3:
            continue
        slab = across[first:end]
        width = float(linear_quantile(slab, 0.98) - linear_quantile(slab, 0.02))
        if widest and width < 0.7 * widest and k > SLABS // 3:
            break
        widest = max(widest, width)
    return widest


def linear_quantile(values: np.ndarray, share: float) -> float:
    """`np.quantile(values, share)` (non-empty `values`, `share` in [0, 1]) to the last bit: its two order
    statistics found by one partition and interpolated as numpy's default ('linear') method does, without numpy's
    general path, which costs several times more on the few hundred values of a coarse ICP step or a slab."""
    position = (len(values) - 1) * share
    below = int(np.floor(position))
    above = min(below + 1, len(values) - 1)
    low, high = np.partition(values, [below, above])[[below, above]]
    gamma = position - below
    span = high - low
    return high - span * (1.0 - gamma) if gamma >= 0.5 else low + span * gamma


def trimmed(values: np.ndarray, share: float) -> np.ndarray:
    """`values <= np.quantile(values, share)`: the share of the values kept by a trimmed fit."""
    return values <= linear_quantile(values, share)


def icp(
    template: np.ndarray,
    template_normals: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    tree: cKDTree,
    start: Similarity,
    steps: int,
) -> tuple[Similarity, float]:
    """Trimmed similarity ICP between the template samples and the mesh samples, both ways (template to
    mesh, and the mesh within the template's box to the template: one way alone lets the scale shrink);
    returns (fit, score: lower is better)."""
    fit = start
    score = np.inf
    template_tree = cKDTree(template)
    lo, hi = template.min(axis=0), template.max(axis=0)
    for _step in range(steps):
        moved = fit.apply(template)
        distance, index = tree.query(moved)
        agree = ((template_normals @ fit.rotation.T) * normals[index]).sum(1)
        cost = distance / fit.scale + 0.01 * (1.0 - agree)  # template metres; a flipped normal costs 2 cm
        keep = trimmed(cost, KEEP)
        local = fit.inverse_apply(points)
        near = np.flatnonzero(np.all((local >= lo) & (local <= hi), axis=1))
        back_distance, back_index = template_tree.query(local[near])
        back_agree = (template_normals[back_index] * (normals[near] @ fit.rotation)).sum(1)
        back_cost = back_distance + 0.01 * (1.0 - back_agree)
        back_keep = trimmed(back_cost, KEEP) if len(back_cost) else back_cost > 0
        score = float(cost[keep].mean() + (back_cost[back_keep].mean() if back_keep.any() else cost.max()))
        fit = umeyama(
            np.vstack([template[keep], template[back_index[back_keep]]]),
            np.vstack([points[index[keep]], points[near[back_keep]]]),
        )
    return fit, score


def align(
    template: np.ndarray,
    template_normals: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
):
    """Generator: yields the fraction done, returns (the similarity placing the template's samples best on
    the mesh's samples, its score)."""
    coarse_step = max(1, len(points) // COARSE_POINTS)
    coarse_points, coarse_normals = points[::coarse_step], normals[::coarse_step]
    coarse_tree = cKDTree(coarse_points)
    t_step = max(1, len(template) // COARSE_POINTS)
    coarse_template, coarse_template_normals = template[::t_step], template_normals[::t_step]
    tried = []
    frames = candidate_frames()
    profile = _TemplateProfile.of(template)
    for i, rotation in enumerate(frames):
        start = _width_profile_start(coarse_points, rotation, profile)
        tried.append(
            icp(
                coarse_template,
                coarse_template_normals,
                coarse_points,
                coarse_normals,
                coarse_tree,
                start,
                COARSE_STEPS,
            )
        )
        yield (i + 1) / (len(frames) + REFINED)
    tried.sort(key=lambda fit_score: fit_score[1])
    tree = cKDTree(points)
    refined = []
    starts = [fit for fit, _score in tried[:REFINED]]
    starts += [_turned_about_up(fit, template.mean(axis=0)) for fit in starts]
    for fit in starts:
        refined.append(icp(template, template_normals, points, normals, tree, fit, FINE_STEPS))
        yield (len(frames) + len(refined)) / (len(frames) + len(starts))
    return min(refined, key=lambda fit_score: fit_score[1])


def _turned_about_up(fit: Similarity, centre: np.ndarray) -> Similarity:
    """`fit` turned half round about the template's up axis through its `centre` (template coordinates):
    the same head facing the other way. Seen from above, a head's back and front have much the same
    outline, so a coarse fit can face backwards (a face whose eye sockets are open holes, with its mouth's
    cavity drawing the fit); refining the turned fit as well lets the better facing win."""
    up = TEMPLATE_AXES[1]
    half_turn = 2.0 * np.outer(up, up) - np.eye(3)  # rotation by 180 degrees about `up`
    rotation = fit.rotation @ half_turn
    return Similarity(rotation, fit.scale, fit.apply(centre) - fit.scale * rotation @ centre)
