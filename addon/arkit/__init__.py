"""The ARKit bridge: ARKit's 52 face blendshape weights per frame <-> MPEG-4 FAP values (no bpy).

The data path, one function per arrow:

    capture file (Live Link Face CSV, Audio2Face JSON, plain CSV/JSON) --captures.read_capture--> Capture
        (52 weights per frame, head and eye turns) --mapping.capture_to_stream--> FapStream --> the playback path
    FAP values --mapping.faps_to_weights--> 52 weights (bounded least squares) --captures.write_live_link_csv-->

Both directions go through one recipe table (`recipes`, data/recipes.json): ARKit name -> FAP values at
weight 1. The same recipes, evaluated with a face's own engine, make its 52 ARKit shape keys.
"""

from ..errors import Mpeg4Error


class ArkitError(Mpeg4Error):
    """A bad ARKit capture or recipe table; the message names the file, the line (or frame) and what is wrong."""
