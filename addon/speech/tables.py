"""The speech tables in `data/`, loaded and checked: viseme and expression shapes (FAP values in FAPU),
co-articulation dominance per viseme, English phoneme -> viseme, Rhubarb mouth shape -> viseme.

Every loader checks the whole file before it returns: a duplicate or missing entry, an unknown FAP, viseme or
expression name, a value that is not a finite number, outside the FAP's range or negative on a
unidirectional FAP, raises `SpeechError` naming the file and the entry. The default tables are loaded once
and returned read-only.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from ..mpeg4.fap_tables import TableReader
from ..mpeg4.faps import N_FAPS, Expression, Viseme
from . import SpeechError

READ = TableReader(SpeechError)  # the speech package's files and tables: errors are SpeechError

DATA = Path(__file__).resolve().with_name("data")
N_VISEMES = len(Viseme)
N_EXPRESSIONS = len(Expression)


@dataclass(frozen=True, eq=False)
class ShapeTable:
    """One face shape per viseme (15 rows) or per expression (7 rows, row 0 = neutral = zeros).

    `targets[i, k]` is FAP k+1 of shape i in FAPU (AU for angles); `faps` the FAP numbers the table drives
    (the union of every shape's FAPs: a shape that does not list one of them holds it at 0, neutral).
    """

    names: tuple[str, ...]
    targets: np.ndarray  # (S, 68) float64
    faps: np.ndarray  # (K,) int, sorted FAP numbers
    why: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class DominanceTable:
    """Cohen & Massaro dominance parameters per viseme (rows) and FAP (68 columns).

    D = alpha * exp(-theta * |tau|**exponent), tau = segment centre - t in seconds; theta_before applies
    where tau >= 0 (before the centre), theta_after after it; theta in 1/s**exponent.
    """

    alpha: np.ndarray  # (15, 68)
    theta_before: np.ndarray  # (15, 68)
    theta_after: np.ndarray  # (15, 68)
    exponent: np.ndarray  # (15, 68)
    groups: Mapping[str, tuple[int, ...]]
    why: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class PhonemeTable:
    """Phoneme name -> the visemes of its parts (one for most, two or three for diphthongs; none for h)."""

    visemes: Mapping[str, tuple[Viseme, ...]]
    stress_marks: str = "',%=!"
    pause_prefix: str = "_"

    def lookup(self, label: str) -> tuple[Viseme, ...] | None:
        """The visemes of a phoneme name (stress marks removed; '_...' is a pause), or None if unknown."""
        name = label.lstrip(self.stress_marks)
        if name in self.visemes:
            return self.visemes[name]
        if name.startswith(self.pause_prefix):
            return (Viseme.NONE,)
        return None


def _shape_table(path, key: str, enum, first: int, extra: set[str]) -> ShapeTable:
    source = str(path)
    doc = READ.object_with(READ.read_json(path, f"{key} table"), {"about", key}, set(), source)
    entries = READ.list_of(doc[key], f"{source}: {key}")
    rows = len(enum) - first
    if len(entries) != rows:
        raise SpeechError(f"{source}: {key} must list {rows} entries ({first}..{len(enum) - 1}), found {len(entries)}")
    targets = np.zeros((len(enum), N_FAPS))
    why = [""] * len(enum)
    seen = set()
    number_key = key[:-1]  # "visemes" -> "viseme"
    for k, entry in enumerate(entries):
        where = f"{source}: {key} entry {k + 1}"
        entry = READ.object_with(entry, {number_key, "name", "why", "faps"} | extra, set(), where)
        value = entry[number_key]
        if isinstance(value, bool) or not isinstance(value, int) or not first <= value < len(enum):
            raise SpeechError(f"{where}: {number_key} {value!r} is not one of {first}..{len(enum) - 1}")
        if value in seen:
            raise SpeechError(f"{where}: {number_key} {value} is listed twice")
        seen.add(value)
        member = enum(value)
        if entry["name"] != member.name and entry["name"] != member.name.lower():
            raise SpeechError(f"{where}: {number_key} {value} is {member.name}, not {entry['name']!r}")
        where = f"{source}: {number_key} {member.name}"
        why[value] = READ.text(entry["why"], f"{where}: 'why'")
        for number_, fap_value in READ.fap_values(entry["faps"], where).items():
            targets[value, number_ - 1] = fap_value
    if first == 0 and np.any(targets[0]):
        raise SpeechError(f"{source}: {enum(0).name} must be the neutral face (every FAP 0)")
    targets.flags.writeable = False
    faps = np.flatnonzero(np.any(targets != 0, axis=0)) + 1
    faps.flags.writeable = False
    return ShapeTable(tuple(m.name for m in enum), targets, faps, tuple(why))


def load_visemes(path: Path | str | None = None) -> ShapeTable:
    """The 15 viseme mouth shapes (0 = silence = neutral) from `path` or the bundled `data/visemes.json`."""
    return _default_visemes() if path is None else _shape_table(path, "visemes", Viseme, 0, {"phonemes"})


def load_expressions(path: Path | str | None = None) -> ShapeTable:
    """The 6 expressions at intensity 63 (row 0 = neutral) from `path` or the bundled `data/expressions.json`."""
    return _default_expressions() if path is None else _shape_table(path, "expressions", Expression, 1, set())


_PARAMETERS = {"alpha", "theta_before", "theta_after"}


def _parameters(value, where: str, required: set[str]) -> dict[str, float]:
    value = READ.object_with(value, required, (_PARAMETERS | {"c"}) - required, where)
    out = {}
    for name, item in value.items():
        out[name] = READ.number(item, f"{where}: {name}")
        if out[name] <= 0:
            raise SpeechError(f"{where}: {name} = {out[name]:g} must be positive")
    return out


def load_dominance(path: Path | str | None = None) -> DominanceTable:
    """Co-articulation parameters per viseme, from `path` or the bundled `data/dominance.json`."""
    if path is None:
        return _default_dominance()
    source = str(path)
    doc = READ.object_with(
        READ.read_json(path, "dominance table"), {"about", "groups", "default", "visemes"}, set(), source
    )
    groups: dict[str, tuple[int, ...]] = {}
    owner: dict[int, str] = {}
    if not isinstance(doc["groups"], dict) or not doc["groups"]:
        raise SpeechError(f"{source}: 'groups' must be a non-empty object of group name: {{faps, why}}")
    for name, group in doc["groups"].items():
        where = f"{source}: group {name!r}"
        group = READ.object_with(group, {"faps", "why"}, set(), where)
        READ.text(group["why"], f"{where}: 'why'")
        numbers = []
        for item in READ.list_of(group["faps"], f"{where}: faps"):
            if isinstance(item, bool) or not isinstance(item, int) or not 3 <= item <= N_FAPS:
                raise SpeechError(f"{where}: {item!r} is not a low-level FAP number (3..{N_FAPS})")
            if item in owner:
                raise SpeechError(f"{where}: FAP {item} is already in group {owner[item]!r}")
            owner[item] = name
            numbers.append(item)
        groups[name] = tuple(numbers)
    default = _parameters(doc["default"], f"{source}: default", _PARAMETERS | {"c"})
    arrays = {name: np.full((N_VISEMES, N_FAPS), value) for name, value in default.items()}
    entries = READ.list_of(doc["visemes"], f"{source}: visemes")
    names = [entry.get("name") if isinstance(entry, dict) else None for entry in entries]
    for member in Viseme:
        if names.count(member.name) != 1:
            raise SpeechError(f"{source}: viseme {member.name} must be listed once, found {names.count(member.name)}")
    why = [""] * N_VISEMES
    for k, entry in enumerate(entries):
        where = f"{source}: visemes entry {k + 1}"
        entry = READ.object_with(entry, {"name", "why"}, set(groups), where)
        try:
            member = Viseme[entry["name"]]
        except (KeyError, TypeError):
            raise SpeechError(f"{where}: unknown viseme {entry['name']!r}") from None
        where = f"{source}: viseme {member.name}"
        why[member] = READ.text(entry["why"], f"{where}: 'why'")
        for group, numbers in groups.items():
            if group in entry:
                for name, value in _parameters(entry[group], f"{where}: {group}", _PARAMETERS).items():
                    arrays[name][member, [n - 1 for n in numbers]] = value
    for array in arrays.values():
        array.flags.writeable = False
    return DominanceTable(
        arrays["alpha"],
        arrays["theta_before"],
        arrays["theta_after"],
        arrays["c"],
        MappingProxyType(groups),
        tuple(why),
    )


def _viseme_names(value, where: str) -> tuple[Viseme, ...]:
    out = []
    for name in READ.list_of(value, where):
        try:
            out.append(Viseme[name])
        except (KeyError, TypeError):
            raise SpeechError(f"{where}: unknown viseme {name!r} (known: {', '.join(Viseme.__members__)})") from None
    return tuple(out)


def load_phonemes(path: Path | str | None = None) -> PhonemeTable:
    """Phoneme name -> visemes, from `path` or the bundled English table `data/phonemes_en.json`."""
    if path is None:
        return _default_phonemes()
    source = str(path)
    doc = READ.object_with(READ.read_json(path, "phoneme table"), {"about", "groups"}, set(), source)
    table: dict[str, tuple[Viseme, ...]] = {}
    for k, group in enumerate(READ.list_of(doc["groups"], f"{source}: groups")):
        where = f"{source}: groups entry {k + 1}"
        group = READ.object_with(group, {"visemes", "phonemes", "why"}, set(), where)
        READ.text(group["why"], f"{where}: 'why'")
        visemes = _viseme_names(group["visemes"], f"{where}: visemes")
        for name in READ.list_of(group["phonemes"], f"{where}: phonemes"):
            if not isinstance(name, str) or not name or name != name.strip() or any(c.isspace() for c in name):
                raise SpeechError(f"{where}: phoneme {name!r} must be a name without blanks")
            if name[0] in PhonemeTable.stress_marks:
                raise SpeechError(f"{where}: phoneme {name!r} starts with a stress mark, which look-ups remove")
            if name in table:
                raise SpeechError(f"{where}: phoneme {name!r} is listed twice")
            table[name] = visemes
    return PhonemeTable(MappingProxyType(table))


RHUBARB_SHAPES = ("A", "B", "C", "D", "E", "F", "G", "H", "X")


def load_rhubarb(path: Path | str | None = None) -> dict[str, Viseme]:
    """Rhubarb Lip Sync mouth shape (A-H, X) -> viseme, from `path` or the bundled `data/rhubarb.json`."""
    if path is None:
        return dict(_default_rhubarb())
    source = str(path)
    doc = READ.object_with(READ.read_json(path, "Rhubarb shape table"), {"about", "shapes"}, set(), source)
    table = {}
    for k, entry in enumerate(READ.list_of(doc["shapes"], f"{source}: shapes")):
        where = f"{source}: shapes entry {k + 1}"
        entry = READ.object_with(entry, {"shape", "viseme", "why"}, set(), where)
        READ.text(entry["why"], f"{where}: 'why'")
        if entry["shape"] not in RHUBARB_SHAPES or entry["shape"] in table:
            raise SpeechError(f"{where}: shape {entry['shape']!r} is not a new one of {' '.join(RHUBARB_SHAPES)}")
        (table[entry["shape"]],) = _viseme_names([entry["viseme"]], f"{where}: viseme")
    if len(table) != len(RHUBARB_SHAPES):
        missing = [shape for shape in RHUBARB_SHAPES if shape not in table]
        raise SpeechError(f"{source}: shapes {' '.join(missing)} are missing")
    return table


@functools.cache
def _default_visemes() -> ShapeTable:
    return _shape_table(DATA / "visemes.json", "visemes", Viseme, 0, {"phonemes"})


@functools.cache
def _default_expressions() -> ShapeTable:
    return _shape_table(DATA / "expressions.json", "expressions", Expression, 1, set())


@functools.cache
def _default_dominance() -> DominanceTable:
    return load_dominance(DATA / "dominance.json")


@functools.cache
def _default_phonemes() -> PhonemeTable:
    return load_phonemes(DATA / "phonemes_en.json")


@functools.cache
def cmu_phones() -> PhonemeTable:
    """PocketSphinx's CMU phone (lower case) -> visemes, from the bundled `data/phones_cmu.json`."""
    return load_phonemes(DATA / "phones_cmu.json")


@functools.cache
def _default_rhubarb() -> tuple[tuple[str, Viseme], ...]:
    return tuple(load_rhubarb(DATA / "rhubarb.json").items())
