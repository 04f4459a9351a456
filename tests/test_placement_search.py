"""Placement search (`twin.analysis.placement_search`, `tx200-twin place`) and the jobs on a Dask cluster
(`twin.base.jobs`): the screen against the twin, infeasible candidates, and the same result on a local Dask
cluster as in local processes (the sweep's too)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.placement_screen import STATUSES, ConfirmSetup, ScreenSetup, confirm_one, screen_rows
from twin.analysis.placement_search import SearchBox, candidate_rows, search_placement
from twin.base.csvio import write_table
from twin.cli import main
from twin.process.description import Process
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.spec import TwinSpec


@pytest.fixture(scope="module")
def cone() -> ToolPath:
    """A small cone (Ø 20 mm, 2 mm deep, 513 samples)."""
    return part_path(PartSpec(depth_m=2e-3, top_half_width_m=10e-3))


@pytest.fixture(scope="module")
def spec() -> TwinSpec:
    return TwinSpec(process=replace(Process(), force_model="isf"))


@pytest.fixture(scope="module")
def scheduler():
    """A local Dask cluster (one worker thread in this process) for the module's tests; its address."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_the_screen_ranks_placements_as_the_twin_does(cone: ToolPath, spec: TwinSpec) -> None:
    """Screen vs `Twin.simulate` on 8 placements drawn across the default box. Thresholds set before this draw
    was run (from a probe on other placements of this cone, where the screen missed by up to 21 %, the joints'
    friction it neglects weighing most on this small part's forces): rank correlation >= 0.8, each within 25 %."""
    from scipy.stats import spearmanr

    twin = spec.build()
    sim = twin.simulate(cone.t_s, cone.p_sheet_m)
    idx = np.unique(np.linspace(0, len(cone.t_s) - 1, 256).round().astype(int))
    setup = ScreenSetup(spec.robot, twin.joint_stiffness, cone.p_sheet_m[idx], sim.f_sheet_n[idx], 0.0)
    rows = candidate_rows(np.r_[twin.p_base_sheet_origin, 0.0], SearchBox(), 8, seed=7)
    screened = screen_rows(twin.kinematics, setup, rows)
    simulated = np.array([confirm_one(ConfirmSetup(spec, cone, 0.0), row) for row in rows])
    assert np.all(screened[:, 2] == 0) and np.all(simulated[:, 2] == 0)
    assert spearmanr(screened[:, 0], simulated[:, 0]).statistic >= 0.8
    np.testing.assert_allclose(screened[:, 0], simulated[:, 0], rtol=0.25)
    assert np.ptp(simulated[:, 0]) > 0.2 * simulated[:, 0].min()  # the placements differ: a ranking to get right


def test_infeasible_candidates_are_counted_and_never_confirmed(cone: ToolPath, spec: TwinSpec) -> None:
    wide = SearchBox(half_width_m=(1.5, 1.5, 0.1))  # reaches far outside the robot's 2.2 m
    result = search_placement(cone, spec, candidates=24, confirm=24, seed=1, box=wide, workers=1)
    codes = result.screened[:, 2].astype(int)
    counts = result.infeasible()
    assert counts["unreachable"] > 0 and sum(counts.values()) == int(np.sum(codes > 0))
    assert np.all(np.isnan(result.screened[codes > 0, 0])) and np.all(result.screened[codes == 0, 0] > 0)
    assert set(result.confirmed_index) == set(np.flatnonzero(codes == 0))  # all the feasible, nothing else
    far = np.r_[result.default_row[:3] + np.array([3.0, 0.0, 0.0]), 0.0]  # 3 m further out: out of reach
    twin = spec.build()
    setup = ScreenSetup(spec.robot, twin.joint_stiffness, cone.p_sheet_m[::8], np.zeros((len(cone.p_sheet_m[::8]), 3)),
                        math.radians(5.0))
    assert STATUSES[int(screen_rows(twin.kinematics, setup, far[None])[0, 2])] == "unreachable"
    strict = setup._replace(joint_margin_rad=math.pi)  # no placement keeps every joint pi from its limits
    assert STATUSES[int(screen_rows(twin.kinematics, strict, result.default_row[None])[0, 2])] == "joint_margin"


def test_a_placement_search_on_a_dask_cluster_equals_the_local_one(cone: ToolPath, spec: TwinSpec,
                                                                    scheduler: str) -> None:
    local = search_placement(cone, spec, candidates=20, confirm=3, seed=2, workers=1)
    dask = search_placement(cone, spec, candidates=20, confirm=3, seed=2, scheduler=scheduler)
    np.testing.assert_array_equal(dask.rows, local.rows)
    np.testing.assert_allclose(dask.screened, local.screened, rtol=1e-12, equal_nan=True)
    np.testing.assert_array_equal(dask.confirmed_index, local.confirmed_index)
    np.testing.assert_allclose(dask.confirmed, local.confirmed, rtol=1e-12)
    assert "Dask" in dask.where and local.best is not None
    best_rms = local.confirmed[list(local.confirmed_index).index(local.best), 0]
    assert best_rms <= local.default_simulated[0]  # the default sits inside the box: the best is no worse


def test_place_cli_through_scheduler_writes_json_and_figure(tmp_path: Path, cone: ToolPath, scheduler: str) -> None:
    ideal = tmp_path / "cone.csv"
    write_table(ideal, {"t_s": cone.t_s, **{f"{a}_mm": 1e3 * cone.p_sheet_m[:, i] for i, a in enumerate("xyz")}})
    argv = ["place", "--ideal", str(ideal), "--candidates", "20", "--confirm", "2", "--seed", "4"]
    assert main([*argv, "--workers", "1", "--json", str(tmp_path / "local.json")]) == 0
    assert main([*argv, "--scheduler", scheduler, "--json", str(tmp_path / "dask.json"),
                 "--figure", str(tmp_path / "map.png")]) == 0
    local, dask = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("local", "dask"))
    for payload in (local, dask):
        payload.pop("timings_s"), payload.pop("where"), payload.pop("figure", None)
    assert dask == local and local["candidates"] == 20 and len(local["confirmed"]) == 2
    assert local["default"]["simulated_rms_mm"] > 0 and (tmp_path / "map.png").stat().st_size > 10_000


def test_the_sweep_on_a_dask_cluster_equals_the_local_one(scheduler: str) -> None:
    from twin.apps.sweep import run_sweep

    groove = groove_path()
    keep = groove.pass_index <= 2
    short = ToolPath(t_s=groove.t_s[keep], p_sheet_m=groove.p_sheet_m[keep], pass_index=groove.pass_index[keep],
                     direction=groove.direction[keep])
    local = run_sweep(3, seed=5, workers=1, path=short, compensate=False)
    dask = run_sweep(3, seed=5, path=short, compensate=False, chunk=1, scheduler=scheduler)
    np.testing.assert_array_equal(dask.parameters, local.parameters)
    np.testing.assert_array_equal(dask.rms_m, local.rms_m)
    np.testing.assert_array_equal(dask.max_m, local.max_m)
    assert np.ptp(local.rms_m) > 0 and dask.workers == 1
