"""Timed viseme segments, the input of co-articulation, and how timed labels (phonemes, visemes) become them.

A label is, in this order: a viseme name of the standard's table as `Viseme` spells it (NONE, PP, FF, TH, DD,
KK, CH, SS, NN, RR, AA, E, IH, OH, OU), a viseme number 0..14, a phoneme of the phoneme table (English
espeak-ng names by default, stress marks allowed, '_...' = pause), or a CMU phone in lower case as
PocketSphinx gives them for a recording (`tables.cmu_phones`; where a name is both, the two mean the same
sound). The only name both a viseme and a phoneme could mean is `E`, and both readings give viseme 11.

Timing rules, checked for the whole list before anything is built: times are finite seconds >= 0, a segment
does not end before it starts (zero length is allowed: espeak-ng reports 0 ms pauses), starts are sorted, and
a segment does not start before the previous one ends (gaps are allowed; the dominance functions span them).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

from ..mpeg4.faps import Viseme
from . import SpeechError
from .tables import PhonemeTable, cmu_phones, load_phonemes

# Slack for "starts before the previous one ends": cue files write the same decimal for both, but a time
# computed as a sum may differ from it in the last bits.
TIME_TOLERANCE = 1e-9


class TimedLabel(NamedTuple):
    start: float  # seconds
    end: float
    label: str
    where: str = ""  # for messages, e.g. "talk.tsv line 4"


@dataclass(frozen=True)
class Segment:
    start: float  # seconds
    end: float
    viseme: Viseme
    label: str = ""  # the phoneme, viseme or cue it came from
    where: str = ""

    @property
    def centre(self) -> float:
        return 0.5 * (self.start + self.end)


def describe(item) -> str:
    """'talk.tsv line 4: 'p' at 0.120 s' - how messages name a timed item."""
    where = getattr(item, "where", "")
    prefix = f"{where}: " if where else ""
    return f"{prefix}{item.label!r} at {item.start:.3f} s"


def check_timing(items: Sequence) -> None:
    """Raise SpeechError naming the first item with a bad time (see the module docstring for the rules)."""
    previous = None
    for item in items:
        start, end = item.start, item.end
        for name, value in (("start", start), ("end", end)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise SpeechError(f"{describe(item)}: the {name} time {value!r} is not a finite number of seconds")
        if start < 0:
            raise SpeechError(f"{describe(item)}: negative start time {start:g} s")
        if end < start:
            raise SpeechError(f"{describe(item)}: it ends at {end:.3f} s, before it starts")
        if previous is not None:
            if start < previous.start:
                raise SpeechError(f"{describe(item)}: times are not sorted: it starts before {describe(previous)}")
            if start < previous.end - TIME_TOLERANCE:
                raise SpeechError(
                    f"{describe(item)}: it overlaps {describe(previous)}, which ends at {previous.end:.3f} s"
                )
        previous = item


def check_segments(segments: Sequence[Segment]) -> None:
    """Check a segment list for co-articulation: the timing rules, and a viseme per segment."""
    for segment in segments:
        if not isinstance(segment, Segment) or not isinstance(segment.viseme, Viseme):
            raise SpeechError(f"expected Segment items with a Viseme, found {segment!r}")
    check_timing(segments)


def resolve_label(label: str, phonemes: PhonemeTable) -> tuple[Viseme, ...] | None:
    """The visemes a label stands for (empty: no shape of its own), or None if it is unknown."""
    if label in Viseme.__members__:
        return (Viseme[label],)
    if label.isascii() and label.isdigit() and int(label) < len(Viseme):
        return (Viseme(int(label)),)
    visemes = phonemes.lookup(label)
    return cmu_phones().lookup(label) if visemes is None else visemes


def segments_from_labels(
    labels: Iterable[TimedLabel], phonemes: PhonemeTable | None = None, *, source: str = "the timed labels"
) -> list[Segment]:
    """Timed labels -> viseme segments. A diphthong's parts share its time equally; a label without a shape
    of its own (h) is left out, so its neighbours cover its time. Everything is checked first."""
    labels = list(labels)
    if not labels:
        raise SpeechError(f"{source}: no timed labels")
    check_timing(labels)
    phonemes = phonemes or load_phonemes()
    resolved = []
    for item in labels:
        visemes = resolve_label(item.label, phonemes) if isinstance(item.label, str) else None
        if visemes is None:
            raise SpeechError(
                f"{describe(item)}: unknown phoneme or viseme (use a viseme name "
                f"{'/'.join(Viseme.__members__)}, a viseme number 0-14, an English espeak-ng phoneme "
                "such as p, @, aI, or a lower-case CMU phone such as dh, aa, ay)"
            )
        resolved.append(visemes)
    segments = []
    for item, visemes in zip(labels, resolved, strict=True):
        step = (item.end - item.start) / max(len(visemes), 1)
        for part, viseme in enumerate(visemes):
            end = item.end if part == len(visemes) - 1 else item.start + (part + 1) * step
            segments.append(Segment(item.start + part * step, end, viseme, item.label, item.where))
    return segments
