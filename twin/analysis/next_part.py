"""The next part's command from the last part's measured forces.

The last run of a part carries the force its sheet pushed the tool with along the whole path, as the F/T sensor
measured it. For the next part of the same program that is the sheet's force known as well as a cell can know it,
without a sheet model: the twin's robot (its joint springs, friction and servo transient, learned where the model
file says so; `twin.analysis.learn.split.measured_force_deflection`) driven by those forces, along the last run's command,
deflects the tool by some amount, and the next command is the ideal path less that deflection (the last command
moved by the last tip's predicted miss comes to the same). A run compensated online is taken as well: its logged
command leaves out the online correction, and the deflection under its forces does not need it. It is the thesis's
compensation (forces and a stiffness, Eq. 4.28) with the forces measured on the part itself instead of an FE model's
(docs/thesis-reproduction.md), and a learning from part to part: repeated, the command follows the sheet as it
answers a deeper tool with more force. The tracker is not read, so its registration error stays out of the command.

Which sample of the run is which of the ideal path: a run whose commanded stream has as many samples as the ideal
path is the same program re-timed by its controller (stops at the corners; `twin.analysis.check.ideal_times`), sample
for sample; a controller's log at its own rate is placed by the share of its length it has travelled, so its stops
(time without travel) do not shift it.

The forces are taken as the sheet pushed, not as the sensor read them: a model file's instruments (the F/T sensor's
bias, gain, cross-talk and clock, as `learn` or `discrepancy` found them; `twin.sim.instruments`) are undone first.

What it cannot do: a part whose forces change from one run to the next more than the command does (a new sheet
lot, another tool) carries the last part's forces over; a run of another program is refused; a log that holds more
than the program (an approach from home) is placed wrong, and refused where that leaves its command too far from the
ideal path.

Measured on the dynamic plant: docs/learning.md ("The next part from the last part's forces").
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from twin.analysis.check import ideal_times
from twin.analysis.learn.split import measured_force_deflection
from twin.base.signals import arc_length, interp_rows
from twin.errors import InputError
from twin.runs.format import Run, Stream
from twin.sim.instruments import Instruments
from twin.sim.quasi_static import Twin

#: A run whose command lies further than this from the ideal path (rms) is of another program [m].
SAME_PROGRAM_M = 0.005


class NextCommand(NamedTuple):
    """The next part's command (`next_command`).

    Attributes:
        t_s: The ideal path's sample times [s], (n,).
        p_cmd_sheet_m: The next command at those samples, sheet frame [m], (n, 3).
        deflection_m: The twin's robot's deflection of the tool under the last run's measured forces, along its
            command, at the ideal's samples [m], (n, 3).
        f_measured_n: The last run's measured force by the sheet on the tool at those samples, sheet frame [N],
            (n, 3): the force the next command assumes.
    """

    t_s: np.ndarray
    p_cmd_sheet_m: np.ndarray
    deflection_m: np.ndarray
    f_measured_n: np.ndarray


def run_times(run: Run, t_ideal_s: np.ndarray, p_ideal_sheet_m: np.ndarray) -> np.ndarray:
    """The run's clock time of each ideal sample [s], (n,) (module docstring): the commanded stream's own where it has
    as many samples as the ideal path, else where it has travelled the share of its length the ideal has."""
    t_cmd = np.asarray(run.commanded.t_s, dtype=float)
    if len(t_cmd) == len(t_ideal_s):
        return ideal_times(t_cmd, t_ideal_s)
    s_run, s_ideal = arc_length(run.commanded.values), arc_length(p_ideal_sheet_m)
    if s_run[-1] <= 0.0 or s_ideal[-1] <= 0.0:
        return np.asarray(t_ideal_s, dtype=float)
    rising = s_run + 1e-12 * np.arange(len(s_run))  # a stop travels nothing: its first sample is where it is reached
    return np.interp(s_ideal / s_ideal[-1] * s_run[-1], rising, t_cmd)


def next_command(run: Run, t_ideal_s: np.ndarray, p_ideal_sheet_m: np.ndarray, twin: Twin,
                 ideal_name: str = "the ideal path") -> NextCommand:
    """The next part's command: the ideal path less the twin's deflection under the last run's measured forces.

    Args:
        run: The last part's run (its commanded stream and forces; the twin at its placement and robot).
        t_ideal_s: The ideal path's sample times [s], (n,).
        p_ideal_sheet_m: The ideal path, sheet frame [m], (n, 3).
        twin: The twin whose robot predicts the tip (`twin.analysis.resolve.spec_for_run`'s, built).
        ideal_name: How the ideal path is named in errors (the CLI: `--ideal FILE`).

    Raises:
        InputError: The run has no forces, does not span the ideal path's times, or its command is not a
            compensation of that path (further than `SAME_PROGRAM_M` from it, rms).
    """
    if run.forces is None or len(run.forces.t_s) < 10:
        raise InputError(f"run {run.directory}: no forces.csv (or fewer than 10 samples): expected the last part's "
                         "run with its F/T sensor on")
    t_ideal = np.asarray(t_ideal_s, dtype=float)
    p_ideal = np.asarray(p_ideal_sheet_m, dtype=float)
    t_run = run_times(run, t_ideal, p_ideal)
    start, end = run.tracker.t_s[0], run.tracker.t_s[-1]
    if t_run[0] < start - 0.1 or t_run[-1] > end + 0.1:
        raise InputError(f"run {run.directory}: its tracker spans {start:.2f} to {end:.2f} s, {ideal_name} "
                         f"{t_run[0]:.2f} to {t_run[-1]:.2f} s on its clock: expected the run of that program")
    last = interp_rows(t_run, run.commanded.t_s, run.commanded.values)  # the program's own samples where it has them
    apart = float(np.sqrt(np.mean(np.sum((last - p_ideal) ** 2, axis=1))))
    if apart > SAME_PROGRAM_M:
        raise InputError(f"run {run.directory}: its command lies {1e3 * apart:.1f} mm (rms) from {ideal_name}: "
                         f"expected a run of that part (a command within {1e3 * SAME_PROGRAM_M:g} mm of it)")
    sheet = sheet_forces(run.forces, float(run.commanded.t_s[0]), twin.spec.effects.instruments)
    deflection = interp_rows(t_run, run.tracker.t_s, measured_force_deflection(replace(run, forces=sheet), twin))
    return NextCommand(t_ideal, p_ideal - deflection, deflection, interp_rows(t_run, sheet.t_s, sheet.values))


def sheet_forces(forces: Stream, t0_s: float, instruments: Instruments) -> Stream:
    """An F/T stream as the sheet pushed (`Instruments.force_from_reading`, on the sensor's own clock; `t0_s`: the
    run's first commanded time)."""
    t_s = instruments.force_times(forces.t_s, t0_s)
    order = np.argsort(t_s, kind="stable")
    return Stream(t_s[order], instruments.force_from_reading(forces.values)[order])
