"""scipy.spatial (Qhull's Delaunay, the k-d tree), imported when a fit first needs it.

Blender ships numpy but not scipy; the extension brings scipy as a wheel (blender_manifest.toml) on the
platforms that have one at the pinned version. Importing it lazily keeps the rest of the add-on (set-up,
playback, speech) working where it is missing, and a fit then refuses with `ScipyMissingError` instead of
the add-on failing to load.
"""

from __future__ import annotations

from types import ModuleType

from .errors import ScipyMissingError


def spatial() -> ModuleType:
    """The scipy.spatial module, or `ScipyMissingError`."""
    try:
        import scipy.spatial
    except ImportError as error:
        raise ScipyMissingError(
            f"fitting needs scipy (Qhull), which Blender does not ship and which is not installed ({error}); "
            "install the MPEG-4 Face extension from its zip, which brings scipy's wheel for Windows x64, macOS and "
            "Linux x64, or install scipy into Blender's Python"
        ) from None
    return scipy.spatial
