"""Writing a `tx200-twin-run/1` run directory atomically, never over an input.

The input-protection rule: the target directory may not be, or hold, any protected input path (the run's own
`directory` is always protected); an existing non-empty target is replaced only with `overwrite`, and only
after the new directory has been written beside it and read back with `read_run`.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import swap_in_directory, temporary_folder, write_table
from twin.base.jsonio import write_json
from twin.errors import DataFileError, InputError
from twin.process.toolpath.groove import ToolPath
from twin.runs.format import RUN_FORMAT, RUN_FRAME, Run, Stream
from twin.runs.read import read_run


def _protected_by(target: Path, protect: Sequence[str | Path]) -> Path | None:
    for other in protect:
        other_path = Path(other).resolve()
        if other_path == target or other_path.is_relative_to(target):
            return Path(other)
    return None


def _checked_target(
    directory: str | Path, run: Run, protect: Sequence[str | Path], overwrite: bool
) -> Path:
    """The resolved target directory, checked to hold no protected input and to be free (or replaceable).

    Raises:
        InputError: The target holds a protected input (or `run.directory`), is a file, or is a non-empty
            directory without `overwrite`.
    """
    target = Path(directory).resolve()
    guarded = [*protect, *([run.directory] if run.directory is not None else [])]
    hit = _protected_by(target, guarded)
    if hit is not None:
        raise InputError(
            f"refusing to write run into {target}: it holds the input {hit}; choose another directory"
        )
    if target.exists() and not target.is_dir():
        raise InputError(f"{target} exists and is not a directory; choose another run directory")
    if target.exists() and any(target.iterdir()) and not overwrite:
        raise InputError(f"{target} exists and is not empty; pass overwrite=True or choose another directory")
    return target


def _checked_meta(run: Run) -> dict[str, Any]:
    """The run's meta.json contents with `format` and `frame` filled in; InputError if it holds `truth`."""
    meta = {"format": RUN_FORMAT, "frame": RUN_FRAME, **run.meta}
    if "truth" in meta:
        raise InputError(
            "meta must not hold 'truth': pass it as write_run(..., truth=...) (written to truth.json)"
        )
    return meta


#: Where a run keeps the copy of a user's robot description (`_with_robot_copy`), relative to the run.
ROBOT_COPY = "robot/robot.toml"
#: The lab's true tool tip beside the run (`write_run`'s `truth_tip`; like truth.json, no reader of runs opens it).
TRUTH_TIP = "truth_tip.csv"
_FILE_KEY = re.compile(r'^(mjcf|scene)\s*=\s*"[^"]*"', re.MULTILINE)


def _with_robot_copy(tmp: Path, meta: Mapping[str, Any]) -> Mapping[str, Any]:
    """A run made with a user's robot (its meta's `robot` a description file, not a shipped name) carries a copy of
    that description and its MJCF (and scene) in `robot/`, and names the copy: the run replays on any machine, and
    after the twin's temporary folder of generated descriptions is cleaned. Meshes the MJCF names stay where its
    `meshdir` points."""
    name = meta.get("robot")
    if not isinstance(name, str) or not Path(name).suffix or not Path(name).is_file():
        return meta
    from twin.robot.description import load_robot

    robot = load_robot(name)
    folder = tmp / Path(ROBOT_COPY).parent
    folder.mkdir(exist_ok=True)
    shutil.copyfile(robot.mjcf, folder / "robot.xml")
    local = {"mjcf": "robot.xml"}
    if robot.scene is not None and robot.scene != robot.mjcf:
        shutil.copyfile(robot.scene, folder / "scene.xml")
        local["scene"] = "scene.xml"
    text = Path(name).read_text(encoding="utf-8-sig")
    text = _FILE_KEY.sub(lambda m: f'{m.group(1)} = "{local.get(m.group(1), "robot.xml")}"', text)
    (tmp / ROBOT_COPY).write_text(text + f"\n# copied by tx200-twin from {json.dumps(name)}\n", encoding="utf-8")
    return {**meta, "robot": ROBOT_COPY}


def _write_files(tmp: Path, run: Run, meta: Mapping[str, Any], truth: Mapping[str, Any] | None) -> None:
    """Write the run's files into `tmp`: positions in mm (4 decimals), forces in N (3), times in s (6).

    Args:
        tmp: The new run directory, not yet in place.
        run: The run (SI units, sheet frame).
        meta: Contents of meta.json.
        truth: Lab-only hidden truth for truth.json, or None.
    """
    write_json(tmp / "meta.json", _with_robot_copy(tmp, meta))
    for name, stream in (("commanded.csv", run.commanded), ("tracker.csv", run.tracker)):
        write_path_csv(stream, tmp / name)
    if run.forces is not None:
        f = run.forces.values
        write_table(
            tmp / "forces.csv",
            {"t_s": run.forces.t_s, "fx_n": f[:, 0], "fy_n": f[:, 1], "fz_n": f[:, 2]},
            formats={"t_s": ".6f", "fx_n": ".3f", "fy_n": ".3f", "fz_n": ".3f"},
        )
    if run.part_profile is not None:
        x_m, z_m = run.part_profile
        write_table(
            tmp / "part_profile.csv",
            {"x_mm": np.asarray(x_m) * 1e3, "z_mm": np.asarray(z_m) * 1e3},
            formats={"x_mm": ".4f", "z_mm": ".4f"},
        )
    if run.part_scan is not None:
        mm = np.asarray(run.part_scan) * 1e3
        write_table(
            tmp / "part_scan.csv",
            {"x_mm": mm[:, 0], "y_mm": mm[:, 1], "z_mm": mm[:, 2]},
            formats={"x_mm": ".3f", "y_mm": ".3f", "z_mm": ".4f"},
        )
    if truth is not None:
        write_json(tmp / "truth.json", truth)


def _read_back(tmp: Path, run: Run) -> None:
    """Read the written directory back with `read_run`; InputError naming the file and row if rejected."""
    try:
        read_run(tmp, require_forces=run.forces is not None)
    except DataFileError as exc:
        raise InputError(
            f"run does not satisfy {RUN_FORMAT}: {str(exc).replace(str(tmp) + os.sep, '')}"
        ) from None


def write_run(
    directory: str | Path,
    run: Run,
    *,
    truth: Mapping[str, Any] | None = None,
    truth_tip: Stream | None = None,
    overwrite: bool = False,
    protect: Sequence[str | Path] = (),
) -> Path:
    """Write a run directory atomically (temporary sibling directory, validated, then renamed into place).

    Positions are written in mm with 4 decimals, forces in N with 3, times in s with 6. The written
    directory is read back with `read_run` before it replaces anything, so the writer never produces a
    run the reader rejects.

    Args:
        directory: Target run directory.
        run: The run (SI units). Missing `format`/`frame` keys in `run.meta` are filled in.
        truth: Lab-only hidden truth, written to truth.json when given.
        truth_tip: Lab-only, the plant's true tool tip (sheet frame), written to truth_tip.csv when given: what an
            experiment scores a result on beside the tracker (no reader of runs opens it).
        overwrite: Replace an existing non-empty directory.
        protect: Input paths that must not be inside (or be) the target; `run.directory` is always protected.

    Returns:
        The directory written.

    Raises:
        InputError: Target exists and is non-empty without `overwrite`, target holds a protected input,
            or the run does not satisfy the format (message names the file and row).
    """
    target = _checked_target(directory, run, protect, overwrite)
    meta = _checked_meta(run)
    tmp = temporary_folder(target)
    try:
        _write_files(tmp, run, meta, truth)
        if truth_tip is not None:
            write_path_csv(truth_tip, tmp / TRUTH_TIP)
        _read_back(tmp, run)
        swap_in_directory(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return target


#: The one precision of every path CSV (a run's commanded and tracker files, ideal and compensated paths): 1 µs
#: and 0.1 µm, below any tracker's noise and any controller's resolution.
PATH_FORMATS = {"t_s": ".6f", "x_mm": ".4f", "y_mm": ".4f", "z_mm": ".4f"}


def write_path_csv(path: ToolPath | Stream, file: str | Path, *, protect: Sequence[str | Path] = ()) -> Path:
    """Write a tool path as CSV `t_s, x_mm, y_mm, z_mm` (sheet frame; a `ToolPath` adds its `pass` and
    `direction` labels), atomically, never over `protect`. The one writer of the format
    `twin.runs.read.read_commanded_csv` reads (`--ideal`, `--commanded`, a run's commanded.csv and tracker.csv).

    Returns:
        The file written.
    """
    p_mm = 1e3 * np.asarray(path.p_sheet_m if isinstance(path, ToolPath) else path.values, dtype=float)
    columns: dict[str, Any] = {"t_s": path.t_s, "x_mm": p_mm[:, 0], "y_mm": p_mm[:, 1], "z_mm": p_mm[:, 2]}
    if isinstance(path, ToolPath):
        columns.update(pass_=np.asarray(path.pass_index, dtype=int), direction=np.asarray(path.direction, dtype=int))
        columns["pass"] = columns.pop("pass_")
    return write_table(file, columns, formats=PATH_FORMATS, protect=protect)
