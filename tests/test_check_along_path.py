"""`check` splits its residual along the ideal path and across it: a tool that runs late along its own track
misses the path in time but not in shape, and the part keeps only the second.

The lag is written here (the tracker's reading taken 20 ms earlier along the run's own record, by interpolation),
on a groove of the virtual lab compensated by the formula."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from twin.analysis.check import check_run
from twin.analysis.compensate import compensate_formula
from twin.lab.virtual import run_lab
from twin.process.fe.load import default_force_history
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import groove_path
from twin.runs.format import Stream
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

LAG_S = 0.02


@pytest.fixture(scope="module")
def run_and_ideal():
    ideal = groove_path()
    twin = Twin(TwinSpec())
    f = SheetForceField(default_force_history()).rigid_forces(ideal)
    comp = compensate_formula(ideal.t_s, ideal.p_sheet_m, f, twin.kinematics.compliance(twin.kinematics.q_home))
    return run_lab(comp.t_s, comp.p_cmd_sheet_m, scenario="compensated", seed=2)[0], ideal


def test_the_residual_splits_into_along_and_across_the_path(run_and_ideal) -> None:
    run, ideal = run_and_ideal
    m = check_run(run, ideal.t_s, ideal.p_sheet_m).summary()
    total = float(m["residual_rms_mm"])
    along, across = float(m["residual_along_path_rms_mm"]), float(m["residual_across_path_rms_mm"])
    assert along**2 + across**2 == pytest.approx(total**2, rel=1e-9)


def test_a_tool_late_along_its_track_misses_along_the_path_only(run_and_ideal) -> None:
    run, ideal = run_and_ideal
    t = run.tracker.t_s
    late = np.stack([np.interp(t - LAG_S, t, run.tracker.values[:, a]) for a in range(3)], axis=1)
    before = check_run(run, ideal.t_s, ideal.p_sheet_m).summary()
    after = check_run(replace(run, tracker=Stream(t, late)), ideal.t_s, ideal.p_sheet_m).summary()
    speed = np.linalg.norm(np.gradient(ideal.p_sheet_m, ideal.t_s, axis=0), axis=1)
    lag_mm = 1e3 * LAG_S * float(np.sqrt(np.mean(speed**2)))  # what the lag alone leaves along the path, rms
    grown = float(after["residual_along_path_rms_mm"]) - float(before["residual_along_path_rms_mm"])
    assert grown > 0.5 * lag_mm, (grown, lag_mm)
    assert abs(float(after["residual_across_path_rms_mm"]) - float(before["residual_across_path_rms_mm"])) < 0.2 * lag_mm
