"""Deformers driven by the MPEG-4 feature-point control mesh; bpy-free, numpy in and out.

`planar_bones` holds the paper's deformer (and its SoFFD mode), `regions` the per-triangle region
geometry it is built on, `baselines` the RBF and feature-point weighted methods it is compared with.

`METHODS` maps a method name to ``bind(rest_vertices, control_rest, triangles, **params)``, which returns
an object with ``evaluate(control_positions, out=None) -> (N, 3)``, so benchmarks can loop by name.
"""

from .baselines import bind_fp_weighted, bind_rbf
from .planar_bones import DeformError, bind_planar_bones, bind_soffd

METHODS = {
    "planar_bones": bind_planar_bones,
    "soffd": bind_soffd,
    "rbf": bind_rbf,
    "fp_weighted": bind_fp_weighted,
}

__all__ = ["METHODS", "DeformError"]
