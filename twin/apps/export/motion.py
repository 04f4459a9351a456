"""The program's moves: a joint move to an approach point above the path, the path at feeds limited to the
process feed while in contact, and a linear retract.

- **Approach and retract**: the program starts with a joint move to the approach point, straight above the path's
  first point at the safe height (sheet frame z), then moves linearly down onto the path at the process feed; it
  ends with a linear move straight up from the path's last point to the safe height, at the process feed. The
  safe height defaults to the sheet top (z = 0 of the sheet frame) or the path's highest point, whichever is
  higher, plus `SAFE_MARGIN_MM`; a given one must lie above every path point.
- **Feeds in contact**: every move of the path is a forming move (the path CSV is the tool path on the sheet).
  The process feed is the given one, else the median of the path's own feeds (|Δp|/Δt of its time stamps). A move
  faster than `FEED_TOLERANCE` times the process feed is programmed at the process feed: it is time-scaled, the
  robot takes longer over it, and the positions are unchanged. This is what a compensated path needs: its
  command jumps by up to ~2 mm within one 15 ms sample where the forces reverse, a feed several times the
  process feed that the robot would otherwise be asked to reach in contact. Moves at or below the tolerance keep
  their feed (the CSV's rounding of times and positions moves feeds by ~0.1 %).

`FeedSummary` reports the process feed, the fastest programmed move in contact, the path's own fastest, how many
moves were slowed and how much longer the program runs than the path's time stamps.

- **Corners**: a point where the path turns by more than `CORNER_DEG` between the move into it and the move out of
  it (`corners`) is one the robot stops on in every language (KRL ends its spline block there, RAPID moves to it
  `fine`); elsewhere the controller blends from move to move within `CHORD_TOL_MM` of the points. The twin's
  smooth paths turn by at most ~3° per point (the cone spiral 1.0°, the compensated groove 2.6° outside its
  reversals); their real corners turn by 90° (down onto the path, up from it) or ~150-180° (a groove's reversals).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from twin.apps.export.program import ProgramPath
from twin.errors import InputError

#: The default safe height above the sheet top or the path's highest point [mm].
SAFE_MARGIN_MM = 20.0
#: A move in contact may be this much faster than the process feed before it is slowed to it.
FEED_TOLERANCE = 1.05
#: A point where the path turns by more than this is a corner the robot stops on [deg] (module docstring).
CORNER_DEG = 10.0
#: How far a controller's blending may take the tool from the path's points [mm]: the tracker's noise, below which a
#: deviation is not measured.
CHORD_TOL_MM = 0.02


class FeedSummary(NamedTuple):
    """The feeds of a program's moves in contact (the path's moves, approach and retract excluded).

    Attributes:
        process_mm_s: The process feed [mm/s].
        max_in_contact_mm_s: The fastest programmed move in contact [mm/s].
        path_max_in_contact_mm_s: The path's own fastest move, |Δp|/Δt of its time stamps [mm/s].
        slowed: Moves programmed at the process feed because the path had them faster than the tolerance.
        first_slowed_row: The path CSV's data row the first slowed move reaches, or 0.
        added_time_s: How much longer the program's path runs than the path's time stamps [s].
        safe_z_mm: The approach and retract height (sheet frame z) [mm].
    """

    process_mm_s: float
    max_in_contact_mm_s: float
    path_max_in_contact_mm_s: float
    slowed: int
    first_slowed_row: int
    added_time_s: float
    safe_z_mm: float

    def warnings(self) -> list[str]:
        """What a programmer should know: slowed moves and the time they add."""
        if not self.slowed:
            return []
        return [
            f"{self.slowed} move(s) in contact were faster than {FEED_TOLERANCE:g}x the process feed "
            f"{self.process_mm_s:.2f} mm/s (fastest {self.path_max_in_contact_mm_s:.1f} mm/s, first at row "
            f"{self.first_slowed_row}); they are programmed at the process feed, so the program runs "
            f"{self.added_time_s:.2f} s longer than the path's time stamps"
        ]


def default_safe_z_mm(points_mm: np.ndarray) -> float:
    """The sheet top (z = 0) or the path's highest point, whichever is higher, plus `SAFE_MARGIN_MM` [mm]."""
    return max(0.0, float(np.max(points_mm[:, 2]))) + SAFE_MARGIN_MM


def with_moves(
    path: ProgramPath, safe_z_mm: float | None = None, process_feed_mm_s: float | None = None
) -> tuple[ProgramPath, FeedSummary]:
    """`path` with an approach and a retract at the safe height and its feeds limited in contact.

    Args:
        path: The path as read (`load_program_path`), feed per point from its time stamps.
        safe_z_mm: Approach and retract height, sheet frame z [mm]; None: `default_safe_z_mm`.
        process_feed_mm_s: The process feed [mm/s]; None: the median of the path's feeds.

    Returns:
        The program's points (approach, path, retract) and feeds, and the feed summary.

    Raises:
        InputError: A safe height not above every path point, or a process feed not > 0 (names the option).
    """
    p, feed = path.points_mm, path.feed_mm_s
    top = float(np.max(p[:, 2]))
    safe = default_safe_z_mm(p) if safe_z_mm is None else float(safe_z_mm)
    if not (math.isfinite(safe) and safe > top):
        raise InputError(
            f"--safe-height-mm {safe_z_mm!r}: the path's highest point is at z = {top:.3f} mm (sheet frame); "
            f"expected a height above it (default: {default_safe_z_mm(p):.3f} mm, {SAFE_MARGIN_MM:g} mm above "
            "the sheet top or the highest point)"
        )
    process = float(np.median(feed[1:] if len(feed) > 1 else feed)) if process_feed_mm_s is None else process_feed_mm_s
    if not (math.isfinite(process) and process > 0):
        raise InputError(f"--feed-mm-s {process_feed_mm_s!r}: expected the process feed, a finite number > 0 [mm/s]")
    moves = feed[1:]  # the feed of each path move (the first point's copies the second's)
    fast = moves > FEED_TOLERANCE * process
    programmed = np.where(fast, process, moves)
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    added = float(np.sum(steps[fast] / process - steps[fast] / moves[fast]))
    approach = np.array([p[0, 0], p[0, 1], safe])
    retract = np.array([p[-1, 0], p[-1, 1], safe])
    summary = FeedSummary(
        process_mm_s=process,
        max_in_contact_mm_s=float(np.max(programmed)) if len(programmed) else process,
        path_max_in_contact_mm_s=float(np.max(moves)) if len(moves) else process,
        slowed=int(np.count_nonzero(fast)),
        first_slowed_row=int(np.flatnonzero(fast)[0]) + 2 if np.any(fast) else 0,
        added_time_s=added,
        safe_z_mm=safe,
    )
    program = replace(
        path,
        points_mm=np.vstack([approach, p, retract]),
        feed_mm_s=np.concatenate([[process, process], programmed, [process]]),
        approach=True,
        process_feed_mm_s=process,
    )
    return program, summary


def turn_angles_deg(points_mm: np.ndarray) -> np.ndarray:
    """The angle the path turns by at each point, between the move into it and the move out of it [deg].

    Args:
        points_mm: The program's points, shape (n, 3) [mm].

    Returns:
        Shape (n,): 0 at the first and the last point (no move on one side).
    """
    step = np.diff(np.asarray(points_mm, dtype=float), axis=0)
    unit = step / np.maximum(np.linalg.norm(step, axis=1, keepdims=True), 1e-12)
    cos = np.clip(np.sum(unit[1:] * unit[:-1], axis=1), -1.0, 1.0)
    return np.concatenate([[0.0], np.degrees(np.arccos(cos)), [0.0]])


def corners(points_mm: np.ndarray) -> np.ndarray:
    """Whether the robot stops at each point: a turn over `CORNER_DEG`, and the last point (the program's end).

    Args:
        points_mm: The program's points, shape (n, 3) [mm].

    Returns:
        Booleans, shape (n,).
    """
    stop = turn_angles_deg(points_mm) > CORNER_DEG
    stop[-1] = True
    return stop
