"""The arcs of G-code (G2/G3 in the XY plane), as the controller interpolates them: chords no longer than a spacing
and no farther than a tolerance from the arc (`twin.process.toolpath.gcode`)."""

from __future__ import annotations

import math

import numpy as np

from twin.process.toolpath.groove import MAX_SAMPLES as MAX_ARC_PIECES
from twin.process.toolpath.groove import SampleLimitError


def arc_points(
    start: np.ndarray, end: np.ndarray, centre_xy: np.ndarray, clockwise: bool, spacing: float, tol: float
) -> np.ndarray:
    """Chord end points (k, 3) of an XY arc from `start` to `end` (end included, start excluded) [mm].

    Raises:
        SampleLimitError: A spacing or tolerance that would make more than `MAX_SAMPLES` chords.
    """
    r0 = start[:2] - centre_xy
    r1 = end[:2] - centre_xy
    radius = float(np.hypot(*r0))
    a0 = math.atan2(r0[1], r0[0])
    sweep = math.atan2(r1[1], r1[0]) - a0
    if clockwise:
        sweep = sweep - 2 * math.pi if sweep >= -1e-12 else sweep
    else:
        sweep = sweep + 2 * math.pi if sweep <= 1e-12 else sweep
    arc_len = abs(sweep) * radius
    max_angle = 2.0 * math.acos(max(-1.0, 1.0 - tol / radius)) if radius > tol else math.pi
    count = max(arc_len / spacing, abs(sweep) / max_angle)
    if not count <= MAX_ARC_PIECES:  # before allocating (the reader counts the whole path's samples)
        raise SampleLimitError(count, spacing / 1e3)
    pieces = max(1, math.ceil(count - 1e-9))
    f = np.arange(1, pieces + 1) / pieces
    a = a0 + sweep * f
    pts = np.column_stack([centre_xy[0] + radius * np.cos(a), centre_xy[1] + radius * np.sin(a),
                           start[2] + (end[2] - start[2]) * f])
    pts[-1] = end
    return pts


def centre_from_radius(start: np.ndarray, end: np.ndarray, radius: float, clockwise: bool) -> np.ndarray | None:
    """Centre of the XY arc of signed radius R (R < 0: the long way round) from start to end, or None [mm]."""
    chord = end[:2] - start[:2]
    d = float(np.hypot(*chord))
    if d < 1e-12 or abs(radius) < d / 2.0 - 1e-9:
        return None
    h = math.sqrt(max(0.0, radius * radius - d * d / 4.0))
    normal = np.array([-chord[1], chord[0]]) / d  # left of the chord
    side = (-1.0 if clockwise else 1.0) * (1.0 if radius > 0 else -1.0)
    return np.asarray(start[:2] + chord / 2.0 + side * h * normal)
