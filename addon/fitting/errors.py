"""What a user can get wrong when fitting the generic face to a person: every error names the FP or item."""

from ..errors import Mpeg4Error


class FittingError(Mpeg4Error):
    """Feature points, UVs, a mesh or a binding that fitting cannot use."""


class FeaturePointError(FittingError):
    """Unknown, non-finite or badly shaped FPs, or too few (or too flat) to triangulate."""


class CoincidentFeaturePointsError(FeaturePointError):
    """Two FPs at one place where the method needs them apart, or coincident FPs asked to move apart."""


class FoldError(FittingError):
    """FPs whose triangles flip orientation between the generic face and the target (the map would fold)."""


class TextureCoordinateError(FittingError):
    """Texture coordinates outside the image, repeated, or folding the texture."""


class CalibrationError(FittingError):
    """A calibration mesh that cannot be used (no FPs, bad triangles, not covering the generic face)."""


class BindingError(FittingError):
    """Saved Sibson coordinates (a DFFD binding) that are not what this add-on writes."""


class ScipyMissingError(FittingError):
    """scipy (Qhull), which fitting needs and Blender does not ship, is not installed."""
