"""G-code import and export of tool paths (the CAM side of any ISF part).

Read subset (RS-274 words, one block per line):

* motion G0 (rapid, at `rapid_m_per_s`), G1 (linear, at the modal feed F), G2/G3 (clockwise / counter-clockwise
  arcs in the XY plane, centre by I/J offsets from the start point or by radius R, optional helical Z),
  linearised into chords no longer than `spacing_m` and no farther than `chord_tol_m` from the arc, a line
  divided into equal steps no longer than `spacing_m` (as the controller interpolates it: the twin forms the
  sheet at the samples, so a 20 mm G1 line kept as one step would form nothing between its ends); G4 dwell
  (P seconds) adds time without motion;
* modal state: G90/G91 absolute/incremental coordinates, G20/G21 inches/millimetres, F feed in units per
  minute (G94), the last motion mode applies to blocks with coordinates only;
* accepted without effect: G17 (XY plane), G40, G49, G54, G80, G94, M codes, N, S, T words, comments in
  parentheses or after `;`, `%` lines. Anything else (G18/G19 arcs, cutter compensation G41/G42, unknown words)
  is refused with a `DataFileError` naming the file and line.

Coordinates are the tool tip in the sheet frame; axes not yet set are 0. The path starts (t = 0) at the end
of the first move (where the tool was before it is unknown); zero-length moves add no sample. `pass_index` is 1 and
`direction` +1 throughout: G-code carries no pass structure (`twin.process.toolpath.groove.label_passes` infers it for
groove-like paths).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from twin.base.csvio import read_text, write_text
from twin.errors import DataFileError, InputError
from twin.process.toolpath.groove import ToolPath

_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_COMMENT = re.compile(r"\([^)]*\)|;.*$")
_IGNORED_G = {17.0, 40.0, 49.0, 54.0, 80.0, 94.0}
_AXES = "XYZ"


def _arc_points(
    start: np.ndarray, end: np.ndarray, centre_xy: np.ndarray, clockwise: bool, spacing: float, tol: float
) -> np.ndarray:
    """Chord end points (k, 3) of an XY arc from `start` to `end` (end included, start excluded) [mm]."""
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
    pieces = max(1, math.ceil(max(arc_len / spacing, abs(sweep) / max_angle) - 1e-9))
    f = np.arange(1, pieces + 1) / pieces
    a = a0 + sweep * f
    pts = np.column_stack([centre_xy[0] + radius * np.cos(a), centre_xy[1] + radius * np.sin(a),
                           start[2] + (end[2] - start[2]) * f])
    pts[-1] = end
    return pts


class _Block(NamedTuple):
    """The non-modal words of one block: axis and arc words [program units] and a G4 dwell [s]."""

    coords: dict[str, float]
    dwell: bool
    dwell_s: float


class _BlockReader:
    """Reads a program block by block into tool-tip samples [mm] and the durations of the moves to them [s].

    Holds the modal state (units, absolute/incremental, motion mode, feed) and the current position; the first
    sample is the unknown start (0, 0, 0), dropped by `tool_path`.
    """

    def __init__(self, source: str | Path, spacing_mm: float, tol_mm: float, rapid_mm_s: float) -> None:
        self.source = source
        self.spacing_mm, self.tol_mm, self.rapid_mm_s = spacing_mm, tol_mm, rapid_mm_s
        self.scale = 1.0  # [mm per program unit]
        self.absolute = True
        self.motion: float | None = None
        self.feed_mm_s: float | None = None
        self.pos = [0.0, 0.0, 0.0]  # [mm]
        self.points: list[list[float]] = [list(self.pos)]
        self.durations: list[float] = [0.0]

    def fail(self, lineno: int, message: str) -> DataFileError:
        """The error for a block, naming the file and the 1-based line."""
        return DataFileError(self.source, f"line {lineno}: {message}")

    def read(self, lineno: int, raw: str) -> None:
        """Read one line: a dwell, a move, modal words only, or nothing (blank, comment, `%`)."""
        line = _COMMENT.sub(" ", raw).strip()
        if not line or line.startswith("%"):
            return
        words = _WORD.findall(line)
        leftover = _WORD.sub("", line).strip()
        if leftover:
            raise self.fail(lineno, f"cannot read {leftover!r} in {raw.strip()!r} (expected words like G1 X10 F600)")
        block = self._apply_words(lineno, words)
        if block.dwell:
            if not block.dwell_s >= 0:
                raise self.fail(lineno, f"G4 dwell P{block.dwell_s} must be >= 0 s")
            self.points.append(list(self.pos))
            self.durations.append(block.dwell_s)
            return
        coords = block.coords
        if not any(a in coords for a in _AXES):
            if "I" in coords or "J" in coords or "R" in coords:
                raise self.fail(lineno, "arc offsets without an end point (X/Y/Z)")
            return
        self._move(lineno, coords)

    def _apply_words(self, lineno: int, words: list[tuple[str, str]]) -> _Block:
        """Apply the modal words of a block in order and collect the others."""
        coords: dict[str, float] = {}
        dwell = False
        dwell_s = 0.0
        for letter, number in words:
            letter = letter.upper()
            value = float(number)
            if letter == "G":
                if value in (0.0, 1.0, 2.0, 3.0):
                    self.motion = value
                elif value == 4.0:
                    dwell = True
                elif value in (20.0, 21.0):
                    self.scale = 25.4 if value == 20.0 else 1.0
                elif value in (90.0, 91.0):
                    self.absolute = value == 90.0
                elif value not in _IGNORED_G:
                    raise self.fail(
                        lineno,
                        f"G{number} is not supported (supported: G0 G1 G2 G3 G4 G17 G20 G21 G90 G91; "
                        "arcs only in the XY plane, no cutter compensation)",
                    )
            elif letter in "XYZIJR":
                coords[letter] = value
            elif letter == "F":
                if not value > 0:
                    raise self.fail(lineno, f"feed F{number} must be > 0 (units per minute)")
                self.feed_mm_s = value * self.scale / 60.0
            elif letter == "P":
                dwell_s = value
            elif letter not in "NMST":
                raise self.fail(lineno, f"word {letter}{number} is not supported (expected G, M, N, X, Y, Z, I, J, R, F, P, S, T)")
        return _Block(coords, dwell, dwell_s)

    def _move(self, lineno: int, coords: dict[str, float]) -> None:
        """Append the samples and durations of a G0/G1 line or a G2/G3 arc to the block's end point."""
        motion = self.motion
        if motion is None:
            raise self.fail(lineno, "coordinates before any motion mode (G0/G1/G2/G3)")
        pos = self.pos
        target = list(pos)
        for i, a in enumerate(_AXES):
            if a in coords:
                target[i] = coords[a] * self.scale + (pos[i] if not self.absolute else 0.0)
        speed = self.rapid_mm_s if motion == 0.0 else self.feed_mm_s
        if speed is None:
            raise self.fail(lineno, f"G{motion:g} move without a feed rate: set F (units per minute) first")
        if motion in (2.0, 3.0):
            start, end = np.array(pos), np.array(target)
            chunk = self._arc_chunk(lineno, motion, coords, start, end)
            prev = np.vstack([start[None, :], chunk[:-1]])
            self.points.extend(chunk.tolist())
            self.durations.extend((np.linalg.norm(chunk - prev, axis=1) / speed).tolist())
        else:  # the controller interpolates a line: steps no longer than the spacing (the first starts unknown)
            length = math.dist(pos, target)
            pieces = 1 if len(self.points) == 1 else max(1, math.ceil(length / self.spacing_mm - 1e-9))
            for k in range(1, pieces):
                self.points.append([a + (b - a) * k / pieces for a, b in zip(pos, target, strict=True)])
            self.points.append(target)
            self.durations.extend([length / pieces / speed] * pieces)
        self.pos = target

    def _arc_chunk(
        self, lineno: int, motion: float, coords: dict[str, float], start: np.ndarray, end: np.ndarray
    ) -> np.ndarray:
        """Chord end points (k, 3) [mm] of a G2/G3 arc, its centre from I/J or R, its radii checked."""
        scale = self.scale
        if "R" in coords:
            centre = _centre_from_radius(start, end, coords["R"] * scale, motion == 2.0)
            if centre is None:
                raise self.fail(lineno, f"arc radius R{coords['R']:g} is shorter than half the chord")
        elif "I" in coords or "J" in coords:
            centre = start[:2] + scale * np.array([coords.get("I", 0.0), coords.get("J", 0.0)])
        else:
            raise self.fail(lineno, f"G{motion:g} arc needs I/J (centre offset) or R (radius)")
        r_start = float(np.hypot(*(start[:2] - centre)))
        r_end = float(np.hypot(*(end[:2] - centre)))
        if r_start < 1e-9 or abs(r_start - r_end) > max(1e-3, 1e-4 * r_start):
            raise self.fail(lineno, f"arc start and end radii differ: {r_start:.6g} vs {r_end:.6g} mm")
        return _arc_points(start, end, centre, motion == 2.0, self.spacing_mm, self.tol_mm)

    def tool_path(self) -> ToolPath:
        """The samples read as a path in SI units, from the end of the first move at t = 0."""
        points, durations = self.points, self.durations
        if len(points) < 3:
            raise DataFileError(self.source, f"{len(points) - 1} move(s): a tool path needs at least 2 moves")
        p_mm = np.asarray(points[1:])  # the position before the first move is unknown: the path starts at its end
        dt = np.asarray(durations[1:])
        dt[0] = 0.0
        keep = np.concatenate(([True], dt[1:] > 0.0))  # zero-length moves add no sample (time stays increasing)
        p_mm, t_s = p_mm[keep], np.cumsum(dt)[keep]
        return ToolPath(
            t_s=t_s, p_sheet_m=p_mm * 1e-3, pass_index=np.ones(len(t_s), dtype=int), direction=np.ones(len(t_s), dtype=int)
        )


def parse_gcode(
    text: str,
    *,
    source: str | Path = "<gcode>",
    spacing_m: float = 0.5e-3,
    chord_tol_m: float = 1e-5,
    rapid_m_per_s: float = 0.1,
) -> ToolPath:
    """Parse G-code text into a sampled tool-tip path (subset in the module docstring).

    Args:
        text: The program.
        source: File name used in error messages.
        spacing_m: Largest step of the sampled path [m]: the chords of an arc, the pieces of a line.
        chord_tol_m: Largest distance between an arc and its chords [m].
        rapid_m_per_s: Speed of G0 moves [m/s].

    Returns:
        The path in SI units, time from 0 (feed and rapid speeds, dwells).

    Raises:
        DataFileError: A block the subset does not cover, a feed move without F, a bad arc; the message
            names the file and the 1-based line.
    """
    for name, value in (("spacing_m", spacing_m), ("chord_tol_m", chord_tol_m), ("rapid_m_per_s", rapid_m_per_s)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{name} = {value!r}: expected a finite number > 0")
    reader = _BlockReader(source, spacing_m * 1e3, chord_tol_m * 1e3, rapid_m_per_s * 1e3)
    for lineno, raw in enumerate(text.splitlines(), start=1):
        reader.read(lineno, raw)
    return reader.tool_path()


def _centre_from_radius(start: np.ndarray, end: np.ndarray, radius: float, clockwise: bool) -> np.ndarray | None:
    """Centre of the XY arc of signed radius R (R < 0: the long way round) from start to end, or None [mm]."""
    chord = end[:2] - start[:2]
    d = float(np.hypot(*chord))
    if d < 1e-12 or abs(radius) < d / 2.0 - 1e-9:
        return None
    h = math.sqrt(max(0.0, radius * radius - d * d / 4.0))
    normal = np.array([-chord[1], chord[0]]) / d  # left of the chord
    side = (-1.0 if clockwise else 1.0) * (1.0 if radius > 0 else -1.0)
    return np.asarray(start[:2] + chord / 2.0 + side * h * normal)


def read_gcode(file: str | Path, **kwargs: float) -> ToolPath:
    """Read a G-code file (see `parse_gcode` for the subset and the keyword arguments).

    Raises:
        DataFileError: Missing or unreadable file, or a block outside the subset (names the line).
    """
    path = Path(file)
    return parse_gcode(read_text(path, "a G-code program"), source=path, **kwargs)


def write_gcode(path: ToolPath, file: str | Path, *, comment: str = "tx200-twin tool path") -> Path:
    """Write a path as G1 moves in millimetres (G21 G90), feeds from the path's sample times (atomic).

    Args:
        path: The tool-tip path, sheet frame.
        file: Output file (never an input: the caller chooses a new name).
        comment: Text of the header comment.
    """
    p_mm = path.p_sheet_m * 1e3
    steps = np.linalg.norm(np.diff(p_mm, axis=0), axis=1)
    dt = np.diff(path.t_s)
    feed = np.where(dt > 0, steps / np.where(dt > 0, dt, 1.0) * 60.0, 0.0)
    lines = [f"({comment.replace('(', '[').replace(')', ']')})", "G21 G90 G17",
             f"G0 X{p_mm[0, 0]:.4f} Y{p_mm[0, 1]:.4f} Z{p_mm[0, 2]:.4f}"]
    last_f = None
    for (x, y, z), f in zip(p_mm[1:], feed, strict=True):
        f_txt = f"{f:.2f}"
        word = f" F{f_txt}" if f_txt != last_f and f > 0 else ""
        last_f = f_txt if word else last_f
        lines.append(f"G1 X{x:.4f} Y{y:.4f} Z{z:.4f}{word}")
    lines.append("M30")
    return write_text(file, "\n".join(lines) + "\n")
