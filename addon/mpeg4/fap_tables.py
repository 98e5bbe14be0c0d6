"""Data tables of FAP values, read strictly: a small UTF-8 JSON file of objects, lists, texts and numbers, and
{FAP name: value} objects checked against the standard's range and direction of each FAP.

Below the packages whose tables these are (speech's visemes and expressions, the ARKit recipes): a
`TableReader` raises the error class of the package that reads, naming the file and the entry.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..user_files import read_regular_file
from ..user_json import parse_json
from .faps import FAPS, N_FAPS, fap

MAX_FILE_BYTES = 16 * 2**20  # a cue list or table this large is not one

# The standard's intra-frame range of each FAP in quantiser steps ("I max", research/mpeg4-fba.md section 3;
# the research marks 29, 30, 41 and 42 as unverified). Times the FAP's quantiser step it is the largest
# magnitude an I-frame can carry, in FAP units; the tables must stay within it.
_I_MAX = (
    (3, 1080), (4, 600), (5, 1860), (6, 600), (7, 600), (8, 600), (9, 600), (10, 1860), (11, 1860), (12, 600),
    (13, 600), (14, 600), (15, 1080), (16, 1080), (17, 1080), (18, 420), (19, 1080), (20, 1080), (21, 600),
    (22, 600), (23, 1200), (24, 1200), (25, 900), (26, 900), (27, 600), (28, 600), (29, 420), (30, 420),
    *((n, 900) for n in range(31, 43)), *((n, 1080) for n in range(43, 47)), (47, 300), (48, 1860),
    (49, 1860), (50, 1860), (51, 600), (52, 1860), (53, 600), (54, 600), (55, 600), (56, 600), (57, 1860),
    (58, 1860), (59, 600), (60, 600), (61, 540), (62, 540), (63, 680), (64, 900), (65, 900), (66, 900),
    (67, 900), (68, 900),
)  # fmt: skip
FAP_RANGE = np.zeros(N_FAPS)
for _number, _i_max in _I_MAX:
    FAP_RANGE[_number - 1] = _i_max * FAPS[_number - 1].quant_step
FAP_RANGE.flags.writeable = False


class TableReader:
    """Reads and checks a table's parts, raising `error` (an Mpeg4Error subclass) with where and what."""

    def __init__(self, error: type[Exception]):
        self.error = error

    def read_text(self, path: Path | str, what: str) -> str:
        """A small UTF-8 text file (a regular file, at most MAX_FILE_BYTES)."""
        source = str(path)
        too_large = f"larger than {MAX_FILE_BYTES // 2**20} MiB"
        data = read_regular_file(path, MAX_FILE_BYTES, self.error, f"{source}: the {what}", too_large)
        try:
            return data.decode("utf-8").removeprefix("\ufeff")
        except UnicodeDecodeError as exc:
            raise self.error(f"{source}: the {what} is not UTF-8 text (byte {exc.start})") from None

    def read_json(self, path: Path | str, what: str) -> object:
        """A JSON document, strictly (`user_json.parse_json`)."""
        return parse_json(self.read_text(path, what), self.error, f"{path}: the {what}")

    def object_with(self, value, keys: set[str], optional: set[str], where: str) -> dict:
        """`value` as an object with all of `keys`, some of `optional` and nothing else."""
        if not isinstance(value, dict):
            raise self.error(f"{where}: expected an object, found {type(value).__name__}")
        missing = keys - value.keys()
        unknown = value.keys() - keys - optional
        if missing:
            raise self.error(f"{where}: missing {', '.join(sorted(missing))}")
        if unknown:
            raise self.error(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
        return value

    def list_of(self, value, where: str) -> list:
        if not isinstance(value, list):
            raise self.error(f"{where}: expected a list, found {type(value).__name__}")
        return value

    def text(self, value, where: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.error(f"{where}: expected a non-empty text")
        return value

    def number(self, value, where: str) -> float:
        """A JSON number as float (bool is not a number here)."""
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise self.error(f"{where}: {value!r} is not a finite number")
        return float(value)

    def fap_values(self, faps, where: str) -> dict[int, float]:
        """{FAP name: value} -> {FAP number: value}, each within the FAP's range and direction."""
        if not isinstance(faps, dict):
            raise self.error(f"{where}: 'faps' must be an object of FAP name: value")
        out = {}
        for name, value in faps.items():
            try:
                info = fap(name)
            except KeyError:
                raise self.error(f"{where}: unknown FAP {name!r}") from None
            if info.fapu is None:
                raise self.error(f"{where}: FAP {name!r} is high-level; a table holds low-level FAPs only")
            value = self.number(value, f"{where}: FAP {name!r}")
            limit = FAP_RANGE[info.number - 1]
            if abs(value) > limit:
                raise self.error(f"{where}: FAP {name!r} = {value:g} is outside the standard's range ±{limit:g}")
            if not info.bidirectional and value < 0:
                raise self.error(f"{where}: FAP {name!r} = {value:g} is negative but the FAP is unidirectional")
            out[info.number] = value
        return out
