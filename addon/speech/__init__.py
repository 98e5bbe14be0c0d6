"""Speech: timed phonemes or visemes -> low-level FAP tracks, and FAP 1/2 of imported streams (no bpy).

The data path, one function per arrow:

    text --espeak.synthesize--> phonemes with times + PCM audio (one synthesis, in sync by construction)
         --espeak.speech_segments / segments.segments_from_labels--> viseme segments
         --coarticulation.fap_tracks--> (F, 68) low-level FAP values at the frame rate --> the playback path

A voice recording enters before it (docs/voice.md):

    recording --recording.read_recording--> 16 kHz samples --phone_alignment (+ transcript)--> timed phones
              --phone_alignment.phone_segments--> viseme segments

Timed label files (our JSON/TSV) and Rhubarb Lip Sync cue files enter at the segment arrow (`cue_files`).
`high_level.apply_high_level` plays FAP 1 (viseme) and FAP 2 (expression) of an imported `.fap` stream
through the same tables. The tables live in `data/*.json`, and `tables` loads and checks them.
"""

from ..errors import Mpeg4Error


class SpeechError(Mpeg4Error):
    """Bad speech input (a timed label, a cue file, text, a table) or a missing espeak-ng; the message names the
    item (phoneme, line, time) and what to do."""
