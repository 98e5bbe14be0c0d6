"""Reading and writing ASCII MPEG-4 `.fap` streams (no bpy; numpy only).

Layout (research notes §7.1): a header line `version name fps frames`, then per frame a mask line
(one 0/1 flag per FAP, in FAP order) and a value line (the frame number, then one value per masked-in
FAP; FAP 1 takes 4 values: viseme select1, select2, blend, def; FAP 2 takes 6: expression select1,
intensity1, select2, intensity2, init_face, def).

Reading policy, chosen to read every producer we know of (XFace, Crystal.TTVS, Greta, VREng; §7.2):

- Line oriented, as all producers write it: blank lines and lines starting with `#` are skipped anywhere;
  LF, CRLF and CR line endings; spaces and tabs separate tokens; leading and trailing blanks are ignored.
- Header: the first token is the version (2.0, 2.1 or 2.2), the last two are fps (positive, finite) and
  the frame count; everything between is the name, so it may contain spaces (Greta).
- The header's frame count is informational: the frames actually present are read, whether fewer or
  more, and nothing is ever sized from the count.
- Masks have 68 or 69 flags (Greta writes a 69th slot, for a FAP that does not exist). The first mask
  fixes the length for the file. A 69th flag is dropped; if it is 1, its value is read and dropped.
- Presence comes from the mask only: an explicit 0 value is present, a masked-out FAP is absent.
- FAP 1 and FAP 2 are read in the reference form (4 and 6 values) or in Greta's one-integer form, which
  fills select1 only. The form is chosen per frame by the value count; the counts a mask allows are all
  distinct, so this is never ambiguous.
- Values are decimal numbers (integers or floats, optional exponent); NaN, infinities and overflowing
  numbers are rejected. Frame numbers are non-negative integers up to 2**53 - 1 (beyond it a float64, and
  so a time, no longer holds every integer) and must strictly increase (gaps and a start at 1 are fine):
  two frames at one time would have no defined order.
- A path that is not a regular file (a FIFO, a device, a socket, a folder), a file over 256 MiB and a line
  over 8,192 characters are refused before anything is read or split; no more than the cap is ever
  read, even from a file that grows or misstates its size.
- Anything else (wrong flag count, a flag that is not 0/1, a non-numeric value, a value count that does
  not fit the mask, a mask line without its value line, an unknown version, an empty file, NUL bytes or
  bytes that are not UTF-8, an unreadable file) raises `FapFileError` naming the file and the line, and
  quoting at most 40 characters of what it found.

Speed: per line there are only a few string operations (and a dictionary look-up of the mask); all value
lines are checked and converted together on their bytes by `_scan_numbers`, so no Python object is made
per value. A value line with more tokens than any frame can hold (78) is malformed whatever they are, so
only its frame number is converted: time and memory follow the number of lines, not of tokens.

Writing uses the reference layout: the stream's version (2.1 for new streams), the name with blanks
replaced by `_`, 68-flag masks, 4/6 values for FAP 1/2, integral values without a decimal point and
other values in their shortest round-trip form, LF endings; the file is replaced atomically.
"""

from __future__ import annotations

import math
import os
import re
import secrets
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Mpeg4Error
from ..user_files import read_regular_file
from .faps import N_FAPS

__all__ = ["N_FAPS", "FapFileError", "FapStream", "format_fap", "parse_fap", "read_fap", "write_fap"]

KNOWN_VERSIONS = ("2.0", "2.1", "2.2")
MAX_FILE_BYTES = 256 * 2**20  # 256 MiB: over a million frames of every FAP
MAX_FRAME_NUMBER = 2**53 - 1  # every integer up to here is an exact float64
# The longest line a producer can write: a frame number and 78 values (68 + 4 + 6), each a long float,
# or a header with a long name. A longer line is refused before it is split into tokens.
MAX_LINE_CHARS = 8192
VISEME_FIELDS = 4
EXPRESSION_FIELDS = 6


class FapFileError(Mpeg4Error):
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

_NUMBER_RE = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?", re.ASCII)
_FRAME_RE = re.compile(r"[0-9]+", re.ASCII)
_MASK_RE = re.compile(r"[01](?:[ \t]+[01])*", re.ASCII)
_TOKEN_RE = re.compile(r"[^ \t]+")
_BLANKS = str.maketrans("", "", " \t")
_MASK_LENGTHS = (N_FAPS, N_FAPS + 1)

# (viseme, expression) value counts a frame may use, by (FAP 1 present, FAP 2 present); reference first.
_HIGH_LEVEL_FORMS = {
    (False, False): [(0, 0)],
    (True, False): [(VISEME_FIELDS, 0), (1, 0)],
    (False, True): [(0, EXPRESSION_FIELDS), (0, 1)],
    (True, True): [(VISEME_FIELDS, EXPRESSION_FIELDS), (VISEME_FIELDS, 1), (1, EXPRESSION_FIELDS), (1, 1)],
}
_MAX_HIGH_LEVEL = VISEME_FIELDS + EXPRESSION_FIELDS
# The most tokens a value line can hold: the frame number, FAP 1 and 2 fields, FAPs 3..68 and a 69th.
_MAX_VALUE_TOKENS = 1 + _MAX_HIGH_LEVEL + (N_FAPS + 1 - 2)
# _FORM_BY_COUNT[2 * fap1 + fap2, n] = the form with n high-level values, or (-1, -1)
_FORM_BY_COUNT = np.full((4, _MAX_HIGH_LEVEL + 1, 2), -1, np.intp)
for (_fap1, _fap2), _forms in _HIGH_LEVEL_FORMS.items():
    for _form in _forms:
        _FORM_BY_COUNT[2 * _fap1 + _fap2, sum(_form)] = _form

# Bytes that may appear in value lines: digits, sign, point, exponent and the separators.
_NUMBER_BYTES = np.zeros(256, bool)
_NUMBER_BYTES[np.frombuffer(b"0123456789+-.eE \t\n", np.uint8)] = True
_POW10 = np.array([float(10**k) for k in range(23)])  # exact: 10**22 is the largest exact power of ten
_EXACT_INTEGER = float(2**53)  # integers up to here are exact doubles
_BLOCK_LINES = 8192
_MAX_TOKEN = 24  # longer tokens (no producer writes them) are checked and converted one by one
_QUOTE_CHARS = 40  # the most a message quotes of a token or line


def _error(source: str, line: int, what: str) -> FapFileError:
    return FapFileError(f"{source}: line {line}: {what}")


def _quote(text: str) -> str:
    """`text` quoted for a message, cut to _QUOTE_CHARS characters."""
    if len(text) <= _QUOTE_CHARS:
        return repr(text)
    return f"{text[:_QUOTE_CHARS]!r}... ({len(text)} characters)"


def _count_tokens(text: str) -> int:
    """The number of blank-separated tokens of one line, without an object per token."""
    blank = np.frombuffer(text.encode("utf-8", errors="surrogatepass"), np.uint8)
    blank = (blank == ord(" ")) | (blank == ord("\t"))
    return int(np.count_nonzero(blank[:-1] & ~blank[1:])) + bool(len(blank) and not blank[0])


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _decode(data: bytes, source: str) -> str:
    nul = data.find(b"\0")
    if nul >= 0:
        raise _error(source, _line_of(data, nul), "binary data (NUL byte), not a text .fap file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _error(source, _line_of(data, exc.start), "bytes that are not UTF-8 text") from None


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
    too_large = f"larger than {MAX_FILE_BYTES // 2**20} MiB, which no FAP stream needs"
    return parse_fap(read_regular_file(path_or_text, MAX_FILE_BYTES, FapFileError, source, too_large), source)


def parse_fap(text: str | bytes, source_name: str = "<string>") -> FapStream:
    """Parse the content of a `.fap` file (see the module docstring for what is accepted)."""
    source = source_name
    if isinstance(text, bytes | bytearray | memoryview):
        text = _decode(bytes(text), source)
    elif not isinstance(text, str):
        raise FapFileError(f"{source}: expected the text of a .fap file, got a {type(text).__name__}")
    elif "\0" in text:
        raise _error(source, text.count("\n", 0, text.index("\0")) + 1, "binary data (NUL character)")
    text = text.removeprefix("\ufeff")  # a UTF-8 byte order mark, as some Windows editors write
    lines = [line.strip(" \t") for line in text.replace("\r\n", "\n").replace("\r", "\n").split("\n")]
    if "#" in text or "" in lines[:-1]:
        numbers = [n for n, line in enumerate(lines, 1) if line and line[0] != "#"]
        lines = [lines[n - 1] for n in numbers]
    else:  # the usual file: no comment and no blank line except after the last line break
        if not lines[-1]:
            lines.pop()
        numbers = range(1, len(lines) + 1)
    if not lines:
        raise _error(source, 1, "empty file: no header line")
    if max(map(len, lines)) > MAX_LINE_CHARS:  # before any line is split into tokens
        i = next(i for i, line in enumerate(lines) if len(line) > MAX_LINE_CHARS)
        raise _error(source, numbers[i], f"{len(lines[i])} characters long; a .fap line has at most {MAX_LINE_CHARS}")
    version, name, fps = _parse_header(lines[0], numbers[0], source)
    if len(lines) % 2 == 0:
        raise _error(source, numbers[-1], "truncated frame: mask line without a value line")
    frames = _parse_frames(lines[1::2], numbers[1::2], lines[2::2], numbers[2::2], source)
    return FapStream(version, name, fps, *frames)


def _parse_header(text: str, line: int, source: str) -> tuple[str, str, float]:
    spans = [match.span() for match in _TOKEN_RE.finditer(text)]
    if len(spans) < 4:
        raise _error(source, line, f"header must be 'version name fps frames', found {_quote(text)}")
    version, fps_token, count_token = (text[slice(*spans[i])] for i in (0, -2, -1))
    name = text[spans[0][1] : spans[-2][0]].strip(" \t")
    if version not in KNOWN_VERSIONS:
        raise _error(source, line, f"unknown version {_quote(version)} (known: {', '.join(KNOWN_VERSIONS)})")
    fps = float(fps_token) if _NUMBER_RE.fullmatch(fps_token) else math.nan
    if not (math.isfinite(fps) and fps > 0):
        raise _error(source, line, f"fps must be a positive finite number, found {_quote(fps_token)}")
    if not _FRAME_RE.fullmatch(count_token):
        raise _error(source, line, f"frame count must be a non-negative integer, found {_quote(count_token)}")
    return version, name, fps


def _parse_mask(text: str) -> np.ndarray | str:
    """The flags of a mask line, or what is wrong with it."""
    if _MASK_RE.fullmatch(text):
        flags = text.translate(_BLANKS)
        if len(flags) in _MASK_LENGTHS:
            return np.frombuffer(flags.encode("ascii"), np.uint8) == ord("1")
    tokens = _TOKEN_RE.findall(text)
    if len(tokens) not in _MASK_LENGTHS:
        return f"mask line must have {N_FAPS} or {N_FAPS + 1} flags, found {len(tokens)}"
    bad = next(i for i, token in enumerate(tokens) if token not in ("0", "1"))
    return f"mask flag {bad + 1} is {_quote(tokens[bad])}, expected 0 or 1"


def _parse_masks(texts: list[str], numbers, source: str) -> np.ndarray:
    """The (F, 68 or 69) mask of every frame; each distinct mask line is parsed once."""
    distinct = list(dict.fromkeys(texts))  # in order of first use
    masks = []
    for text in distinct:
        mask = _parse_mask(text)
        if isinstance(mask, np.ndarray) and masks and len(mask) != len(masks[0]):
            mask = f"mask has {len(mask)} flags but the first mask (line {numbers[0]}) has {len(masks[0])}"
        if isinstance(mask, str):
            raise _error(source, numbers[texts.index(text)], mask)
        masks.append(mask)
    index = {text: i for i, text in enumerate(distinct)}
    return np.array(masks, bool)[np.fromiter(map(index.__getitem__, texts), np.intp, len(texts))]


def _value_line_error(text: str, line: int, mask: np.ndarray, mask_line: int, source: str) -> FapFileError:
    tokens = _TOKEN_RE.findall(text)
    if not _FRAME_RE.fullmatch(tokens[0]):
        return _error(source, line, f"frame number {_quote(tokens[0])} is not a non-negative integer")
    digits = tokens[0].lstrip("0")  # int() refuses over 4,300 digits, and leading zeros count
    if len(digits) > len(str(MAX_FRAME_NUMBER)) or int(digits or "0") > MAX_FRAME_NUMBER:
        shown = tokens[0] if len(tokens[0]) <= 20 else f"{tokens[0][:12]}...({len(tokens[0])} digits)"
        return _error(source, line, f"frame number {shown} is too large (at most {MAX_FRAME_NUMBER})")
    for i, token in enumerate(tokens[1:], 1):
        number = float(token) if _NUMBER_RE.fullmatch(token) else None
        if number is None or not math.isfinite(number):
            try:
                what = "not a finite number" if not math.isfinite(float(token)) else "not a number"
            except ValueError:
                what = "not a number"
            return _error(source, line, f"value {i} ({_quote(token)}) is {what}")
    n_low = int(mask[2:].sum())
    counts = [n_low + sum(form) for form in _HIGH_LEVEL_FORMS[bool(mask[0]), bool(mask[1])]]
    return _error(
        source,
        line,
        f"the mask on line {mask_line} needs {' or '.join(map(str, counts))} values after "
        f"the frame number, found {len(tokens) - 1}",
    )


def _parse_frames(mask_texts, mask_numbers, value_texts, value_numbers, source) -> tuple:
    """frame_numbers, mask, values, viseme and expression arrays of the frames' mask and value lines."""
    n_frames = len(value_texts)
    if n_frames == 0:
        return (
            np.zeros(0, np.int64),
            np.zeros((0, N_FAPS), bool),
            np.zeros((0, N_FAPS)),
            np.zeros((0, VISEME_FIELDS)),
            np.zeros((0, EXPRESSION_FIELDS)),
        )
    masks = _parse_masks(mask_texts, mask_numbers, source)
    frame_numbers, numbers, n_numbers, bad_line = _scan_value_lines(value_texts)
    n_low = masks[:, 2:].sum(axis=1)  # includes a 69th flag, whose value is read and dropped
    n_high = n_numbers - n_low
    form = _FORM_BY_COUNT[2 * masks[:, 0] + masks[:, 1], np.clip(n_high, 0, _MAX_HIGH_LEVEL)]
    bad_line |= (form[:, 0] < 0) | (n_high < 0) | (n_high > _MAX_HIGH_LEVEL) | (frame_numbers > MAX_FRAME_NUMBER)
    if bad_line.any():
        i = int(np.argmax(bad_line))
        raise _value_line_error(value_texts[i], value_numbers[i], masks[i], mask_numbers[i], source)

    # After the frame number a line holds n_high viseme/expression values, then the low-level values.
    viseme = np.zeros((n_frames, VISEME_FIELDS))
    expression = np.zeros((n_frames, EXPRESSION_FIELDS))
    dropped = []  # high-level values and those of a 69th flag
    high_frames = np.flatnonzero(n_high)
    if high_frames.size:
        counts = n_high[high_frames]
        frame = np.repeat(high_frames, counts)
        k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        index = np.repeat((np.cumsum(n_numbers) - n_numbers)[high_frames], counts) + k
        n_viseme = form[frame, 0]
        is_viseme = k < n_viseme
        viseme[frame[is_viseme], k[is_viseme]] = numbers[index[is_viseme]]
        expression[frame[~is_viseme], (k - n_viseme)[~is_viseme]] = numbers[index[~is_viseme]]
        dropped.append(index)
    if masks.shape[1] > N_FAPS:
        dropped.append((np.cumsum(n_numbers) - 1)[masks[:, N_FAPS]])
    if dropped:
        numbers = np.delete(numbers, np.concatenate(dropped))
    values = np.zeros((n_frames, N_FAPS))
    values[:, 2:][masks[:, 2:N_FAPS]] = numbers  # row-major: each frame's values in FAP order

    frame_numbers = frame_numbers.astype(np.int64)
    not_increasing = np.flatnonzero(np.diff(frame_numbers) <= 0)
    if not_increasing.size:
        i = not_increasing[0] + 1
        raise _error(
            source,
            value_numbers[i],
            f"frame number {frame_numbers[i]} does not follow frame "
            f"{frame_numbers[i - 1]} (line {value_numbers[i - 1]}): frame numbers must increase",
        )
    return frame_numbers, masks[:, :N_FAPS], values, viseme, expression


def _scan_value_lines(texts: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frame numbers (as float64), the other numbers of all lines in order, their count per line, and
    whether a line holds a malformed token or a frame number that is not a non-negative integer.

    A line with more tokens than any value line can hold is bad: it is counted, but only its frame number
    is scanned, and it adds no numbers.
    """
    frame_numbers, numbers, n_numbers, bad_line = [], [], [], []
    # In blocks of lines, so that the per-token arrays stay in the processor's cache (twice as fast).
    for i in range(0, len(texts), _BLOCK_LINES):
        block = texts[i : i + _BLOCK_LINES]
        text = "\n".join(block)
        crowded = {}  # line in block -> token count, for lines with more tokens than a value line can hold
        if text.count(" ") + text.count("\t") + len(block) > _MAX_VALUE_TOKENS * len(block):  # may hold some
            crowded = {
                j: n
                for j, line in enumerate(block)
                if line.count(" ") + line.count("\t") >= _MAX_VALUE_TOKENS
                and (n := _count_tokens(line)) > _MAX_VALUE_TOKENS
            }
            if crowded:  # malformed whatever their tokens: scan their frame numbers only
                text = "\n".join(_TOKEN_RE.match(line)[0] if j in crowded else line for j, line in enumerate(block))
        tokens, well_formed, digits_only, line_of_token = _scan_numbers(text)
        n_tokens = np.bincount(line_of_token, minlength=len(block))
        first_token = np.cumsum(n_tokens) - n_tokens
        bad = ~digits_only[first_token]
        bad[line_of_token[~well_formed]] = True
        if crowded:
            rows = np.fromiter(crowded, np.intp, len(crowded))
            bad[rows] = True
            n_tokens[rows] = np.fromiter(crowded.values(), np.intp, len(crowded))
        bad_line.append(bad)
        frame_numbers.append(tokens[first_token])
        n_numbers.append(n_tokens - 1)
        is_number = np.ones(len(tokens), bool)
        is_number[first_token] = False
        numbers.append(tokens[is_number])
    return tuple(np.concatenate(parts) for parts in (frame_numbers, numbers, n_numbers, bad_line))


def _scan_numbers(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Check and convert the blank-separated decimal numbers of `text` (lines of numbers) at once.

    Returns per token its float64 value (exactly as `float()` gives it), whether it is a finite decimal
    number, whether it is all digits, and its line index.

    The characters of all tokens are walked column by column (character j of every token at once,
    longest tokens first so each step works on a prefix of the arrays), checking the grammar
    [sign] digits [. digits] [e [sign] digits] and accumulating each token as mantissa * 10**scale.
    While the mantissa is below 2**53 and |scale| <= 22 both factors are exact doubles, so the one
    multiplication or division rounds correctly. The rare other tokens (over 15 significant digits,
    huge exponents, very long) go through `float()`.
    """
    data = text.encode("utf-8", errors="surrogatepass")
    b = np.frombuffer(data, np.uint8)
    blank = (b == ord(" ")) | (b == ord("\t")) | (b == ord("\n"))
    edges = np.diff(blank.view(np.int8), prepend=np.int8(1), append=np.int8(1))
    starts = np.flatnonzero(edges == -1)
    ends = np.flatnonzero(edges == 1)
    lengths = ends - starts
    line_of_token = np.searchsorted(np.flatnonzero(b == ord("\n")), starts)

    n = len(starts)
    clipped = np.minimum(lengths, _MAX_TOKEN).astype(np.uint8)
    order = np.argsort(np.uint8(_MAX_TOKEN) - clipped, kind="stable")  # a radix sort: longest first
    first = starts[order]
    n_active = np.cumsum(np.bincount(clipped, minlength=_MAX_TOKEN + 1)[::-1])[::-1]
    mantissa = np.zeros(n)
    exponent = np.zeros(n)
    fraction_digits = np.zeros(n)
    mantissa_digits = np.zeros(n, np.int64)
    exponent_digits = np.zeros(n, np.int64)
    after_dot = np.zeros(n, bool)
    in_exponent = np.zeros(n, bool)
    after_e = np.zeros(n, bool)
    exponent_negative = np.zeros(n, bool)
    bad = np.zeros(n, bool)
    has_dot = "." in text
    has_exponent = "e" in text or "E" in text
    has_sign = "-" in text or "+" in text
    for j in range(_MAX_TOKEN):
        k = n_active[j + 1]
        if k == 0:
            break
        char = b[first[:k] + j]
        digit = char - np.uint8(ord("0"))
        is_digit = digit < 10
        if has_sign:
            is_sign = (char == ord("-")) | (char == ord("+"))
            if j > 0:
                bad[:k] |= is_sign & ~after_e[:k]
        if has_exponent:
            if has_sign:
                exponent_negative[:k] |= after_e[:k] & (char == ord("-"))
            exp_digit = is_digit & in_exponent[:k]
            exponent[:k] = np.where(exp_digit, exponent[:k] * 10 + digit, exponent[:k])
            exponent_digits[:k] += exp_digit
            is_digit &= ~in_exponent[:k]
            is_e = (char | 0x20) == ord("e")
            bad[:k] |= is_e & (in_exponent[:k] | (mantissa_digits[:k] == 0))
            in_exponent[:k] |= is_e
            after_e[:k] = is_e
        mantissa[:k] = np.where(is_digit, mantissa[:k] * 10 + digit, mantissa[:k])
        mantissa_digits[:k] += is_digit
        if has_dot:
            fraction_digits[:k] += is_digit & after_dot[:k]
            is_dot = char == ord(".")
            bad[:k] |= is_dot & (after_dot[:k] | in_exponent[:k])
            after_dot[:k] |= is_dot
    bad |= (mantissa_digits == 0) | (in_exponent & (exponent_digits == 0))

    scale = np.where(exponent_negative, -exponent, exponent) - fraction_digits
    inexact = (mantissa > _EXACT_INTEGER) | (np.abs(scale) >= len(_POW10))
    power = _POW10[np.minimum(np.abs(scale), len(_POW10) - 1).astype(np.intp)]
    by_length = np.where(scale >= 0, mantissa * power, mantissa / power)
    by_length[b[first] == ord("-")] *= -1
    numbers = np.empty(n)
    numbers[order] = by_length
    well_formed = np.empty(n, bool)
    well_formed[order] = ~bad
    digits_only = np.empty(n, bool)
    digits_only[order] = mantissa_digits == clipped[order]
    for i in np.concatenate([order[inexact & ~bad], np.flatnonzero(lengths > _MAX_TOKEN)]):
        token = data[starts[i] : ends[i]].decode("utf-8", errors="replace")
        well_formed[i] = bool(_NUMBER_RE.fullmatch(token))
        digits_only[i] = bool(_FRAME_RE.fullmatch(token))
        numbers[i] = float(token) if well_formed[i] else 0.0
    junk = np.flatnonzero(~_NUMBER_BYTES[b])  # never a blank, so always inside a token
    well_formed[np.searchsorted(starts, junk, side="right") - 1] = False
    well_formed &= np.isfinite(numbers)
    return numbers, well_formed, digits_only, line_of_token


# --- writing -------------------------------------------------------------------------------------------


def _format_number(x: float) -> str:
    return str(int(x)) if x.is_integer() and abs(x) < _EXACT_INTEGER else repr(x)


def _format_numbers(values: np.ndarray) -> list[str]:
    integral = (values == np.rint(values)) & (np.abs(values) < _EXACT_INTEGER)
    if integral.all():
        return list(map(str, values.astype(np.int64).tolist()))
    return [str(int(x)) if whole else repr(x) for x, whole in zip(values.tolist(), integral.tolist(), strict=True)]


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
    # Each frame's values in file order: viseme fields, expression fields, FAPs 3..68.
    row = np.hstack([stream.viseme, stream.expression, np.asarray(stream.values)[:, 2:]]).astype(np.float64)
    present = np.hstack([np.repeat(mask[:, :2], [VISEME_FIELDS, EXPRESSION_FIELDS], axis=1), mask[:, 2:]])
    tokens = _format_numbers(row[present])
    ends = np.cumsum(present.sum(axis=1)).tolist()
    mask_texts: dict[bytes, str] = {}
    name = "_".join(stream.name.split()) or "unnamed"
    out = [f"{stream.version} {name} {_format_number(float(stream.fps))} {len(mask)}"]
    flags = (mask.astype(np.uint8) + ord("0")).tobytes()
    frames = map(str, np.asarray(stream.frame_numbers).astype(np.int64).tolist())
    start = 0
    for i, (frame, end) in enumerate(zip(frames, ends, strict=True)):
        key = flags[i * N_FAPS : (i + 1) * N_FAPS]
        mask_text = mask_texts.get(key)
        if mask_text is None:
            mask_text = mask_texts[key] = " ".join(key.decode("ascii"))
        out.append(mask_text)
        out.append(f"{frame} {' '.join(tokens[start:end])}" if end > start else frame)
        start = end
    return "\n".join(out) + "\n"


def format_fap(stream: FapStream) -> str:
    """The text of `stream` as a `.fap` file in the reference layout."""
    return _format(stream, "<string>")


def write_fap(stream: FapStream, path) -> None:
    """Write `stream` to `path` atomically: a complete new file or, on failure, the old one untouched."""
    target = os.fspath(path)
    data = _format(stream, target).encode("utf-8", errors="replace")
    # A new file next to the target (same file system, so the rename is atomic), created with the
    # usual permissions (tempfile.mkstemp would make it private to the user).
    head, tail = os.path.split(os.path.abspath(target))
    tmp = os.path.join(head, f".{tail}.{secrets.token_hex(4)}.tmp")
    try:
        file = open(tmp, "xb")  # "x": never touch a file that is not ours
    except OSError as exc:
        raise FapFileError(f"{target}: cannot write the file: {exc}") from None
    try:
        with file:
            file.write(data)
            file.flush()
            os.fsync(file.fileno())
        os.replace(tmp, target)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise FapFileError(f"{target}: cannot write the file: {exc}") from None
