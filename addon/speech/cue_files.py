"""Timed label files -> viseme segments: our own JSON/TSV format and Rhubarb Lip Sync's mouth cues.

Our format (times in seconds, labels as in `segments`: viseme names, viseme numbers or English espeak-ng
phonemes):

    TSV  one `start end label` per line, separated by tabs or spaces; blank lines and lines starting with
         '#' are skipped.                                   e.g.  0.00  0.12  _
                                                                  0.12  0.20  p
    JSON {"segments": [{"start": 0.0, "end": 0.12, "label": "_"}, {"start": 0.12, "end": 0.2, "label": "p"}]}
         ("about" may hold a description).

Rhubarb Lip Sync (its README, "Output formats"):

    TSV  `time<TAB>shape` per line; each cue lasts until the next line's time, and the last line only marks
         the end of the recording (its shape, always X or A, is checked but not played).
    JSON {"metadata": {...}, "mouthCues": [{"start": 0.0, "end": 0.05, "value": "X"}, ...]}

Shapes map to visemes through `data/rhubarb.json` (A -> PP, B -> SS, C -> E, D -> AA, E -> OH, F -> OU,
G -> FF, H -> NN, X -> NONE). Every reader checks the whole file (syntax, times, labels) before it returns;
a problem raises SpeechError naming the file, the line or entry, the label and the time.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from ..mpeg4.faps import Viseme
from . import SpeechError
from .segments import Segment, TimedLabel, check_timing, describe, segments_from_labels
from .tables import READ, PhonemeTable, load_rhubarb

MAX_CUES = 100_000  # lines or entries of one cue file: an hour of speech has about 50,000 phonemes
_NUMBER = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?", re.ASCII)


def _lines(path) -> list[tuple[int, list[str]]]:
    """(line number, fields) of each line that is neither blank nor a '#' comment."""
    source = str(path)
    text = READ.read_text(path, "cue file")
    out = []
    for n, line in enumerate(text.replace("\r\n", "\n").replace("\r", "\n").split("\n"), 1):
        fields = line.split()
        if fields and not fields[0].startswith("#"):
            if len(out) == MAX_CUES:
                raise SpeechError(f"{source} line {n}: more than {MAX_CUES} timed lines; split the file")
            out.append((n, fields))
    if not out:
        raise SpeechError(f"{source}: no timed lines in the file")
    return out


def _time(token: str, where: str) -> float:
    if not _NUMBER.fullmatch(token):
        raise SpeechError(f"{where}: time {token[:30]!r} is not a number of seconds")
    value = float(token)
    if not math.isfinite(value):
        raise SpeechError(f"{where}: time {token[:30]!r} is not a finite number of seconds")
    return value


# --- our format ----------------------------------------------------------------------------------------


def read_timed_labels(path) -> list[TimedLabel]:
    """The timed labels of one of our files: JSON if the name ends in .json, else TSV."""
    source = str(path)
    if str(path).lower().endswith(".json"):
        doc = READ.read_json(path, "timed label file")
        if not isinstance(doc, dict) or "segments" not in doc or not doc.keys() <= {"segments", "about"}:
            raise SpeechError(f'{source}: expected {{"segments": [{{"start", "end", "label"}}, ...]}}')
        return _json_items(doc["segments"], source, "segment", "label")
    labels = []
    for n, fields in _lines(path):
        where = f"{source} line {n}"
        if len(fields) != 3:
            raise SpeechError(f"{where}: expected 'start end label', found {len(fields)} field(s)")
        labels.append(TimedLabel(_time(fields[0], where), _time(fields[1], where), fields[2], where))
    return labels


def _json_items(items, source: str, what: str, label_key: str) -> list[TimedLabel]:
    if not isinstance(items, list) or not items:
        raise SpeechError(f"{source}: expected a non-empty list of {what}s")
    if len(items) > MAX_CUES:
        raise SpeechError(f"{source}: {len(items)} {what}s, more than {MAX_CUES}; split the file")
    out = []
    for k, item in enumerate(items, 1):
        where = f"{source} {what} {k}"
        if not isinstance(item, dict) or item.keys() != {"start", "end", label_key}:
            raise SpeechError(f'{where}: expected {{"start": seconds, "end": seconds, "{label_key}": text}}')
        if not isinstance(item[label_key], str) or not item[label_key].strip():
            raise SpeechError(f"{where}: {label_key} {item[label_key]!r} is not a text")
        start = READ.number(item["start"], f"{where}: start")
        end = READ.number(item["end"], f"{where}: end")
        out.append(TimedLabel(start, end, item[label_key].strip(), where))
    return out


def read_segments(path, phonemes: PhonemeTable | None = None) -> list[Segment]:
    """One of our timed label files -> viseme segments."""
    return segments_from_labels(read_timed_labels(path), phonemes, source=str(path))


def format_timed_labels(labels) -> str:
    """Our TSV format for (start, end, label) items, times in shortest round-trip form."""
    lines = ["# start\tend\tlabel (seconds; mpeg4_face timed labels)"]
    for item in labels:
        if any(c.isspace() for c in item.label) or not item.label:
            raise SpeechError(f"{describe(item)}: a label must be a name without blanks")
        lines.append(f"{float(item.start)!r}\t{float(item.end)!r}\t{item.label}")
    return "\n".join(lines) + "\n"


def write_timed_labels(path, labels) -> None:
    """Write (start, end, label) items (TimedLabel, Segment or espeak Phoneme) in our TSV format."""
    labels = list(labels)
    check_timing(labels)
    text = format_timed_labels(labels)
    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise SpeechError(f"{path}: cannot write the file: {exc.strerror or exc}") from None


# --- Rhubarb Lip Sync ----------------------------------------------------------------------------------


def read_rhubarb(path, shapes: dict[str, Viseme] | None = None) -> list[Segment]:
    """A Rhubarb Lip Sync cue file (JSON if the name ends in .json, else TSV) -> viseme segments."""
    source = str(path)
    shapes = shapes or load_rhubarb()
    if source.lower().endswith(".json"):
        doc = READ.read_json(path, "Rhubarb cue file")
        if not isinstance(doc, dict) or "mouthCues" not in doc or not doc.keys() <= {"mouthCues", "metadata"}:
            raise SpeechError(f'{source}: expected a Rhubarb JSON file {{"metadata": ..., "mouthCues": [...]}}')
        cues = _json_items(doc["mouthCues"], source, "mouth cue", "value")
    else:
        lines = _lines(path)
        marks = []
        for n, fields in lines:
            where = f"{source} line {n}"
            if len(fields) != 2:
                raise SpeechError(f"{where}: expected 'time<TAB>shape', found {len(fields)} field(s)")
            marks.append(TimedLabel(_time(fields[0], where), 0.0, fields[1], where))
        if len(marks) < 2:
            raise SpeechError(f"{source}: a Rhubarb TSV file needs at least two lines (the last marks the end)")
        for before, after in zip(marks, marks[1:], strict=False):
            if after.start < before.start:
                raise SpeechError(f"{describe(after)}: times are not sorted: it comes before {describe(before)}")
        _shape_visemes(marks[-1:], shapes)
        cues = [mark._replace(end=after.start) for mark, after in zip(marks, marks[1:], strict=False)]
    check_timing(cues)
    visemes = _shape_visemes(cues, shapes)
    return [Segment(c.start, c.end, v, c.label, c.where) for c, v in zip(cues, visemes, strict=True)]


def _shape_visemes(cues, shapes: dict[str, Viseme]) -> list[Viseme]:
    out = []
    for cue in cues:
        if cue.label not in shapes:
            raise SpeechError(f"{describe(cue)}: unknown Rhubarb mouth shape (known: {' '.join(shapes)})")
        out.append(shapes[cue.label])
    return out


def read_cue_file(path, phonemes: PhonemeTable | None = None) -> list[Segment]:
    """Any supported file -> viseme segments: Rhubarb JSON (has "mouthCues") or TSV (2 fields a line), or
    our JSON (has "segments") or TSV (3 fields a line)."""
    source = str(path)
    if source.lower().endswith(".json"):
        doc = READ.read_json(path, "cue file")
        if isinstance(doc, dict) and "mouthCues" in doc:
            return read_rhubarb(path)
        return read_segments(path, phonemes)
    n, fields = _lines(path)[0]
    if len(fields) == 2:
        return read_rhubarb(path)
    if len(fields) == 3:
        return read_segments(path, phonemes)
    raise SpeechError(
        f"{source} line {n}: neither a Rhubarb cue ('time shape') nor a timed label ('start end label') line"
    )
