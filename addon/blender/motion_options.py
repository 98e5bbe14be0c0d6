"""Operator options shared by everything that keys FAP motion onto a face (stream import, speech, cues)."""

from bpy.props import FloatProperty


class GainAndClamp:
    """Mix-in: the Gain and Clamp options (annotations are registered with each operator that uses it)."""

    gain: FloatProperty(
        name="Gain",
        default=1.0,
        min=0.0,
        soft_max=2.0,
        description="Scale the whole motion (1: as given); each FAP group's own gain and plausible "
        "range are the face's settings, applied after this",
    )
    clamp: FloatProperty(
        name="Clamp",
        default=0.0,
        min=0.0,
        soft_max=2000.0,
        description="Limit each FAP value to this many FAP units after the gain (0: no limit)",
    )
