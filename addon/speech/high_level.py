"""FAP 1 (viseme) and FAP 2 (expression) of a stream -> low-level FAP values through the tables.

In each frame that transmits FAP 1, the standard's viseme blend gives
    v = shape(select1) * blend/63 + shape(select2) * (1 - blend/63),
and in each frame that transmits FAP 2 the expressions add with their own intensities:
    e = shape(select1) * intensity1/63 + shape(select2) * intensity2/63
(research/mpeg4-fba.md section 5; `faps.viseme_weights` and `faps.expression_weights` give the weights).

Rules chosen where the standard leaves the decoder free (research section 13.5):
- Viseme and expression add, so that speech plays on an expressive face.
- A low-level FAP transmitted in the same frame overrides the high-level value of that FAP; it does not add
  to it. We recall that the standard gives the low-level FAPs priority over FAP 1 and 2, but we could not
  check this. Overriding also keeps a transmitted value exact: a frame that sends open_jaw 0 plays 0. And it
  does not count a FAP twice when an encoder sends a viseme together with its own low-level version of it.
- FAP 1 sets every FAP of the viseme table, and FAP 2 every FAP of the expression table: a viseme defines the
  whole mouth, with neutral values where its shape does not move. These FAPs then count as transmitted in
  that frame, so later frames without FAP 1 or 2 hold them, as they hold any FAP.
- viseme_def, expression_def and init_face are read but do not redefine the tables. In such a frame the
  transmitted low-level FAPs play as sent, by the override rule above.
- Greta's one-integer FAP 1 reads as select1 with blend 0 (`fap_file`). By the standard's formula that plays
  select2 = 0, silence. Greta writes its lips as low-level FAPs, and its integer in the FAP 1 slot is not a
  viseme (research section 10).
"""

from __future__ import annotations

from numbers import Real

import numpy as np

from ..mpeg4.faps import N_FAPS, Expression, expression_weights, viseme_weights
from . import SpeechError
from .tables import ShapeTable, load_expressions, load_visemes

MAX_BLEND = 63  # viseme_blend and expression intensities run 0..63

# (column, field name, largest value, must be an integer)
_VISEME_FIELDS = ((0, "viseme_select1", 14, True), (1, "viseme_select2", 14, True), (2, "viseme_blend", 63, False))
_EXPRESSION_FIELDS = (
    (0, "expression_select1", 6, True),
    (1, "expression_intensity1", 63, False),
    (2, "expression_select2", 6, True),
    (3, "expression_intensity2", 63, False),
)


def _check_fields(fields: np.ndarray, rows: np.ndarray, columns, frame_numbers) -> None:
    for column, name, largest, integral in columns:
        value = fields[rows, column]
        bad = ~np.isfinite(value) | (value < 0) | (value > largest)
        if integral:
            bad |= value != np.round(value)
        if bad.any():
            i = int(rows[np.argmax(bad)])
            frame = f"frame {int(frame_numbers[i])}" if frame_numbers is not None else f"frame index {i}"
            kind = "an integer" if integral else "a number"
            raise SpeechError(f"{frame}: {name} = {fields[i, column]:g} is not {kind} in 0..{largest}")


def apply_high_level(
    mask: np.ndarray,
    values: np.ndarray,
    viseme_fields: np.ndarray,
    expression_fields: np.ndarray,
    *,
    frame_numbers: np.ndarray | None = None,
    visemes: ShapeTable | None = None,
    expressions: ShapeTable | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """A stream's (F, 68) mask and values with FAP 1 and 2 played into the low-level FAPs (new arrays).

    `viseme_fields` (F, 4) and `expression_fields` (F, 6) are `FapStream.viseme` and `.expression`; only the
    frames whose mask sets FAP 1 (column 0) or FAP 2 (column 1) are read, and they are checked first
    (SpeechError naming the frame). `frame_numbers` (F,) names frames in messages.
    """
    mask = np.asarray(mask, dtype=bool)
    values = np.asarray(values, dtype=np.float64)
    viseme_fields = np.asarray(viseme_fields, dtype=np.float64)
    expression_fields = np.asarray(expression_fields, dtype=np.float64)
    n_frames = len(mask)
    for name, array, shape in (
        ("mask", mask, (n_frames, N_FAPS)),
        ("values", values, (n_frames, N_FAPS)),
        ("viseme_fields", viseme_fields, (n_frames, 4)),
        ("expression_fields", expression_fields, (n_frames, 6)),
    ):
        if array.shape != shape:
            raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    has_viseme = np.flatnonzero(mask[:, 0])
    has_expression = np.flatnonzero(mask[:, 1])
    _check_fields(viseme_fields, has_viseme, _VISEME_FIELDS, frame_numbers)
    _check_fields(expression_fields, has_expression, _EXPRESSION_FIELDS, frame_numbers)
    visemes = visemes or load_visemes()
    expressions = expressions or load_expressions()

    high = np.zeros((n_frames, N_FAPS))
    filled = np.zeros((n_frames, N_FAPS), dtype=bool)
    if has_viseme.size:
        high[has_viseme] += viseme_weights(viseme_fields[has_viseme]) @ visemes.targets
        filled[np.ix_(has_viseme, visemes.faps - 1)] = True
    if has_expression.size:
        high[has_expression] += expression_weights(expression_fields[has_expression]) @ expressions.targets
        filled[np.ix_(has_expression, expressions.faps - 1)] = True
    take = filled & ~mask  # transmitted low-level values win
    out_values = values.copy()
    out_values[take] = high[take]
    return mask | filled, out_values


def expression_values(
    expression: Expression | int | str, weight: float, expressions: ShapeTable | None = None
) -> np.ndarray:
    """(68,) FAP values of one expression at `weight` in 0..1 (= intensity/63), e.g. to layer on speech
    tracks; the expression is an `Expression`, its number 1..6 or its name ("joy")."""
    try:
        if isinstance(expression, str):
            member = Expression[expression.strip().upper()]
        else:
            member = Expression(expression)
    except (KeyError, ValueError):
        names = ", ".join(e.name.lower() for e in Expression if e)
        raise SpeechError(f"unknown expression {expression!r} (known: {names})") from None
    if isinstance(weight, bool) or not isinstance(weight, Real) or not 0.0 <= weight <= 1.0:
        raise SpeechError(f"expression {member.name.lower()}: weight {weight!r} is not a number in 0..1")
    return (expressions or load_expressions()).targets[member] * float(weight)
