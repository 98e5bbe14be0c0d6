"""The scipy pieces placement uses, imported in one place: Blender ships numpy but not scipy, and the
extension's scipy wheel may be missing on a platform, so a missing scipy is a report, not a traceback."""

from .errors import PlacementError

try:
    from scipy.sparse import coo_matrix, csr_matrix, diags, kron
    from scipy.sparse.csgraph import dijkstra
    from scipy.sparse.linalg import splu
    from scipy.spatial import cKDTree
except ImportError as error:  # pragma: no cover - depends on the platform's wheels
    raise PlacementError(
        f"automatic placement needs scipy, which is not installed ({error}); install the MPEG-4 Face extension "
        "from its zip, which brings scipy's wheel for this platform"
    ) from error

__all__ = ["cKDTree", "coo_matrix", "csr_matrix", "diags", "dijkstra", "kron", "splu"]
