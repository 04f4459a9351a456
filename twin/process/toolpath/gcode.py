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
* subprograms: `M98 P<n> [L<k>]` runs the file's subprogram `O<n>` k times (1..9999), nested up to
  `MAX_CALL_DEPTH`; a call of a program the file does not hold is refused (`gcode_programs` splits the file);
* understood without effect on the path: G17 (XY plane), G40, G49, G54, G80, G94, M0/M1 (stops), M3/M4/M5 (tool
  rotation), M6 (tool change), M7/M8/M9 (lubrication), N, S, T words, comments in parentheses or after `;`, `%` lines.
  Every other word is refused by name with a `DataFileError` naming the file and line, never dropped: G18/G19 arcs,
  cutter compensation G41/G42, other G and M codes, unknown letters, P outside G4/M98, L outside M98, I/J/R outside
  G2/G3, a word given twice in a block, axes in a G4 block.

Coordinates are the tool tip in the sheet frame; axes not yet set are 0. The path starts (t = 0) at the end of the
first move (where the tool was before it is unknown); zero-length moves add no sample. `pass_index` is 1 and
`direction` +1 throughout: G-code carries no pass structure (`groove.label_passes` infers it for groove-like paths).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from twin.base.csvio import read_text
from twin.errors import DataFileError, InputError
from twin.process.toolpath import gcode_programs as programs_
from twin.process.toolpath.gcode_arcs import arc_points, centre_from_radius
from twin.process.toolpath.groove import ToolPath, check_samples

_IGNORED_G = {17.0, 40.0, 49.0, 54.0, 80.0, 94.0}
#: M codes that change nothing on the path: stops, tool rotation, tool change, lubrication.
_IGNORED_M = {0.0, 1.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0}
_END_M = {2.0, 30.0}
_M_KNOWN = "M0 M1 M2 M3 M4 M5 M6 M7 M8 M9 M30 M98 M99"
_AXES = "XYZ"


class _Block(NamedTuple):
    """The non-modal words of one block: axis and arc words [program units], a G4 dwell [s], and its program
    control: None, "end" (M2/M30), "return" (M99) or ("call", program number, repeats) (M98)."""

    coords: dict[str, float]
    dwell: bool
    dwell_s: float
    control: str | tuple[str, int, int] | None = None


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
        self.where = ""  # the subprogram calls that reached the current block, for messages

    def fail(self, lineno: int, message: str) -> DataFileError:
        """The error for a block, naming the file, the 1-based line and the subprogram calls that reached it."""
        return DataFileError(self.source, f"line {lineno}{self.where}: {message}")

    def read(self, lineno: int, raw: str) -> str | tuple[str, int, int] | None:
        """Read one line: a dwell, a move, modal words only, or nothing (blank, comment, `%`); return its program
        control (`_Block.control`), applied after its motion."""
        line = programs_.COMMENT.sub(" ", raw).strip()
        if not line or line.startswith("%"):
            return None
        words = programs_.WORD.findall(line)
        leftover = programs_.WORD.sub("", line).strip()
        if leftover:
            raise self.fail(lineno, f"cannot read {leftover!r} in {raw.strip()!r} (expected words like G1 X10 F600)")
        block = self._apply_words(lineno, words)
        coords = block.coords
        if block.dwell:
            if any(a in coords for a in "XYZIJR"):
                raise self.fail(lineno, f"G4 dwell with {'/'.join(a for a in 'XYZIJR' if a in coords)} in the same "
                                "block: expected G4 P<seconds> alone (a dwell X word is not read as seconds)")
            if not block.dwell_s >= 0:
                raise self.fail(lineno, f"G4 dwell P{block.dwell_s} must be >= 0 s")
            self.points.append(list(self.pos))
            self.durations.append(block.dwell_s)
            return block.control
        arc = [a for a in "IJR" if a in coords]
        if arc and self.motion not in (2.0, 3.0):
            mode = "no motion mode" if self.motion is None else f"G{self.motion:g}"
            raise self.fail(lineno, f"{'/'.join(arc)} (arc centre or radius) with {mode}: expected G2/G3")
        if not any(a in coords for a in _AXES):
            if arc:
                raise self.fail(lineno, "arc offsets without an end point (X/Y/Z)")
            return block.control
        self._move(lineno, coords)
        return block.control

    def run(self, lines: programs_.Lines, programs: dict[int, programs_.Lines], called: tuple[tuple[int, int], ...] = ()) -> None:
        """Run a program's lines: the main program (`called` empty) to its end (M2/M30), a subprogram to its M99;
        an M98 call runs the called subprogram in place."""
        for k, (lineno, raw) in enumerate(lines):
            self.where = "".join(f" (in O{n} called from line {at})" for n, at in reversed(called))
            control = self.read(lineno, raw)
            if control is None:
                continue
            if control == "return":
                if not called:
                    raise self.fail(lineno, "M99 (subprogram return) in the main program: expected M30 to end it")
                return
            if control == "end":
                if called:
                    raise self.fail(lineno, f"M{'30' if 'M30' in raw.upper() else '2'} (program end) inside "
                                    f"subprogram O{called[-1][0]}: expected M99")
                for later, text in lines[k + 1:]:
                    if programs_.COMMENT.sub(" ", text).strip().lstrip("%").strip():
                        raise self.fail(later, f"block {text.strip()!r} after the program end on line {lineno}: "
                                        "expected only subprograms (O<n> ... M99) after M2/M30")
                return
            if not isinstance(control, tuple):
                continue
            _, number, repeats = control
            if number not in programs:
                raise self.fail(lineno, f"M98 P{number} calls subprogram O{number}, which this file does not hold "
                                f"(expected O{number} ... M99 in the same file; it holds "
                                f"{', '.join(f'O{n}' for n in programs) or 'no subprogram'})")
            if len(called) >= programs_.MAX_CALL_DEPTH or any(n == number for n, _ in called):
                raise self.fail(lineno, f"M98 P{number}: subprogram calls nested deeper than {programs_.MAX_CALL_DEPTH} or "
                                "recursive (a subprogram calling itself)")
            for _ in range(repeats):
                self.run(programs[number], programs, (*called, (number, lineno)))
            self.where = "".join(f" (in O{n} called from line {at})" for n, at in reversed(called))
        if called:
            raise self.fail(lines[-1][0] if lines else 0, f"subprogram O{called[-1][0]} has no M99")

    def _apply_words(self, lineno: int, words: list[tuple[str, str]]) -> _Block:
        """Apply the modal words of a block in order and collect the others; refuse any word not understood."""
        coords: dict[str, float] = {}
        dwell = False
        dwell_s: float | None = None
        control: str | tuple[str, int, int] | None = None
        call = False
        repeats: float | None = None
        seen: set[str] = set()
        for letter, number in words:
            letter = letter.upper()
            value = float(number)
            if letter in "XYZIJRFPLNST":
                if letter in seen:
                    raise self.fail(lineno, f"{letter} given twice in one block ({letter}{number}): expected one")
                seen.add(letter)
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
            elif letter == "M":
                if value in _END_M or value == 99.0 or value == 98.0:
                    if control is not None or call:
                        raise self.fail(lineno, f"M{number} with another program control (M2 M30 M98 M99) in the "
                                        "same block: expected one")
                    call = value == 98.0
                    control = None if call else ("end" if value in _END_M else "return")
                elif value not in _IGNORED_M:
                    raise self.fail(lineno, f"M{number} is not supported (understood: {_M_KNOWN})")
            elif letter in "XYZIJR":
                coords[letter] = value
            elif letter == "F":
                if not value > 0:
                    raise self.fail(lineno, f"feed F{number} must be > 0 (units per minute)")
                self.feed_mm_s = value * self.scale / 60.0
            elif letter == "P":
                dwell_s = value
            elif letter == "L":
                repeats = value
            elif letter == "O":
                raise self.fail(lineno, f"program number O{number} inside a block: expected O<n> alone on its line "
                                "(the start of a subprogram)")
            elif letter not in "NST":
                raise self.fail(lineno, f"word {letter}{number} is not supported (expected G, M, N, X, Y, Z, I, J, R, "
                                "F, P, L, S, T)")
        if dwell and call:
            raise self.fail(lineno, "G4 and M98 in one block: expected each in its own block (P is either's)")
        if call:
            control = self._call(lineno, dwell_s, repeats)
        elif dwell_s is not None and not dwell:
            raise self.fail(lineno, f"P{dwell_s:g} without G4 (dwell) or M98 (subprogram call): expected one of them")
        if repeats is not None and not call:
            raise self.fail(lineno, f"L{repeats:g} without M98: L is the repeat count of a subprogram call")
        return _Block(coords, dwell, 0.0 if dwell_s is None else dwell_s, control)

    def _call(self, lineno: int, program: float | None, repeats: float | None) -> tuple[str, int, int]:
        """The control of an `M98 P<n> [L<k>]` block, its program number and repeat count checked."""
        if program is None or program != int(program) or program < 0:
            raise self.fail(lineno, f"M98 {'without P' if program is None else f'P{program:g}'}: expected "
                            "M98 P<n> (n the subprogram's number, an integer >= 0)")
        count = 1.0 if repeats is None else repeats
        if count != int(count) or not 1 <= count <= programs_.MAX_REPEATS:
            raise self.fail(lineno, f"M98 P{int(program)} L{count:g}: expected a repeat count L in 1..{programs_.MAX_REPEATS}")
        return ("call", int(program), int(count))

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
            check_samples(len(self.points) + len(chunk), self.spacing_mm / 1e3)
            prev = np.vstack([start[None, :], chunk[:-1]])
            self.points.extend(chunk.tolist())
            self.durations.extend((np.linalg.norm(chunk - prev, axis=1) / speed).tolist())
        else:  # the controller interpolates a line: steps no longer than the spacing (the first starts unknown)
            length = math.dist(pos, target)
            check_samples(len(self.points) + length / self.spacing_mm, self.spacing_mm / 1e3)
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
            centre = centre_from_radius(start, end, coords["R"] * scale, motion == 2.0)
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
        return arc_points(start, end, centre, motion == 2.0, self.spacing_mm, self.tol_mm)

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
        DataFileError: A block the subset does not cover (a word named), a feed move without F, a bad arc, a call
            of a subprogram the file does not hold; the message names the file and the 1-based line.
    """
    for name, value in (("spacing_m", spacing_m), ("chord_tol_m", chord_tol_m), ("rapid_m_per_s", rapid_m_per_s)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{name} = {value!r}: expected a finite number > 0")
    reader = _BlockReader(source, spacing_m * 1e3, chord_tol_m * 1e3, rapid_m_per_s * 1e3)
    main, programs = programs_.split_programs(text, source)
    reader.run(main, programs)
    return reader.tool_path()


def read_gcode(file: str | Path, **kwargs: float) -> ToolPath:
    """Read a G-code file (see `parse_gcode` for the subset and the keyword arguments).

    Raises:
        DataFileError: Missing or unreadable file, or a block outside the subset (names the line).
    """
    path = Path(file)
    return parse_gcode(read_text(path, "a G-code program"), source=path, **kwargs)
