"""Which loose parts of a face mesh are rigid parts (`loose_parts.find_parts`), no scene."""

import numpy as np

from addon.deform.loose_parts import find_parts
from addon.mpeg4.feature_points import fp_index

AXES = np.eye(3)  # x to the face's left, y up, z forward


def _sheet(centre, size: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat count x count grid of vertices in the x-y plane about `centre`, and its edges."""
    u = np.linspace(-size / 2, size / 2, count)
    x, y = np.meshgrid(u, u, indexing="ij")
    points = np.stack([x.ravel(), y.ravel(), np.zeros(count * count)], axis=1) + centre
    index = np.arange(count * count).reshape(count, count)
    edges = np.concatenate([np.stack([index[:-1].ravel(), index[1:].ravel()], 1)])
    edges = np.concatenate([edges, np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1)])
    return points, edges


def _head(face_fps: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A body part of 900 vertices below, a face part of 400 about the mouth (at the origin), a small part inside
    the mouth behind the lips; the FPs of the mouth, and the chin, cheeks and nose tip on the face part when
    `face_fps`. Returns rest, edges, neutral FP rows and the first vertex of the face part."""
    body, body_edges = _sheet((0.0, -0.3, 0.0), 0.4, 30)
    face, face_edges = _sheet((0.0, 0.0, 0.0), 0.12, 20)
    teeth, teeth_edges = _sheet((0.0, 0.004, -0.01), 0.03, 5)
    rest = np.concatenate([body, face, teeth])
    edges = np.concatenate([body_edges, face_edges + len(body), teeth_edges + len(body) + len(face)])
    neutral = np.full((84, 3), np.nan)
    for fp_id, point in {"2.2": (0, 0.002, 0), "2.3": (0, -0.002, 0), "2.4": (0.025, 0, 0), "2.5": (-0.025, 0, 0),
                         "9.10": (0, 0.001, -0.01), "9.11": (0, -0.001, -0.01)}.items():  # fmt: skip
        neutral[fp_index(fp_id)] = point
    if face_fps:
        for fp_id, point in {"2.1": (0, -0.05, 0), "5.1": (0.04, 0.03, 0), "5.2": (-0.04, 0.03, 0),
                             "9.15": (0, 0.05, 0)}.items():  # fmt: skip
            neutral[fp_index(fp_id)] = point
    return rest, edges, neutral, len(body)


def test_a_face_sewn_to_its_head_as_a_loose_part_stays_skin():
    """The face part lies about the mouth, where teeth are looked for: without its skin FPs it is taken for teeth
    (as the Rocketbox male's face was, so it never moved); with the chin, cheeks and nose tip on it, it stays skin,
    and the part behind the lips is still the upper teeth."""
    rest, edges, neutral, face_start = _head(face_fps=False)
    face = np.arange(face_start, face_start + 400)
    found = find_parts(rest, edges, neutral, AXES)
    assert np.isin(face, np.concatenate(list(found.values()))).all()
    rest, edges, neutral, face_start = _head(face_fps=True)
    found = find_parts(rest, edges, neutral, AXES)
    assert set(found) == {"upper_teeth"}
    assert np.array_equal(found["upper_teeth"], np.arange(face_start + 400, face_start + 425))
