"""A held-out set of changes on the dynamic plant (issue #47): the cell learned once, then something changes.

For each cell (a robot and a part) the test learns the cell from two clean runs of the dynamic plant (`learn RUN1
RUN2 --write-model cell.json`, which records the floor the learned cell leaves on its own runs), then hides one
change in a third run and a fourth (the next run, with the same change), asks `discrepancy RUN3 --model
cell.json --model-out M.json` what changed, and replays the next run with the cell and with M. A case is right
when the change is named right and the next run's excess over the floor shrinks by at least half.

Every change is written here, never through the library's effects or families:
* data-level edits of the plant's clean runs (a re-tared, re-mounted, re-calibrated or re-clocked F/T sensor; a
  re-registered, drifting or re-clocked tracker), each in this module's own form (a finite rotation, a resampled
  clock);
* plant variants this module builds with the plant's knobs (`--set`), which the twin never reads: a gear's lost
  motion; or a program executed off by a move of the robot on its base, the run's command left as written; or
  the plant's sheet clamped in a frame that gives (`_GivingFrame`, this module's own lagged spring).

The thresholds are the issue's (named right, the held-out excess over the floor at most half), fixed before any
run. Seven sets: `development` (a TX200 groove and a KR210 cone, and an IRB 6640 pyramid and a TX200 cone with
other forms and sizes: the first held-out set, run once at 8 / 20, then developed on; the library was changed while
looking at them), `held-out` (an IRB 6640 cone and a KR210 pyramid, other forms and sizes again: written before
any of its runs, run once; run again with the library `held-out-2` was written for) and `held-out-2` (a KR210 groove and a
TX200 pyramid, written before any of its runs, run once; then again after a fix) and `held-out-3` (an IRB 6640
groove and a TX200 variable-wall-angle cone, written before any of its runs, run once), `held-out-4` and `held-out-5`
(a clamping frame that gives on four cells, written before any of its runs, run once) and `held-out-6` (the frame
on six other cells, written before any of its runs after the part scan's judge, run once). `python -m tests.plant_changes --set held-out --out
changes.json` runs a set, `--set both --jobs 2` all of them two at a time (`make test-slow` checks all, a set per
core).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import multiprocessing
import re
import shutil
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.discrepancy.families import learns_from_run
from twin.analysis.discrepancy.floor import OBSERVABLE_SHARE, Floor, excess_by_stream
from twin.analysis.discrepancy.residuals import ResidualModel
from twin.cli import main
from twin.runs.format import Run, Stream
from twin.runs.read import read_run
from twin.runs.write import write_run
from twin.sim.model_file import read_floor_entry, read_model_file

#: The issue's bar: the next run's excess over the floor with the model found at most this share of the cell's.
SHRINK_TO = 0.5
CLEAN_SEEDS = (1, 2)
CHANGED_SEED, NEXT_SEED = 3, 4


@dataclass(frozen=True)
class Cell:
    """A robot forming a part: `path_args` for `tx200-twin path` (empty: the groove)."""

    robot: str
    part: str
    path_args: tuple[str, ...] = ()


CELLS = {
    "tx200-groove": Cell("tx200", "groove"),
    "kr210-cone": Cell("kr210", "cone", ("--shape", "cone", "--depth-mm", "4")),
    "irb6640-pyramid": Cell("irb6640", "pyramid", ("--shape", "pyramid", "--depth-mm", "4")),
    "tx200-cone": Cell("tx200", "cone", ("--shape", "cone", "--depth-mm", "3")),
    # held out: written before any of its runs, run once with the library as it is committed with it
    "irb6640-cone": Cell("irb6640", "cone", ("--shape", "cone", "--depth-mm", "5")),
    "kr210-pyramid": Cell("kr210", "pyramid", ("--shape", "pyramid", "--depth-mm", "4")),
    # the second held-out set: written before any of its runs, run once
    "kr210-groove": Cell("kr210", "groove"),
    "tx200-pyramid": Cell("tx200", "pyramid", ("--shape", "pyramid", "--depth-mm", "5")),
    # the third held-out set: written before any of its runs (after the floor's structure slack), run once
    "irb6640-groove": Cell("irb6640", "groove", ("--passes", "8", "--depth-mm", "8", "--top-length-mm", "60",
                                                 "--bottom-length-mm", "52")),
    "tx200-vwa-cone": Cell("tx200", "vwa-cone", ("--shape", "vwa-cone", "--depth-mm", "4", "--top-width-mm", "90",
                                                 "--mode", "z-level")),
    # the fourth held-out set: written before any of its runs (after the joint-compliance family), run once
    "irb6640-vwa-cone": Cell("irb6640", "vwa-cone", ("--shape", "vwa-cone", "--depth-mm", "5", "--top-width-mm", "100",
                                                     "--wall-angle-deg", "40", "--wall-angle-end-deg", "60")),
    "kr210-cone-wide": Cell("kr210", "cone", ("--shape", "cone", "--depth-mm", "5", "--top-width-mm", "100",
                                              "--wall-angle-deg", "35")),
}


def _rotation(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """This module's own finite rotation (Rodrigues), shape (3, 3)."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle_rad) * kx + (1.0 - np.cos(angle_rad)) * kx @ kx


def _reclocked(stream: Stream, t0: float, offset_s: float, rate: float) -> Stream:
    """The stream as a clock `offset_s` ahead and `rate` fast stamps it: the sample taken at t is stamped
    t + offset + rate (t - t0) (the values as measured, only their stamps changed)."""
    return Stream(stream.t_s + offset_s + rate * (stream.t_s - t0), stream.values)


def _forces(change: Callable[[Run], np.ndarray]) -> Callable[[Run], Run]:
    def edit(run: Run) -> Run:
        assert run.forces is not None
        return replace(run, forces=Stream(run.forces.t_s, change(run)))
    return edit


def _tracker(change: Callable[[Run], np.ndarray]) -> Callable[[Run], Run]:
    def edit(run: Run) -> Run:
        return replace(run, tracker=Stream(run.tracker.t_s, change(run)))
    return edit


R_MOUNT = _rotation(np.array([0.0, 0.0, 1.0]), np.deg2rad(4.0))
R_TRACKER = _rotation(np.array([0.3, -1.0, 0.5]), 1.5e-3)
DRIFT_M_PER_S = 1e-3 * 0.004 * np.array([0.8, -0.5, 0.3]) / np.linalg.norm([0.8, -0.5, 0.3])


@dataclass(frozen=True)
class Change:
    """One hidden change: a data edit of the clean runs (`edit`), plant knobs (`knobs`), or the robot moved on its
    base (`base_shift_mm`: the plant commanded that much off, the run's command unchanged); `expected`: the names
    that are right; `sheet`: plant flags for a sheet other than the cell's records (meta.json keeps the cell's);
    `learned`: with `unexplained`, what the learned twin must say first of its kind (a regular expression on the
    first learned sentence that starts with its first word: `joint 2 is`, the sheet pushing more);
    `frame_mm_per_kn`: the plant's sheet clamped in a frame that gives (`_GivingFrame`, this module's own)."""

    name: str
    expected: tuple[str, ...]
    edit: Callable[[Run], Run] | None = None
    knobs: tuple[str, ...] = ()
    base_shift_mm: tuple[float, float, float] | None = None
    what: str = ""
    sheet: tuple[str, ...] = ()
    learned: str = ""
    frame_mm_per_kn: float = 0.0


def _about(axis: tuple[float, float, float], angle_rad: float) -> np.ndarray:
    return _rotation(np.asarray(axis), angle_rad)


DEVELOPMENT = (
    Change("ft_retared", ("force_sensor_bias",), what="F/T re-tared: +40 N x, -30 N z",
           edit=_forces(lambda r: r.forces.values + np.array([40.0, 0.0, -30.0]))),  # type: ignore[union-attr]
    Change("ft_remounted", ("force_sensor_crosstalk",), what="F/T re-mounted turned 4 deg about z",
           edit=_forces(lambda r: r.forces.values @ R_MOUNT.T)),  # type: ignore[union-attr]
    Change("ft_recalibrated", ("force_sensor_gain",), what="F/T calibration x 1.06 on x, x 0.94 on z",
           edit=_forces(lambda r: r.forces.values * np.array([1.06, 1.0, 0.94]))),  # type: ignore[union-attr]
    Change("ft_clock", ("stream_time_offset",), what="F/T clock 40 ms ahead and 300 ppm fast",
           edit=lambda r: replace(r, forces=_reclocked(r.forces, r.commanded.t_s[0], 0.04, 3e-4))),  # type: ignore[arg-type]
    Change("tracker_reregistered", ("tracker_registration",),
           what="tracker re-registered: 1.5 mrad about (0.3, -1, 0.5), shift (0.25, -0.15, 0.10) mm",
           edit=_tracker(lambda r: r.tracker.values @ R_TRACKER.T + 1e-3 * np.array([0.25, -0.15, 0.10]))),
    Change("tracker_drift", ("tracker_drift",), what="tracker drifting 4 um/s along (0.8, -0.5, 0.3)",
           edit=_tracker(lambda r: r.tracker.values + np.outer(r.tracker.t_s - r.commanded.t_s[0], DRIFT_M_PER_S))),
    Change("tracker_clock", ("tracker_clock",), what="tracker clock 15 ms behind and 200 ppm fast",
           edit=lambda r: replace(r, tracker=_reclocked(r.tracker, r.commanded.t_s[0], -0.015, 2e-4))),
    Change("gear_play", ("lost_motion", "lost_motion_under_load"), what="joint 3's gear with 0.4 mrad of play (plant knob)",
           knobs=("backlash_j3_mrad=0.4",)),
    Change("robot_moved", ("tracker_registration",),
           what="the robot moved 1.5 mm on its base, in plane: every commanded point lands off on the sheet",
           base_shift_mm=(1.5, -1.0, 0.0)),
    Change("sheet_thicker", ("force_scale", "unexplained"),
           what="a new coil: the sheet 1.2 mm thick where the cell's records say 1.0 mm (plant process)",
           sheet=("--thickness-mm", "1.2"), learned=r"^the sheet pushes [\d.]+ N more"),
)

#: Added to the development set after the second held-out run (the slow tables only; `make test` keeps the
#: groove checks of `DEVELOPMENT`): a gear softer and a vertical axis's play on the development cells.
DEVELOPMENT_MORE = (
    Change("gear_softer_j3", ("joint_compliance", "unexplained"), what="joint 3's gear 40 % softer (plant knob)",
           knobs=("gear_stiffness_j3_scale=0.6",), learned="^joint 3 is"),
    Change("gear_play_j1", ("lost_motion", "lost_motion_under_load"), what="joint 1's gear with 0.5 mrad of play "
           "(plant knob)", knobs=("backlash_j1_mrad=0.5",)),
)
#: Other forms and sizes, on other cells; a gear made softer is learned (no family covers it) and named by the
#: learned robot's words. Written as a held-out set, run once (8 / 20 right), then used for development.
FIRST_HELD_OUT = (
    Change("ft_retared", ("force_sensor_bias",), what="F/T re-tared: -25 N x, +15 N y, +45 N z",
           edit=_forces(lambda r: r.forces.values + np.array([-25.0, 15.0, 45.0]))),  # type: ignore[union-attr]
    Change("ft_remounted", ("force_sensor_crosstalk",), what="F/T re-mounted turned 6 deg about z and 1 deg about x",
           edit=_forces(lambda r: r.forces.values @ (_about((0, 0, 1), np.deg2rad(6.0))  # type: ignore[union-attr]
                                                     @ _about((1, 0, 0), np.deg2rad(1.0))).T)),
    Change("ft_recalibrated", ("force_sensor_gain",), what="F/T calibration x 0.92 on every axis",
           edit=_forces(lambda r: 0.92 * r.forces.values)),  # type: ignore[union-attr]
    Change("ft_clock", ("stream_time_offset",), what="F/T clock 25 ms behind",
           edit=lambda r: replace(r, forces=_reclocked(r.forces, r.commanded.t_s[0], -0.025, 0.0))),  # type: ignore[arg-type]
    Change("tracker_reregistered", ("tracker_registration",),
           what="tracker re-registered: 2 mrad about (1, 0.2, 0), shift (-0.30, 0.20, 0.05) mm",
           edit=_tracker(lambda r: r.tracker.values @ _about((1.0, 0.2, 0.0), 2e-3).T
                         + 1e-3 * np.array([-0.30, 0.20, 0.05]))),
    Change("tracker_drift", ("tracker_drift",), what="tracker drifting 8 um/s along (-0.3, 0.9, 0.2)",
           edit=_tracker(lambda r: r.tracker.values + np.outer(
               r.tracker.t_s - r.commanded.t_s[0], 8e-6 * np.array([-0.3, 0.9, 0.2]) / np.linalg.norm([-0.3, 0.9, 0.2])))),
    Change("tracker_clock", ("tracker_clock",), what="tracker clock 10 ms ahead",
           edit=lambda r: replace(r, tracker=_reclocked(r.tracker, r.commanded.t_s[0], 0.010, 0.0))),
    Change("gear_play", ("lost_motion", "lost_motion_under_load"), what="joint 2's gear with 0.3 mrad of play (plant knob)",
           knobs=("backlash_j2_mrad=0.3",)),
    Change("gear_softer", ("joint_compliance", "unexplained"), what="joint 2's gear 30 % softer (plant knob)",
           knobs=("gear_stiffness_j2_scale=0.7",), learned="^joint 2 is"),
    Change("robot_moved", ("tracker_registration",), what="the robot moved on its base: (-1, 2, 0) mm in plane",
           base_shift_mm=(-1.0, 2.0, 0.0)),
)
#: The held-out set: other forms and sizes again, on two more cells; written before any of its runs.
HELD_OUT = (
    Change("ft_retared", ("force_sensor_bias",), what="F/T re-tared: +10 N x, -35 N y, +20 N z",
           edit=_forces(lambda r: r.forces.values + np.array([10.0, -35.0, 20.0]))),  # type: ignore[union-attr]
    Change("ft_remounted", ("force_sensor_crosstalk",), what="F/T re-mounted turned 8 deg about z",
           edit=_forces(lambda r: r.forces.values @ _about((0, 0, 1), np.deg2rad(8.0)).T)),  # type: ignore[union-attr]
    Change("ft_recalibrated", ("force_sensor_gain",), what="F/T calibration x 1.10 on z",
           edit=_forces(lambda r: r.forces.values * np.array([1.0, 1.0, 1.10]))),  # type: ignore[union-attr]
    Change("ft_clock", ("stream_time_offset",), what="F/T clock 60 ms ahead",
           edit=lambda r: replace(r, forces=_reclocked(r.forces, r.commanded.t_s[0], 0.060, 0.0))),  # type: ignore[arg-type]
    Change("tracker_reregistered", ("tracker_registration",),
           what="tracker re-registered: 3 mrad about (0, 1, 1), shift (0.10, 0.40, -0.20) mm",
           edit=_tracker(lambda r: r.tracker.values @ _about((0.0, 1.0, 1.0), 3e-3).T
                         + 1e-3 * np.array([0.10, 0.40, -0.20]))),
    Change("tracker_drift", ("tracker_drift",), what="tracker drifting 6 um/s along (0.2, 0.2, -0.95)",
           edit=_tracker(lambda r: r.tracker.values + np.outer(
               r.tracker.t_s - r.commanded.t_s[0], 6e-6 * np.array([0.2, 0.2, -0.95]) / np.linalg.norm([0.2, 0.2, -0.95])))),
    Change("tracker_clock", ("tracker_clock",), what="tracker clock 20 ms behind and 100 ppm fast",
           edit=lambda r: replace(r, tracker=_reclocked(r.tracker, r.commanded.t_s[0], -0.020, 1e-4))),
    Change("gear_play", ("lost_motion", "lost_motion_under_load"), what="joint 1's gear with 0.5 mrad of play (plant knob)",
           knobs=("backlash_j1_mrad=0.5",)),
    Change("gear_softer", ("joint_compliance", "unexplained"), what="joint 3's gear 40 % softer (plant knob)",
           knobs=("gear_stiffness_j3_scale=0.6",), learned="^joint 3 is"),
    Change("robot_moved", ("tracker_registration",), what="the robot moved on its base: (2, 0.5, 0) mm in plane",
           base_shift_mm=(2.0, 0.5, 0.0)),
)
#: The second held-out set (after the gear's flank took the links' inertia and each joint's own motion, and the
#: linearised sheet answered against the pass over the same place): other forms, sizes and cells again, a sheet
#: sensor re-mounted off-axis, a softer vertical axis; written before any of its runs.
HELD_OUT_2 = (
    Change("ft_retared", ("force_sensor_bias",), what="F/T re-tared: -30 N x, +20 N y, -40 N z",
           edit=_forces(lambda r: r.forces.values + np.array([-30.0, 20.0, -40.0]))),  # type: ignore[union-attr]
    Change("ft_remounted", ("force_sensor_crosstalk",), what="F/T re-mounted turned 5 deg about z and 2 deg about y",
           edit=_forces(lambda r: r.forces.values @ (_about((0, 0, 1), np.deg2rad(5.0))  # type: ignore[union-attr]
                                                     @ _about((0, 1, 0), np.deg2rad(2.0))).T)),
    Change("ft_recalibrated", ("force_sensor_gain",), what="F/T calibration x 1.08 on x and y, x 0.95 on z",
           edit=_forces(lambda r: r.forces.values * np.array([1.08, 1.08, 0.95]))),  # type: ignore[union-attr]
    Change("ft_clock", ("stream_time_offset",), what="F/T clock 50 ms behind and 200 ppm slow",
           edit=lambda r: replace(r, forces=_reclocked(r.forces, r.commanded.t_s[0], -0.050, -2e-4))),  # type: ignore[arg-type]
    Change("tracker_reregistered", ("tracker_registration",),
           what="tracker re-registered: 2.5 mrad about (1, -1, 0.3), shift (-0.20, -0.30, 0.15) mm",
           edit=_tracker(lambda r: r.tracker.values @ _about((1.0, -1.0, 0.3), 2.5e-3).T
                         + 1e-3 * np.array([-0.20, -0.30, 0.15]))),
    Change("tracker_drift", ("tracker_drift",), what="tracker drifting 5 um/s along (-0.6, -0.6, 0.5)",
           edit=_tracker(lambda r: r.tracker.values + np.outer(
               r.tracker.t_s - r.commanded.t_s[0], 5e-6 * np.array([-0.6, -0.6, 0.5]) / np.linalg.norm([-0.6, -0.6, 0.5])))),
    Change("tracker_clock", ("tracker_clock",), what="tracker clock 12 ms ahead and 150 ppm slow",
           edit=lambda r: replace(r, tracker=_reclocked(r.tracker, r.commanded.t_s[0], 0.012, -1.5e-4))),
    Change("gear_play", ("lost_motion", "lost_motion_under_load"), what="joint 2's gear with 0.4 mrad of play (plant knob)",
           knobs=("backlash_j2_mrad=0.4",)),
    Change("gear_softer", ("joint_compliance", "unexplained"), what="joint 1's gear 35 % softer (plant knob)",
           knobs=("gear_stiffness_j1_scale=0.65",), learned="^joint 1 is"),
    Change("robot_moved", ("tracker_registration",), what="the robot moved on its base: (-1.5, -1, 0) mm in plane",
           base_shift_mm=(-1.5, -1.0, 0.0)),
    Change("sheet_thicker", ("force_scale", "unexplained"),
           what="a new coil: the sheet 1.15 mm thick where the cell's records say 1.0 mm (plant process)",
           sheet=("--thickness-mm", "1.15"), learned=r"^the sheet pushes [\d.]+ N more"),
)
#: The third held-out set (after the consistency rule counted a clean run's structure above the floor with its slack):
#: another robot on the groove, shorter and with fewer passes, and a part no set has formed (a variable-wall-angle
#: cone, z-level); other forms and sizes again; written before any of its runs.
HELD_OUT_3 = (
    Change("ft_retared", ("force_sensor_bias",), what="F/T re-tared: +20 N x, +25 N y, -50 N z",
           edit=_forces(lambda r: r.forces.values + np.array([20.0, 25.0, -50.0]))),  # type: ignore[union-attr]
    Change("ft_remounted", ("force_sensor_crosstalk",), what="F/T re-mounted turned 7 deg about z and 1.5 deg about x",
           edit=_forces(lambda r: r.forces.values @ (_about((0, 0, 1), np.deg2rad(7.0))  # type: ignore[union-attr]
                                                     @ _about((1, 0, 0), np.deg2rad(1.5))).T)),
    Change("ft_recalibrated", ("force_sensor_gain",), what="F/T calibration x 0.93 on x, x 1.07 on z",
           edit=_forces(lambda r: r.forces.values * np.array([0.93, 1.0, 1.07]))),  # type: ignore[union-attr]
    Change("ft_clock", ("stream_time_offset",), what="F/T clock 35 ms ahead and 250 ppm slow",
           edit=lambda r: replace(r, forces=_reclocked(r.forces, r.commanded.t_s[0], 0.035, -2.5e-4))),  # type: ignore[arg-type]
    Change("tracker_reregistered", ("tracker_registration",),
           what="tracker re-registered: 2 mrad about (-0.5, 1, 0.8), shift (0.15, 0.25, -0.10) mm",
           edit=_tracker(lambda r: r.tracker.values @ _about((-0.5, 1.0, 0.8), 2e-3).T
                         + 1e-3 * np.array([0.15, 0.25, -0.10]))),
    Change("tracker_drift", ("tracker_drift",), what="tracker drifting 7 um/s along (0.9, 0.3, -0.3)",
           edit=_tracker(lambda r: r.tracker.values + np.outer(
               r.tracker.t_s - r.commanded.t_s[0], 7e-6 * np.array([0.9, 0.3, -0.3]) / np.linalg.norm([0.9, 0.3, -0.3])))),
    Change("tracker_clock", ("tracker_clock",), what="tracker clock 18 ms behind and 250 ppm slow",
           edit=lambda r: replace(r, tracker=_reclocked(r.tracker, r.commanded.t_s[0], -0.018, -2.5e-4))),
    Change("gear_play", ("lost_motion", "lost_motion_under_load"), what="joint 3's gear with 0.35 mrad of play (plant knob)",
           knobs=("backlash_j3_mrad=0.35",)),
    Change("gear_softer", ("joint_compliance", "unexplained"), what="joint 2's gear 25 % softer (plant knob)",
           knobs=("gear_stiffness_j2_scale=0.75",), learned="^joint 2 is"),
    Change("robot_moved", ("tracker_registration",), what="the robot moved on its base: (1, -2, 0) mm in plane",
           base_shift_mm=(1.0, -2.0, 0.0)),
    Change("sheet_thicker", ("force_scale", "unexplained"),
           what="a new coil: the sheet 1.1 mm thick where the cell's records say 1.0 mm (plant process)",
           sheet=("--thickness-mm", "1.1"), learned=r"^the sheet pushes [\d.]+ N more"),
)
#: The fourth held-out set (after the joint-compliance family, which couples the tip's change and the force's through
#: one gear): an IRB 6640 forming a variable-wall-angle cone (spiral), a KR210 a wider, shallower-walled cone; other
#: forms and sizes again; written before any of its runs.
HELD_OUT_4 = (
    Change("ft_retared", ("force_sensor_bias",), what="F/T re-tared: -15 N x, -30 N y, +35 N z",
           edit=_forces(lambda r: r.forces.values + np.array([-15.0, -30.0, 35.0]))),  # type: ignore[union-attr]
    Change("ft_remounted", ("force_sensor_crosstalk",), what="F/T re-mounted turned 6 deg about z and 2 deg about x",
           edit=_forces(lambda r: r.forces.values @ (_about((0, 0, 1), np.deg2rad(6.0))  # type: ignore[union-attr]
                                                     @ _about((1, 0, 0), np.deg2rad(2.0))).T)),
    Change("ft_recalibrated", ("force_sensor_gain",), what="F/T calibration x 1.05 on x and y, x 0.93 on z",
           edit=_forces(lambda r: r.forces.values * np.array([1.05, 1.05, 0.93]))),  # type: ignore[union-attr]
    Change("ft_clock", ("stream_time_offset",), what="F/T clock 45 ms behind and 150 ppm fast",
           edit=lambda r: replace(r, forces=_reclocked(r.forces, r.commanded.t_s[0], -0.045, 1.5e-4))),  # type: ignore[arg-type]
    Change("tracker_reregistered", ("tracker_registration",),
           what="tracker re-registered: 1.8 mrad about (0.7, 0.7, -0.3), shift (-0.25, 0.10, 0.20) mm",
           edit=_tracker(lambda r: r.tracker.values @ _about((0.7, 0.7, -0.3), 1.8e-3).T
                         + 1e-3 * np.array([-0.25, 0.10, 0.20]))),
    Change("tracker_drift", ("tracker_drift",), what="tracker drifting 6 um/s along (-0.4, 0.8, 0.45)",
           edit=_tracker(lambda r: r.tracker.values + np.outer(
               r.tracker.t_s - r.commanded.t_s[0], 6e-6 * np.array([-0.4, 0.8, 0.45]) / np.linalg.norm([-0.4, 0.8, 0.45])))),
    Change("tracker_clock", ("tracker_clock",), what="tracker clock 14 ms ahead and 200 ppm fast",
           edit=lambda r: replace(r, tracker=_reclocked(r.tracker, r.commanded.t_s[0], 0.014, 2e-4))),
    Change("gear_play", ("lost_motion", "lost_motion_under_load"), what="joint 2's gear with 0.45 mrad of play (plant knob)",
           knobs=("backlash_j2_mrad=0.45",)),
    Change("gear_softer", ("joint_compliance", "unexplained"), what="joint 3's gear 30 % softer (plant knob)",
           knobs=("gear_stiffness_j3_scale=0.7",), learned="^joint 3 is"),
    Change("robot_moved", ("tracker_registration",), what="the robot moved on its base: (-2, -1, 0) mm in plane",
           base_shift_mm=(-2.0, -1.0, 0.0)),
    Change("sheet_thicker", ("force_scale", "unexplained"),
           what="a new coil: the sheet 1.12 mm thick where the cell's records say 1.0 mm (plant process)",
           sheet=("--thickness-mm", "1.12"), learned=r"^the sheet pushes [\d.]+ N more"),
)
class _GivingFrame:
    """This module's own plant variant: the plant's sheet in a clamping frame that gives along its normal, a spring
    of compliance c with a first-order lag of FRAME_LAG_S (the frame's own mass and damping), stepped with the plant:
    each tick the sheet is met at the tip raised by the frame's give d, and d moves towards c f_z over the tick."""

    def __init__(self, sheet: Any, compliance_m_per_n: float, timestep_s: float) -> None:
        self.sheet, self.c, self.give, self.f_z = sheet, compliance_m_per_n, 0.0, 0.0
        self.blend = min(1.0, timestep_s / FRAME_LAG_S)

    def _met(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(p, dtype=float) + np.array([0.0, 0.0, self.give])

    def force(self, p: np.ndarray) -> np.ndarray:
        f = self.sheet.force(self._met(p))
        self.f_z = float(f[2])
        return f

    def advance(self, p: np.ndarray) -> None:
        self.sheet.advance(self._met(p))
        self.give += self.blend * (self.c * self.f_z - self.give)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.sheet, name)


FRAME_LAG_S = 0.005


@contextlib.contextmanager
def _frame_that_gives(mm_per_kn: float) -> Iterator[None]:
    """The plant's sheets, while inside, built on `_GivingFrame` (none for 0)."""
    import twin.lab.dynamic.simulate as plant

    make = plant.make_sheet
    if mm_per_kn > 0.0:
        plant.make_sheet = lambda knobs, process: _GivingFrame(make(knobs, process), 1e-6 * mm_per_kn,  # type: ignore[assignment]
                                                               knobs["timestep_s"])
    try:
        yield
    finally:
        plant.make_sheet = make


#: The fifth held-out set (issue #47's clamping frame): written before any of its runs, after the
#: `frame_compliance` family was developed on the TX200 groove and the KR210 cone (0.3 mm/kN), run once.
HELD_OUT_5 = (
    Change("frame_gives", ("frame_compliance",), what="the clamping frame gives 0.25 mm/kN (plant variant)",
           frame_mm_per_kn=0.25),
    Change("frame_gives_more", ("frame_compliance",), what="the clamping frame gives 0.6 mm/kN (plant variant)",
           frame_mm_per_kn=0.6),
)
#: The sixth held-out set (issue #47's clamping frame, judged by the part scan): written before any of its runs, after
#: the scan's judge (`twin.analysis.discrepancy.scan`) was developed on the KR210 cone (0.3 mm/kN), while the fifth set
#: ran again with it (its results not yet seen), on six cells no frame was hidden in before, three robots' grooves,
#: cones and pyramids.
HELD_OUT_6 = (
    Change("frame_gives_0p4", ("frame_compliance",), what="the clamping frame gives 0.4 mm/kN (plant variant)",
           frame_mm_per_kn=0.4),
    Change("frame_gives_0p8", ("frame_compliance",), what="the clamping frame gives 0.8 mm/kN (plant variant)",
           frame_mm_per_kn=0.8),
)
#: Each set's cells and the changes hidden on each: the development set (the library was changed while looking at
#: it; the first held-out set joined it once run) and the held-out set.
SETS: dict[str, dict[str, tuple[Change, ...]]] = {
    "development": {"tx200-groove": DEVELOPMENT + DEVELOPMENT_MORE, "kr210-cone": DEVELOPMENT + DEVELOPMENT_MORE,
                    "irb6640-pyramid": FIRST_HELD_OUT,
                    "tx200-cone": FIRST_HELD_OUT},
    "held-out": {"irb6640-cone": HELD_OUT, "kr210-pyramid": HELD_OUT},
    "held-out-2": {"kr210-groove": HELD_OUT_2, "tx200-pyramid": HELD_OUT_2},
    "held-out-3": {"irb6640-groove": HELD_OUT_3, "tx200-vwa-cone": HELD_OUT_3},
    "held-out-4": {"irb6640-vwa-cone": HELD_OUT_4, "kr210-cone-wide": HELD_OUT_4},
    "held-out-5": {"irb6640-groove": HELD_OUT_5, "kr210-pyramid": HELD_OUT_5, "tx200-pyramid": HELD_OUT_5,
                   "irb6640-cone": HELD_OUT_5},
    "held-out-6": {"tx200-cone": HELD_OUT_6, "irb6640-pyramid": HELD_OUT_6, "tx200-vwa-cone": HELD_OUT_6,
                   "irb6640-vwa-cone": HELD_OUT_6, "kr210-cone-wide": HELD_OUT_6, "kr210-groove": HELD_OUT_6},
}


def _cli(args: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main(args)
    return code, out.getvalue()


def _plant_run(cell: Cell, root: Path, seed: int, out: Path, knobs: tuple[str, ...] = (),
               base_shift_mm: tuple[float, float, float] | None = None, sheet: tuple[str, ...] = (),
               frame_mm_per_kn: float = 0.0) -> Path:
    args = ["lab", "--plant", "dynamic", "--robot", cell.robot, "--scenario", "nominal", "--seed", str(seed),
            "--out", str(out)]
    path = root / "path.csv"
    if base_shift_mm is not None:  # the robot, moved, executes the program off by the move on the sheet
        shifted = np.loadtxt(path, delimiter=",", skiprows=1)
        header = path.read_text().splitlines()[0]
        shifted[:, 1:4] -= np.asarray(base_shift_mm)
        path = out.parent / f"{out.name}-path.csv"
        np.savetxt(path, shifted, delimiter=",", header=header, comments="", fmt=["%.6f"] * 4 + ["%d"] * (shifted.shape[1] - 4))
    args += ["--commanded", str(path)]
    for knob in knobs:
        args += ["--set", knob]
    with _frame_that_gives(frame_mm_per_kn):
        code, text = _cli([*args, *sheet])
    assert code == 0, text
    if sheet:  # the user's records keep the cell's sheet: the new coil is hidden
        meta = json.loads((out / "meta.json").read_text())
        meta["process"] = json.loads((root / "clean1" / "meta.json").read_text())["process"]
        (out / "meta.json").write_text(json.dumps(meta, indent=1))
    if base_shift_mm is not None:  # the user's records keep the program as written: the move is hidden
        run = read_run(out)
        commanded = Stream(run.commanded.t_s, run.commanded.values + 1e-3 * np.asarray(base_shift_mm))
        final = out.parent / f"{out.name}-as-written"
        return write_run(final, replace(run, commanded=commanded))
    return out


def learn_cell(name: str, root: Path, reuse: bool = False) -> Path:
    """The cell's clean runs, and the cell learned from the first two (`cell.json`, with its floor); `reuse`: a cell
    already learned in `root` is kept (the plant and `learn` are deterministic), and a cell whose `cell.json` was
    removed is learned again from the runs already there (after a change to the learner)."""
    cell = CELLS[name]
    seeds = (*CLEAN_SEEDS, CHANGED_SEED, NEXT_SEED)
    clean = [root / f"clean{s}" for s in seeds]
    have_runs = reuse and all(path.is_dir() for path in clean)
    if have_runs and (root / "cell.json").exists():
        return root / "cell.json"
    if not have_runs:  # (with the runs but no cell.json: learned again from them)
        root.mkdir(parents=True, exist_ok=True)
        code, text = _cli(["path", *cell.path_args, "--robot", cell.robot, "--out", str(root / "path.csv")])
        assert code == 0, text
        clean = [_plant_run(cell, root, s, root / f"clean{s}") for s in seeds]
    code, text = _cli(["learn", str(clean[0]), str(clean[1]), "--write-model", str(root / "cell.json")])
    assert code == 0, text
    return root / "cell.json"


def _excess_above(run: Run, model: Path, floor: Floor) -> tuple[float, float]:
    """The run's excess over noise with the twin `model` less the cell's floor, and the floor's own, over the run's
    streams [noise units², whole run] (the search's measures: its residual over the noise it estimates)."""
    spec = read_model_file(model)
    by_stream = excess_by_stream(ResidualModel(run, spec), spec.effects)
    on_run = floor.excess_on({s: n for s, (_, n) in by_stream.items()})
    return max(sum(e for e, _ in by_stream.values()) - on_run, 0.0), on_run


def run_case(cell_name: str, change: Change, root: Path, reuse: bool = False) -> dict[str, Any]:
    """One hidden change on one learned cell (module docstring): the verdict and the next run's shrink; `reuse`: the
    changed and next runs an earlier call left are kept (the plant is deterministic: a change of the twin alone)."""
    cell, cell_model = CELLS[cell_name], root / "cell.json"
    case = root / change.name
    kept = reuse and all((case / tag / "tracker.csv").is_file() for tag in ("changed", "next"))
    if case.exists() and not kept:
        shutil.rmtree(case)
    case.mkdir(exist_ok=True)
    for old in (case / "M.json", case / "report.json"):
        old.unlink(missing_ok=True)
    runs = []
    for seed, tag in ((CHANGED_SEED, "changed"), (NEXT_SEED, "next")):
        if kept:  # a robot moved: the run as the user's records keep it (`_plant_run`)
            written = case / f"{tag}-as-written"
            runs.append(written if written.is_dir() else case / tag)
        elif change.edit is not None:
            runs.append(write_run(case / tag, change.edit(read_run(root / f"clean{seed}"))))
        else:
            runs.append(_plant_run(cell, root, seed, case / tag, change.knobs, change.base_shift_mm, change.sheet,
                                   change.frame_mm_per_kn))
    code, text = _cli(["discrepancy", str(runs[0]), "--model", str(cell_model), "--model-out",
                       str(case / "M.json"), "--json", str(case / "report.json")])
    assert code == 0, text
    report = json.loads((case / "report.json").read_text())
    floor = Floor.from_json(read_floor_entry(cell_model), str(cell_model))
    nxt = read_run(runs[1])
    (before, floor_excess), (after, _) = _excess_above(nxt, cell_model, floor), _excess_above(nxt, case / "M.json", floor)
    named = report.get("effect")
    learned = (report.get("learned") or {}).get("named", [])
    first = next((w for w in learned if w.startswith(change.learned.lstrip("^").split()[0])), "") if change.learned else ""
    right_words = not learns_from_run(named) or not change.learned or bool(re.search(change.learned, first))
    return {"cell": cell_name, "change": change.name, "what": change.what, "expected": list(change.expected),
            "named": named, "families": [f["name"] for f in report.get("families", [])],
            "learned": [w for w in (first or next((w for w in learned if w.startswith("joint")), ""),) if w],
            "named_right": named in change.expected and right_words,
            "observable": before > OBSERVABLE_SHARE * floor_excess,
            "excess_before": before, "excess_after": after,
            "shrink": 1.0 - after / before if before > 0 else float("nan"),
            "remainder": report.get("remainder", {}).get("words", "")}


def run_set(which: str, root: Path, reuse: bool = False) -> list[dict[str, Any]]:
    """Every change of a set (`SETS`) on each of its cells (`reuse`: cells already learned under `root` kept, and the
    runs already formed there)."""
    rows = []
    for name, changes in SETS[which].items():
        learn_cell(name, root / name, reuse)
        rows += [{"set": which, **run_case(name, c, root / name, reuse)} for c in changes]
    return rows


def run_sets(whiches: Iterable[str], root: Path, reuse: bool = False, jobs: int = 1) -> dict[str, list[dict[str, Any]]]:
    """`run_set` of each of `whiches` under root/WHICH, `jobs` sets at a time, each in a process of its own (the sets
    share no folder and every run its seed, so the rows are those the sets give one at a time)."""
    whiches = list(whiches)
    if jobs <= 1 or len(whiches) <= 1:
        return {which: run_set(which, root / which, reuse) for which in whiches}
    with ProcessPoolExecutor(min(jobs, len(whiches)), mp_context=multiprocessing.get_context("spawn")) as pool:
        done = {which: pool.submit(run_set, which, root / which, reuse) for which in whiches}
        return {which: future.result() for which, future in done.items()}


def right(row: dict[str, Any]) -> bool:
    """A change the next run shows above the floor (`Floor.observable`'s share): named right and the next run's
    excess over the floor at most SHRINK_TO of the cell's; one it does not show: `none` (not observable)."""
    if not row["observable"]:
        return row["named"] == "none"
    return bool(row["named_right"]) and row["shrink"] >= 1.0 - SHRINK_TO


def _gist(sentences: list[str]) -> str:
    """What the learned twin says first, without its numbers: `joint 2 softer`, `the sheet pushes more`."""
    for w in sentences:
        if said := re.match(r"(joint \d) is [\d.]+ % (softer|stiffer)", w):
            return f"{said[1]} {said[2]}"
    for w in sentences:
        if said := re.match(r"the sheet pushes [\d.]+ N (more|less)", w):
            return f"the sheet pushes {said[1]}"
    return "nothing named"


def markdown(rows: list[dict[str, Any]]) -> str:
    """One set's rows as a table (rounded to what a machine's floating point cannot move), and its count."""
    which = rows[0]["set"]
    lines = [f"| {which}: cell | change | named | right | next run: observable above the floor; its excess over it, "
             "cell -> found |", "|---|---|---|---|---|"]
    for r in rows:
        shrink = "none to shrink" if r["excess_before"] <= 0 else (
            "at least halved" if r["shrink"] >= 1.0 - SHRINK_TO else "not halved")
        words = f" (learned: {_gist(r['learned'])})" if r["learned"] and learns_from_run(r["named"]) else ""
        seen = "yes" if r["observable"] else "no"
        lines.append(f"| {r['cell']} | {r['what']} | `{r['named']}`{words} | {'yes' if right(r) else 'no'} | "
                     f"{seen}; {shrink} |")
    lines.append("")
    seen = [r for r in rows if r["observable"]]
    lines.append(f"{which}: right in {sum(right(r) for r in rows)} / {len(rows)}; of the {len(seen)} changes the next "
                 f"run shows above the floor, named right with its excess over the floor at least halved in "
                 f"{sum(right(r) for r in seen)} / {len(seen)}; of the {len(rows) - len(seen)} it does not, said "
                 f"`none` (not observable) in {sum(right(r) for r in rows if not r['observable'])}.")
    return "\n".join(lines)


BEGIN, END = "<!-- plant-changes:begin", "<!-- plant-changes:end -->"


def write_markdown(path: Path, tables: list[str]) -> None:
    """Replace the block between BEGIN and END in `path` with the tables."""
    text = path.read_text()
    head, tail = text[:text.index(BEGIN)], text[text.index(END):]
    header = (f"{BEGIN} (generated by `.venv/bin/python -m tests.plant_changes --set SET --out F.json --markdown "
              "docs/discrepancy.md`; do not edit) -->")
    path.write_text(head + header + "\n" + "\n\n".join(tables) + "\n" + tail)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--work", type=Path, default=Path("plant-changes"))
    parser.add_argument("--set", choices=(*SETS, "both"), default="held-out")
    parser.add_argument("--markdown", type=Path, help="write both sets' tables into this file (with --set both)")
    parser.add_argument("--reuse-cells", action="store_true",
                        help="keep cells already learned under --work, and the runs already formed there")
    parser.add_argument("--jobs", type=int, default=1, help="sets run at a time, each in its own process (default 1)")
    args = parser.parse_args()
    sets = tuple(SETS) if args.set == "both" else (args.set,)
    tables = run_sets(sets, args.work, args.reuse_cells, args.jobs)
    args.out.write_text(json.dumps(tables, indent=1))
    for table in tables.values():
        print(markdown(table))
    if args.markdown is not None and len(tables) == len(SETS):
        write_markdown(args.markdown, [markdown(t) for t in tables.values()])
