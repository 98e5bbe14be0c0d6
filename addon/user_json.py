"""Reading JSON a user gave, bounded (no bpy): the one JSON reader of the add-on (FDP files, cue files, tables).

Python's `json` alone lets a hostile file escape as a raw Python error: a 400-digit integer later fails
to become a float (OverflowError), a 5,000-digit one exceeds the integer-string limit (ValueError), and
arrays nested 100,000 deep exhaust the recursion (RecursionError). Here every number is checked as it is
parsed (at most MAX_DIGITS digits, finite), NaN and Infinity are refused, nesting is counted before
parsing (at most MAX_DEPTH), and a key repeated in one object is refused: each problem raises the
reader's own Mpeg4Error naming the file and the line and column.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np

from .errors import Mpeg4Error

MAX_DEPTH = 64  # our documents nest four deep
MAX_DIGITS = 40  # characters of one number (a float64 needs 17 significant digits and an exponent)
_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_OPEN, _CLOSE = np.frombuffer(b"[{", np.uint8), np.frombuffer(b"]}", np.uint8)


class _Refused(Exception):
    """A value the parser met that the document may not hold; `token` locates it in the text."""

    def __init__(self, problem: str, token: str | None = None):
        super().__init__(problem)
        self.token = token


def parse_json(text: str, error: type[Mpeg4Error], source: str) -> object:
    """The JSON document in `text`, checked as the module docstring says; `error` (with "`source`: ...")
    for anything else."""
    _check_depth(text, error, source)
    try:
        return json.loads(
            text, object_pairs_hook=_unique_keys, parse_int=_integer, parse_float=_real, parse_constant=_constant
        )
    except json.JSONDecodeError as exc:
        raise error(f"{source}: line {exc.lineno}, column {exc.colno}: not valid JSON: {exc.msg}") from None
    except _Refused as exc:
        raise error(f"{source}: {_where(text, exc.token)}{exc}") from None


def _check_depth(text: str, error: type[Mpeg4Error], source: str) -> None:
    codes = np.frombuffer(_STRING.sub('""', text).encode("utf-8", "replace"), np.uint8)
    step = np.isin(codes, _OPEN).astype(np.int32) - np.isin(codes, _CLOSE)
    if len(step) and int(np.cumsum(step).max()) > MAX_DEPTH:
        raise error(f"{source}: nested more than {MAX_DEPTH} deep; not a document this add-on reads")


def _where(text: str, token: str | None) -> str:
    at = text.find(token) if token else -1
    if at < 0:
        return ""
    line = text.count("\n", 0, at) + 1
    return f"line {line}, column {at - (text.rfind(chr(10), 0, at) + 1) + 1}: "


def _short(token: str) -> str:
    return token if len(token) <= 24 else f"{token[:12]}...{token[-6:]} ({len(token)} characters)"


def _integer(token: str) -> int:
    if len(token.lstrip("-")) > MAX_DIGITS:
        raise _Refused(f"the number {_short(token)} has more than {MAX_DIGITS} digits", token)
    return int(token)


def _real(token: str) -> float:
    if len(token) > MAX_DIGITS:
        raise _Refused(f"the number {_short(token)} is longer than {MAX_DIGITS} characters", token)
    value = float(token)
    if not math.isfinite(value):
        raise _Refused(f"the number {_short(token)} is out of range", token)
    return value


def _constant(name: str) -> float:
    raise _Refused(f"{name} is not a number a file may hold", name)


def _unique_keys(pairs: list[tuple[str, object]]) -> dict[str, object]:
    out: dict[str, object] = {}
    for key, value in pairs:
        if key in out:
            raise _Refused(f"key {key[:40]!r} appears twice in one object")
        out[key] = value
    return out
