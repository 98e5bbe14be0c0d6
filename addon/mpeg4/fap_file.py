"""Reading and writing ASCII MPEG-4 `.fap` streams (no bpy; numpy only).

Layout (research notes §7.1): a header line `version name fps frames`, then per frame a mask line
(one 0/1 flag per FAP, in FAP order) and a value line (the frame number, then one value per masked-in
FAP; FAP 1 takes 4 values: viseme select1, select2, blend, def; FAP 2 takes 6: expression select1,
intensity1, select2, intensity2, init_face, def).

Reading policy, chosen to read every producer we know of (XFace, Crystal.TTVS, Greta, VREng; §7.2):

- Line oriented, as all producers write it: blank lines and lines starting with `#` are skipped anywhere;
  LF, CRLF and CR line endings; spaces and tabs separate tokens; trailing blanks are ignored.
- Header: the first token is the version (2.0, 2.1 or 2.2), the last two are fps (positive, finite) and
  the frame count; everything between is the name, so it may contain spaces (Greta).
- The header's frame count is informational: the frames actually present are read, whether fewer or
  more, and nothing is ever sized from the count.
- Masks have 68 or 69 entries (Greta writes a 69th slot, for a FAP that does not exist). The first mask
  fixes the length for the file. A 69th flag is dropped; if it is 1, its value is read and dropped.
- Presence comes from the mask only: an explicit 0 value is present, a masked-out FAP is absent.
- FAP 1 and FAP 2 are read in the reference form (4 and 6 values) or in Greta's one-integer form, which
  then fills select1 only. The form is chosen per frame by the value count; the possible counts of one
  mask are all distinct, so this is never ambiguous.
- Values are decimal numbers (integers or floats, optional exponent); NaN, infinities and overflowing
  numbers are rejected. Frame numbers are non-negative integers and must strictly increase (gaps and
  a start at 1 are fine): two frames at the same time would have no defined order.
- Anything else (wrong flag count, a flag that is not 0/1, a non-numeric value, a value count that does
  not fit the mask, a mask line without its value line, an unknown version, an empty file, NUL bytes or
  bytes that are not UTF-8, an unreadable file) raises `FapFileError` naming the file and the line.

Speed: the work per line is a few string operations and one regular-expression match; the numbers of all
value lines are converted at once by `_parse_decimals` on the raw bytes, so no Python object is made
per value.

Writing uses the reference layout: the stream's version (2.1 for new streams), the name with blanks
replaced by `_`, 68-entry masks, 4/6 values for FAP 1/2, integral values without a decimal point and
other values in their shortest round-trip form, LF endings; the file is replaced atomically.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .faps import N_FAPS

__all__ = ["N_FAPS", "FapFileError", "FapStream", "format_fap", "parse_fap", "read_fap", "write_fap"]

KNOWN_VERSIONS = ("2.0", "2.1", "2.2")
VISEME_FIELDS = 4
EXPRESSION_FIELDS = 6


class FapFileError(ValueError):
    """A `.fap` file (or a stream to be written) that cannot be read or written."""


@dataclass(frozen=True, eq=False)
class FapStream:
    """A FAP stream: per frame the mask of transmitted FAPs and their values.

    Column k of `mask` and `values` is FAP k+1. `values` holds the low-level FAPs 3..68 in FAPU (AU for
    angles); its columns 0 and 1 and all masked-out entries are 0. FAP 1 and FAP 2 live in `viseme`
    (select1, select2, blend, def) and `expression` (select1, intensity1, select2, intensity2,
    init_face, def), valid where mask[:, 0] and mask[:, 1] are set, and 0 elsewhere.
    """

    version: str
    name: str
    fps: float
    frame_numbers: np.ndarray  # (F,) int64; time = frame_number / fps
    mask: np.ndarray  # (F, 68) bool
    values: np.ndarray  # (F, 68) float64
    viseme: np.ndarray  # (F, 4) float64
    expression: np.ndarray  # (F, 6) float64

    @property
    def n_frames(self) -> int:
        return len(self.frame_numbers)

    @property
    def times(self) -> np.ndarray:
        """Seconds of each frame (frame_number / fps)."""
        return self.frame_numbers / self.fps


# --- reading -------------------------------------------------------------------------------------------

# Possessive quantifiers: a line that fails to match fails in linear time.
_NUMBER = r"[-+]?+(?:[0-9]++(?:\.[0-9]*+)?+|\.[0-9]++)(?:[eE][-+]?+[0-9]++)?+"
_NUMBER_RE = re.compile(_NUMBER, re.ASCII)
_FRAME_RE = re.compile(r"[0-9]++", re.ASCII)
_MASK_RE = re.compile(r"[01](?:[ \t]++[01])*+", re.ASCII)
_TOKEN_RE = re.compile(r"[^ \t]+")
_HEADER_RE = re.compile(r"([^ \t]+)[ \t]+([^ \t].*?)[ \t]+([^ \t]+)[ \t]+([^ \t]+)")
_BLANKS = str.maketrans("", "", " \t")
_MASK_LENGTHS = (N_FAPS, N_FAPS + 1)

# Layout of the "expanded" row that value lines are scattered into: the frame number, the viseme
# fields, the expression fields, FAPs 3..68 and the dropped 69th slot.
_X_VISEME = 1
_X_EXPRESSION = _X_VISEME + VISEME_FIELDS
_X_LOW = _X_EXPRESSION + EXPRESSION_FIELDS
_X_DROPPED = _X_LOW + N_FAPS - 2
_X_WIDTH = _X_DROPPED + 1

_POW10 = np.array([float(10**k) for k in range(23)])  # exact: 10**22 is the largest exact power
_EXACT_DIGITS = 15  # a mantissa of up to 15 digits is < 2**53, so summing its digits is exact
_FRAME_LIMIT = 2**53  # frame numbers beyond this are not exact in float64


def _value_line_re(n_values: int) -> re.Pattern:
    return re.compile(rf"[0-9]++(?:[ \t]++{_NUMBER}){{{n_values}}}", re.ASCII)


_VALUE_LINE_RES: dict[int, re.Pattern] = {}


def _error(source: str, line: int, what: str) -> FapFileError:
    return FapFileError(f"{source}: line {line}: {what}")


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _decode(data: bytes, source: str) -> str:
    nul = data.find(b"\0")
    if nul >= 0:
        raise _error(source, _line_of(data, nul), "binary data (NUL byte), not a text .fap file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _error(source, _line_of(data, exc.start), "bytes that are not UTF-8 text") from None
    return text.removeprefix("\ufeff")


def read_fap(path_or_text, *, source_name: str | None = None) -> FapStream:
    """Read a `.fap` stream from a path (str or os.PathLike) or from the file's content.

    bytes are content; a str is content if it holds a line break, else a path.
    """
    if isinstance(path_or_text, bytes | bytearray | memoryview):
        return parse_fap(bytes(path_or_text), source_name or "<bytes>")
    if isinstance(path_or_text, str) and ("\n" in path_or_text or "\r" in path_or_text):
        return parse_fap(path_or_text, source_name or "<string>")
    if not isinstance(path_or_text, str | os.PathLike):
        raise FapFileError(f"cannot read a .fap stream from a {type(path_or_text).__name__}")
    source = source_name or os.fspath(path_or_text)
    try:
        data = Path(path_or_text).read_bytes()
    except (OSError, ValueError) as exc:  # ValueError: a path with a NUL character
        raise FapFileError(f"{source}: cannot read the file: {exc}") from None
    return parse_fap(data, source)


def parse_fap(text: str | bytes, source_name: str = "<string>") -> FapStream:
    """Parse the content of a `.fap` file (see the module docstring for what is accepted)."""
    source = source_name
    if isinstance(text, bytes | bytearray | memoryview):
        text = _decode(bytes(text), source)
    elif not isinstance(text, str):
        raise FapFileError(f"{source}: expected the text of a .fap file, got a {type(text).__name__}")
    elif "\0" in text:
        raise _error(source, text.count("\n", 0, text.index("\0")) + 1, "binary data (NUL character)")
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    content = [(n, s) for n, line in enumerate(lines, 1) if (s := line.strip(" \t")) and s[0] != "#"]
    if not content:
        raise _error(source, len(lines), "empty file: no header line")
    version, name, fps = _parse_header(content[0], source)
    mask_lines, value_lines = content[1::2], content[2::2]
    if len(mask_lines) > len(value_lines):
        raise _error(source, mask_lines[-1][0], "truncated frame: mask line without a value line")
    return _parse_frames(version, name, fps, mask_lines, value_lines, source)


def _parse_header(header: tuple[int, str], source: str) -> tuple[str, str, float]:
    line, text = header
    match = _HEADER_RE.fullmatch(text)
    if not match:
        raise _error(source, line, f"header must be 'version name fps frames', found {text[:80]!r}")
    version, name, fps_token, count_token = match.groups()
    if version not in KNOWN_VERSIONS:
        raise _error(source, line, f"unknown version {version!r} (known: {', '.join(KNOWN_VERSIONS)})")
    fps = float(fps_token) if _NUMBER_RE.fullmatch(fps_token) else math.nan
    if not (math.isfinite(fps) and fps > 0):
        raise _error(source, line, f"fps must be a positive finite number, found {fps_token!r}")
    if not _FRAME_RE.fullmatch(count_token):
        raise _error(source, line, f"frame count must be a non-negative integer, found {count_token!r}")
    return version, name, fps


def _parse_mask(text: str, line: int, source: str) -> np.ndarray:
    if _MASK_RE.fullmatch(text):
        flags = text.translate(_BLANKS)
        if len(flags) in _MASK_LENGTHS:
            return np.frombuffer(flags.encode("ascii"), np.uint8) == ord("1")
    tokens = _TOKEN_RE.findall(text)
    if len(tokens) not in _MASK_LENGTHS:
        raise _error(source, line, f"mask line must have {N_FAPS} or {N_FAPS + 1} flags, found {len(tokens)}")
    bad = next(i for i, token in enumerate(tokens) if token not in ("0", "1"))
    raise _error(source, line, f"mask flag {bad + 1} is {tokens[bad][:20]!r}, expected 0 or 1")


def _forms(mask: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """The value counts a frame with this mask may have and where each value goes in the expanded row.

    Reference form first; with FAP 1 and/or FAP 2 present, Greta's one-value forms follow.
    """
    low = _X_LOW + np.flatnonzero(mask[2:N_FAPS])
    dropped = [_X_DROPPED] if len(mask) > N_FAPS and mask[N_FAPS] else []
    viseme_forms = [range(_X_VISEME, _X_EXPRESSION), [_X_VISEME]] if mask[0] else [[]]
    expression_forms = [range(_X_EXPRESSION, _X_LOW), [_X_EXPRESSION]] if mask[1] else [[]]
    forms = []
    for viseme in viseme_forms:
        for expression in expression_forms:
            columns = np.concatenate([[0], viseme, expression, low, dropped]).astype(np.intp)
            forms.append((len(columns) - 1, columns))
    return forms


def _value_line_error(text: str, line: int, mask_line: int, counts: list[int], source: str) -> FapFileError:
    tokens = _TOKEN_RE.findall(text)
    if not _FRAME_RE.fullmatch(tokens[0]):
        return _error(source, line, f"frame number {tokens[0][:20]!r} is not a non-negative integer")
    for i, token in enumerate(tokens[1:], 1):
        if not _NUMBER_RE.fullmatch(token):
            try:
                what = "not a finite number" if not math.isfinite(float(token)) else "not a number"
            except ValueError:
                what = "not a number"
            return _error(source, line, f"value {i} ({token[:20]!r}) is {what}")
    expected = " or ".join(str(n) for n in counts)
    return _error(
        source, line, f"the mask on line {mask_line} needs {expected} values after the frame number, "
        f"found {len(tokens) - 1}"
    )


def _parse_frames(version, name, fps, mask_lines, value_lines, source) -> FapStream:
    n_frames = len(value_lines)
    mask_ids: dict[str, int] = {}
    unique_masks: list[np.ndarray] = []
    form_ids: list[list[tuple[re.Pattern, int]]] = []  # per unique mask: (value-line regex, form id)
    form_columns: list[np.ndarray] = []
    mask_length = None
    frame_mask = np.empty(n_frames, np.intp)
    frame_form = np.empty(n_frames, np.intp)
    for i, ((mask_line, mask_text), (line, text)) in enumerate(zip(mask_lines, value_lines, strict=True)):
        mask_id = mask_ids.get(mask_text)
        if mask_id is None:
            mask = _parse_mask(mask_text, mask_line, source)
            if mask_length is None:
                mask_length = (len(mask), mask_line)
            elif len(mask) != mask_length[0]:
                raise _error(
                    source, mask_line, f"mask has {len(mask)} flags but the first mask (line "
                    f"{mask_length[1]}) has {mask_length[0]}"
                )
            mask_id = mask_ids[mask_text] = len(unique_masks)
            unique_masks.append(mask)
            candidates = []
            for count, columns in _forms(mask):
                if count not in _VALUE_LINE_RES:
                    _VALUE_LINE_RES[count] = _value_line_re(count)
                candidates.append((_VALUE_LINE_RES[count], len(form_columns)))
                form_columns.append(columns)
            form_ids.append(candidates)
        frame_mask[i] = mask_id
        for regex, form in form_ids[mask_id]:
            if regex.fullmatch(text):
                frame_form[i] = form
                break
        else:
            counts = [len(form_columns[form]) - 1 for _, form in form_ids[mask_id]]
            raise _value_line_error(text, line, mask_line, counts, source)

    form_lengths = np.array([len(c) for c in form_columns], np.intp)
    form_table = np.zeros((len(form_columns), max(form_lengths, default=1)), np.intp)
    for form, columns in enumerate(form_columns):
        form_table[form, : len(columns)] = columns
    counts = form_lengths[frame_form]
    starts = np.cumsum(counts) - counts
    flat = _parse_decimals("\n".join(text for _, text in value_lines))
    bad = np.flatnonzero(~np.isfinite(flat))
    if bad.size:
        frame = np.searchsorted(starts, bad[0], side="right") - 1
        raise _error(source, value_lines[frame][0], f"value {bad[0] - starts[frame]} is not a finite number")

    frame_of_token = np.repeat(np.arange(n_frames), counts)
    slot = np.arange(len(flat)) - np.repeat(starts, counts)
    expanded = np.zeros((n_frames, _X_WIDTH))
    expanded[frame_of_token, form_table[frame_form[frame_of_token], slot]] = flat

    frame_numbers = expanded[:, 0]
    too_large = np.flatnonzero(frame_numbers >= _FRAME_LIMIT)
    if too_large.size:
        raise _error(source, value_lines[too_large[0]][0], "frame number is too large")
    frame_numbers = frame_numbers.astype(np.int64)
    not_increasing = np.flatnonzero(np.diff(frame_numbers) <= 0)
    if not_increasing.size:
        i = not_increasing[0] + 1
        raise _error(
            source, value_lines[i][0], f"frame number {frame_numbers[i]} does not follow frame "
            f"{frame_numbers[i - 1]} (line {value_lines[i - 1][0]}): frame numbers must increase"
        )

    masks = np.zeros((n_frames, N_FAPS), bool)
    if n_frames:
        masks[:] = np.array(unique_masks)[frame_mask, :N_FAPS]
    values = np.zeros((n_frames, N_FAPS))
    values[:, 2:] = expanded[:, _X_LOW:_X_DROPPED]
    return FapStream(
        version=version,
        name=name,
        fps=fps,
        frame_numbers=frame_numbers,
        mask=masks,
        values=values,
        viseme=expanded[:, _X_VISEME:_X_EXPRESSION].copy(),
        expression=expanded[:, _X_EXPRESSION:_X_LOW].copy(),
    )


def _parse_decimals(text: str) -> np.ndarray:
    """Convert the blank-separated decimal numbers of `text` to float64, exactly as `float()` would.

    The tokens must already match `_NUMBER`. Each token is m * 10**scale with an integer mantissa m;
    when m has at most 15 digits and |scale| <= 22, m and 10**|scale| are exact doubles and one
    multiplication or division rounds correctly. The few other tokens go through `float()`.
    """
    b = np.frombuffer(text.encode("ascii"), np.uint8)
    in_token = (b != ord(" ")) & (b != ord("\t")) & (b != ord("\n"))
    is_start = in_token.copy()
    is_start[1:] &= ~in_token[:-1]
    is_end = in_token.copy()
    is_end[:-1] &= ~in_token[1:]
    starts = np.flatnonzero(is_start)
    ends = np.flatnonzero(is_end) + 1
    n_tokens = len(starts)
    token_of = np.cumsum(is_start, dtype=np.int32) - 1

    dots = np.flatnonzero(b == ord("."))
    dot_at = np.full(n_tokens, -1)
    dot_at[token_of[dots]] = dots
    exps = np.flatnonzero((b | 0x20) == ord("e"))
    mantissa_end = ends.copy()
    mantissa_end[token_of[exps]] = exps
    exponent_negative = np.zeros(n_tokens, bool)
    exponent_negative[token_of[exps]] = b[exps + 1] == ord("-")
    fraction_digits = np.where(dot_at >= 0, mantissa_end - dot_at - 1, 0)

    digits = np.flatnonzero((b - np.uint8(ord("0"))) < 10)
    digit_token = token_of[digits]
    digit_value = (b[digits] - ord("0")).astype(np.float64)
    in_mantissa = digits < mantissa_end[digit_token]
    # place = how many mantissa (or exponent) digits follow this one in its token
    place = np.where(
        in_mantissa,
        mantissa_end[digit_token] - digits - 1 - (dot_at[digit_token] > digits),
        ends[digit_token] - digits - 1,
    )
    inexact = np.zeros(n_tokens, bool)
    inexact[digit_token[(digit_value > 0) & (place >= np.where(in_mantissa, _EXACT_DIGITS, 3))]] = True
    weight = digit_value * _POW10[np.minimum(place, len(_POW10) - 1)]
    mantissa = np.bincount(digit_token[in_mantissa], weight[in_mantissa], minlength=n_tokens)
    exponent = np.bincount(digit_token[~in_mantissa], weight[~in_mantissa], minlength=n_tokens)
    scale = np.where(exponent_negative, -exponent, exponent) - fraction_digits
    inexact |= np.abs(scale) >= len(_POW10)
    power = _POW10[np.minimum(np.abs(scale), len(_POW10) - 1).astype(np.intp)]
    result = np.where(scale >= 0, mantissa * power, mantissa / power)
    result[b[starts] == ord("-")] *= -1
    for i in np.flatnonzero(inexact):
        result[i] = float(text[starts[i] : ends[i]])
    return result


# --- writing -------------------------------------------------------------------------------------------


def _format_number(x: float) -> str:
    return str(int(x)) if x.is_integer() and abs(x) < _FRAME_LIMIT else repr(x)


def _format_numbers(values: np.ndarray) -> list[str]:
    integral = (values == np.rint(values)) & (np.abs(values) < _FRAME_LIMIT)
    tokens = np.empty(len(values), object)
    tokens[integral] = list(map(str, values[integral].astype(np.int64).tolist()))
    tokens[~integral] = list(map(repr, values[~integral].tolist()))
    return tokens.tolist()


def _check_stream(stream: FapStream, target: str) -> None:
    def fail(what: str) -> FapFileError:
        return FapFileError(f"{target}: cannot write the FAP stream: {what}")

    n = len(np.asarray(stream.frame_numbers))
    shapes = {
        "frame_numbers": (n,),
        "mask": (n, N_FAPS),
        "values": (n, N_FAPS),
        "viseme": (n, VISEME_FIELDS),
        "expression": (n, EXPRESSION_FIELDS),
    }
    for field, shape in shapes.items():
        if np.shape(getattr(stream, field)) != shape:
            raise fail(f"{field} has shape {np.shape(getattr(stream, field))}, expected {shape}")
    if stream.version not in KNOWN_VERSIONS:
        raise fail(f"unknown version {stream.version!r}")
    if not (math.isfinite(stream.fps) and stream.fps > 0):
        raise fail(f"fps must be a positive finite number, found {stream.fps!r}")
    frames = np.asarray(stream.frame_numbers)
    if n and (frames[0] < 0 or np.any(np.diff(frames) <= 0) or np.any(frames != np.rint(frames))):
        raise fail("frame numbers must be non-negative integers that increase")
    mask = np.asarray(stream.mask, bool)
    for field, present in (("values", mask), ("viseme", mask[:, :1]), ("expression", mask[:, 1:2])):
        bad = np.argwhere(present & ~np.isfinite(np.asarray(getattr(stream, field), np.float64)))
        if bad.size:
            raise fail(f"{field} of frame {frames[bad[0][0]]} is not finite")


def _format(stream: FapStream, target: str) -> str:
    _check_stream(stream, target)
    mask = np.asarray(stream.mask, bool)
    n_frames = len(mask)
    expanded = np.zeros((n_frames, _X_DROPPED))
    present = np.zeros((n_frames, _X_DROPPED), bool)
    expanded[:, _X_VISEME:_X_EXPRESSION] = stream.viseme
    expanded[:, _X_EXPRESSION:_X_LOW] = stream.expression
    expanded[:, _X_LOW:] = np.asarray(stream.values, np.float64)[:, 2:]
    present[:, _X_VISEME:_X_EXPRESSION] = mask[:, :1]
    present[:, _X_EXPRESSION:_X_LOW] = mask[:, 1:2]
    present[:, _X_LOW:] = mask[:, 2:]
    tokens = _format_numbers(expanded[present])
    ends = np.cumsum(present.sum(axis=1)).tolist()
    mask_texts: dict[bytes, str] = {}
    name = "_".join(stream.name.split()) or "unnamed"
    out = [f"{stream.version} {name} {_format_number(float(stream.fps))} {n_frames}\n"]
    start = 0
    flags = mask.astype(np.uint8) + ord("0")
    for frame, row, end in zip(np.asarray(stream.frame_numbers).tolist(), flags, ends, strict=True):
        key = row.tobytes()
        mask_text = mask_texts.get(key)
        if mask_text is None:
            mask_text = mask_texts[key] = " ".join(key.decode("ascii"))
        out.append(f"{mask_text}\n{' '.join([str(int(frame)), *tokens[start:end]])}\n")
        start = end
    return "".join(out)


def format_fap(stream: FapStream) -> str:
    """The text of `stream` as a `.fap` file in the reference layout."""
    return _format(stream, "<string>")


def write_fap(stream: FapStream, path) -> None:
    """Write `stream` to `path` atomically: a complete new file or, on failure, the old one untouched."""
    target = os.fspath(path)
    data = _format(stream, target).encode("utf-8", errors="replace")
    directory = os.path.dirname(os.path.abspath(target))
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{os.path.basename(target)}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as file:
            file.write(data)
            file.flush()
            os.fsync(file.fileno())
        os.replace(tmp, target)
        tmp = None
    except OSError as exc:
        raise FapFileError(f"{target}: cannot write the file: {exc}") from None
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
