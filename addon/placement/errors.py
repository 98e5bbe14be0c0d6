"""What automatic placement tells the user: the mesh is not a head it can read, or scipy is missing."""

from ..errors import Mpeg4Error


class PlacementError(Mpeg4Error):
    """The mesh cannot get feature points automatically; the message says what was not found."""
