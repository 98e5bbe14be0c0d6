"""What a user can get wrong with Elastic Bones; every message names the bone, FP, FAP or vertex."""

from ..errors import Mpeg4Error


class ElasticError(Mpeg4Error):
    """Bad input to the Elastic Bones engine."""


class MissingFeaturePointsError(ElasticError):
    """A bone cannot be placed: the face lacks (or has non-finite) feature points it needs."""


class RuleTableError(ElasticError):
    """A FAP -> bone rule, a bone table row or a parameter names an unknown FAP or bone."""


class SkinWeightError(ElasticError):
    """Skin weights of the wrong shape, negative, non-finite or not summing to 1 (eq. 2)."""


class ScipyMissingError(ElasticError):
    """The skin weights need scipy's sparse graphs, and scipy cannot be imported."""
