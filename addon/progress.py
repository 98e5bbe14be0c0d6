"""Work done as generators of progress fractions (0..1) that return their result (no bpy)."""

from __future__ import annotations

from collections.abc import Generator
from typing import TypeVar

Result = TypeVar("Result")


def scaled(steps: Generator[float, None, Result], start: float, end: float) -> Generator[float, None, Result]:
    """Run a stage's generator, its fractions mapped onto [start, end] of the whole; returns its result. Closing
    this generator (Esc) closes the stage at once."""
    try:
        while True:
            try:
                fraction = next(steps)
            except StopIteration as done:
                return done.value
            yield start + (end - start) * fraction
    finally:
        steps.close()
