"""argparse types of the options whose values have a plausible range: seeds, counts, lengths and feeds.

A bad value ends in argparse's own message (`argument --depth-mm: '-5' ...: expected ...`, exit 2), naming the
option as typed, before any internal (SI) field sees it. The bounds are plausibility, not physics: no forming
cell's sheet, path or feed comes near them, and values past them only make the path's sampling hang.
"""

from __future__ import annotations

import argparse
import math

LONGEST_MM = 1e4  # 10 m: longer than any robot cell's reach
FASTEST_MM_S = 1e4  # 10 m/s: faster than any forming feed


def _number(text: str, kind: type = float) -> float:
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not finite; expected a finite number")
    return value


def seed(text: str) -> int:
    """A random seed: an integer >= 0."""
    value = int(_number(text, int))
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative; expected a seed, an integer >= 0")
    return value


def count(text: str) -> int:
    """A count (passes, draws, iterations, workers): an integer >= 1."""
    value = int(_number(text, int))
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected an integer >= 1")
    return value


def length_mm(text: str) -> float:
    """A length in millimetres: > 0 and <= 10 m."""
    value = _number(text)
    if not 0.0 < value <= LONGEST_MM:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a length in mm > 0 and <= {LONGEST_MM:g}")
    return value


def feed_mm_s(text: str) -> float:
    """A feed in millimetres per second: > 0 and <= 10 m/s."""
    value = _number(text)
    if not 0.0 < value <= FASTEST_MM_S:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a feed in mm/s > 0 and <= {FASTEST_MM_S:g}")
    return value


def finite(text: str) -> float:
    """Any finite number (a coordinate, an angle)."""
    return _number(text)
