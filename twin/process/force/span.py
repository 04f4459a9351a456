"""The span a learned sheet was learned over, and the warning when a path leaves it.

A sheet learned from one nominal run has seen the depths its tool reached and the turns its path made, nothing
else. Compensating that run's own part drives the tool deeper than the nominal run reached (the nominal tip lagged
by the arm's deflection), and a pyramid's corners turn the tool faster than a cone's circle ever did: there the
learned terms extrapolate (on the plant a cone-learned sheet under-predicts a pyramid's axial force most at its
corners, and its own cone's over the last passes, deeper than its nominal run went). The learner
records the span of its runs beside its weights (`SPAN_KEYS` in `Process.force_fit`, written by
`twin.analysis.learn.sheet.fit_sheet`); `span_warnings` names where a path to be formed or replayed leaves it, so
a user reads that part of the prediction as extrapolated (`twin.errors.ExtrapolationWarning`, printed by the CLI).

The two quantities are read off the path alone, in contact (below the sheet's plane):
- the depth below the sheet's plane [mm], its deepest;
- the turn of the travel over one tool radius of path [deg] (a circle of radius r turns by R/r rad; a sharp
  corner by its whole angle), its 99th percentile (a single jittered sample is no turn).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from twin.errors import ExtrapolationWarning

if TYPE_CHECKING:
    from twin.process.description import Process

#: `Process.force_fit` keys of the learned span (`Span`'s fields, in that order).
SPAN_KEYS = ("span_depth_mm", "span_turn_deg")
#: How far past the span a path goes before it is named: the tracker's noise on a depth [mm], and on a turn [deg].
DEPTH_MARGIN_MM = 0.25
TURN_MARGIN_DEG = 5.0
#: The percentile of the turn read as a path's largest.
TURN_PERCENTILE = 99.0


class Span(NamedTuple):
    """What a path covers, in contact: its deepest depth below the sheet's plane [mm] and its largest turn over one
    tool radius of travel [deg]."""

    depth_mm: float
    turn_deg: float


def path_span(p_sheet_m: np.ndarray, radius_m: float) -> Span:
    """The span of a path (module docstring): its samples below the sheet's plane.

    Args:
        p_sheet_m: The tool tip, shape (n, 3) [m], sheet frame.
        radius_m: The tool's radius [m] (the length of path a turn is read over).
    """
    p = np.asarray(p_sheet_m, dtype=float)
    below = p[:, 2] < 0.0
    if not np.any(below):
        return Span(0.0, 0.0)
    depth_mm = float(-1e3 * np.min(p[below, 2]))
    step = np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)
    moving = step > 1e-7
    if np.count_nonzero(moving) < 2:
        return Span(depth_mm, 0.0)
    heading = np.unwrap(np.arctan2(np.diff(p[:, 1])[moving], np.diff(p[:, 0])[moving]))
    s = np.concatenate(([0.0], np.cumsum(step[moving][:-1])))  # path length at the start of each heading [m]
    ahead = np.searchsorted(s, s + radius_m).clip(max=len(s) - 1)
    turn = np.abs(heading[ahead] - heading)
    inside = below[1:][moving]
    turn_deg = float(np.degrees(np.percentile(turn[inside], TURN_PERCENTILE))) if np.any(inside) else 0.0
    return Span(depth_mm, turn_deg)


def learned_span(measured: list[np.ndarray], commanded: list[np.ndarray], radius_m: float) -> Span:
    """The span of a learner's runs: the deepest of their measured tips (how deep the tool went), the largest turn
    of their commanded paths (a tracker's jitter is no turn)."""
    return Span(max(path_span(p, radius_m).depth_mm for p in measured),
                max(path_span(p, radius_m).turn_deg for p in commanded))


def span_of(force_fit: Mapping[str, float]) -> Span | None:
    """The learned span a model carries, None where it carries none (a model file written before, or not learned)."""
    if not all(key in force_fit for key in SPAN_KEYS):
        return None
    return Span(*(float(force_fit[key]) for key in SPAN_KEYS))


def span_warnings(learned: Span | None, p_sheet_m: np.ndarray, radius_m: float, what: str,
                  reached_m: np.ndarray | None = None) -> list[str]:
    """Sentences naming where the path `what` leaves the learned span (none inside it, or without a span);
    `reached_m`: the tip a run reached (its tracker), read for the depth in place of the path (a replay)."""
    if learned is None:
        return []
    span = path_span(p_sheet_m, radius_m)
    if reached_m is not None:
        span = span._replace(depth_mm=path_span(reached_m, radius_m).depth_mm)
    out = []
    if span.depth_mm > learned.depth_mm + DEPTH_MARGIN_MM:
        out.append(f"{what} goes {span.depth_mm:.2f} mm deep, past the {learned.depth_mm:.2f} mm the learned sheet "
                   "was learned to (its runs' deepest measured tip): its force there is extrapolated")
    if span.turn_deg > learned.turn_deg + TURN_MARGIN_DEG:
        out.append(f"{what} turns by up to {span.turn_deg:.0f} deg over one tool radius, past the "
                   f"{learned.turn_deg:.0f} deg of the runs the learned sheet was learned from (a corner its runs "
                   "had none of): its force there is extrapolated")
    return out


def warn_outside_span(process: Process, p_sheet_m: np.ndarray, what: str, reached_m: np.ndarray | None = None) -> None:
    """Warn (`ExtrapolationWarning`) where the path `what` leaves the span of a learned sheet (`span_warnings`);
    nothing for another force model or a learned one without a span."""
    learned = span_of(dict(process.force_fit)) if process.force_model == "learned" else None
    for sentence in span_warnings(learned, p_sheet_m, process.tool_radius_m, what, reached_m):
        warnings.warn(sentence, ExtrapolationWarning, stacklevel=3)
