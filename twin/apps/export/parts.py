"""Splitting a program by its controller's size limit: numbered parts, in order, that a main program calls.

A part holds at most the format's limit of points (`LIMITS`, or `ProgramPath.max_points`); the first part starts
with the joint move to the approach point, the others continue linearly from where the previous part ended
(`ProgramPath.joint_start` False), each with its own points and feeds. Parts are named `NAME_1`, `NAME_2`, ...
(the base name shortened so that the longest part name keeps `program.MAX_NAME` characters).

The limits are those of the open post-processors, read as points per file (our programs write one point per line
of data and walk it with a loop, where the posts write one move per line): RoboDK's `KUKA_KRC4.py` starts a new
program file after `MAX_LINES_X_PROG = 1400` lines, its `ABB_RAPID_IRC5.py` a new module after 5000
(github.com/ros-industrial-attic/robodk_postprocessors, 08ec3d3 and 05c5ca8), each called in order by a main
program (`NAMEMain` there, `NAME` here). VAL3 and the G-code and CSV outputs are not split: the VAL3 application
is data walked by a loop in one program (RoboDK's `Staubli_VAL3.py` pages of 200 moves are code lines, which we
do not write), and a G-code or CSV file has no controller limit of its own.
"""

from __future__ import annotations

from dataclasses import replace

from twin.apps.export.program import MAX_NAME, ProgramPath
from twin.errors import InputError

#: Points per file / module before a program is split (module docstring for the sources).
LIMITS = {"krl": 1400, "rapid": 5000}


def parts(path: ProgramPath, fmt: str) -> list[ProgramPath]:
    """The program in parts of at most the limit's points each; [path] when it fits.

    Args:
        path: The program (approach, path, retract).
        fmt: The format (`krl`, `rapid`), for its limit when `path.max_points` is 0.

    Raises:
        InputError: A limit below 2 points (names `--max-points`).
    """
    limit = path.max_points or LIMITS[fmt]
    if limit < 2:
        raise InputError(f"--max-points {limit}: expected at least 2 points per file")
    n = len(path.points_mm)
    if n <= limit:
        return [path]
    count = -(-n // limit)
    base = path.name[: MAX_NAME - len(f"_{count}")]
    out = []
    for k, start in enumerate(range(0, n, limit), start=1):
        stop = min(start + limit, n)
        configs = path.configurations[start:stop]
        out.append(
            replace(
                path,
                name=f"{base}_{k}",
                points_mm=path.points_mm[start:stop],
                feed_mm_s=path.feed_mm_s[start:stop],
                configurations=configs,
                cell=replace(path.cell, configuration=configs[0] if configs else None),
                joint_start=k == 1,
            )
        )
    return out
