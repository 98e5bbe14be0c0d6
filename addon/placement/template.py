"""The template placement registers to a user's head: the sample head's skin and its 84 FPs.

`template.npz` is written by `scripts/sample/build_placement_template.py` from the shipped sample head: its
vertices (metres, the head's own frame: Z up, facing -Y, left on +X, origin at 7.1) and triangles, the 84
FP positions, for each FP that is a skin vertex that vertex (-1 for the pupils, teeth, tongue and 7.1), and
the skin decimated to about 1,300 vertices, which the registration solves on (`coarse_*`), the principal
shapes of MakeHuman's head and face targets on it (`shape_basis`, the prior `shape.fit_shape` fits), and the
84 FPs' motion under those shapes (`fp_basis`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..geometry.normals import vertex_normals

TEMPLATE_FILE = Path(__file__).with_name("template.npz")


@dataclass(frozen=True)
class Template:
    vertices: np.ndarray  # (n, 3)
    triangles: np.ndarray  # (t, 3)
    normals: np.ndarray  # (n, 3)
    fp_positions: np.ndarray  # (84, 3)
    fp_vertices: np.ndarray  # (84,) vertex index or -1
    coarse_vertices: np.ndarray  # (m, 3)
    coarse_triangles: np.ndarray
    coarse_normals: np.ndarray
    shape_basis: np.ndarray  # (k, m, 3) principal shapes of the decimated skin (`shape`), one deviation each
    fp_basis: np.ndarray  # (k, 84, 3) the FPs' motion under the same shapes (the tongue's moves with the skin's)


@functools.cache
def load_template() -> Template:
    with np.load(TEMPLATE_FILE) as data:
        vertices = data["vertices"].astype(np.float64)
        triangles = data["triangles"].astype(np.int64)
        coarse_vertices = data["coarse_vertices"].astype(np.float64)
        coarse_triangles = data["coarse_triangles"].astype(np.int64)
        return Template(
            vertices=vertices,
            triangles=triangles,
            normals=vertex_normals(vertices, triangles),
            fp_positions=data["fp_positions"].astype(np.float64),
            fp_vertices=data["fp_vertices"].astype(np.int64),
            coarse_vertices=coarse_vertices,
            coarse_triangles=coarse_triangles,
            coarse_normals=vertex_normals(coarse_vertices, coarse_triangles),
            shape_basis=data["shape_basis"].astype(np.float64),
            fp_basis=data["fp_basis"].astype(np.float64),
        )
