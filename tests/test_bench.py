"""Smoke tests of the benchmark (twin/apps/bench.py, `tx200-twin bench`): keys and sanity, never timings."""

from __future__ import annotations

import json

import numpy as np
import pytest

from twin.analysis.replay import replay
from twin.apps.bench import analytic_replay, format_table, run_benchmarks
from twin.cli import main
from twin.errors import InputError
from twin.process.toolpath.groove import groove_path
from twin.runs.format import Run, Stream
from twin.sim.spec import TwinSpec

SAMPLES = 160  # approach and most of pass 1: a tiny workload
TIMES = (
    "lab_run_s", "replay_s", "replay_warm_s", "simulate_warm_s", "ik_path_s", "analytic_replay_s",
    "identify_method2_s", "compensate_twin_s", "force_field_eval_s", "gcode_load_s",
)


@pytest.fixture(scope="module")
def result() -> dict:
    return run_benchmarks(repeats=1, samples=SAMPLES)


def test_bench_reports_every_time_as_a_positive_number(result: dict) -> None:
    for key in TIMES:
        assert isinstance(result[key], float) and result[key] > 0.0, key
    assert result["discrepancy_s"] is None or result["discrepancy_s"] > 0.0
    assert isinstance(result["gcode_moves"], int) and result["gcode_moves"] > 100
    if result["discrepancy_s"] is None:
        assert result["discrepancy_note"]
    assert result["workload"] == {"commanded_samples": SAMPLES, "machining_s": pytest.approx(
        result["workload"]["machining_s"]), "repeats": 1}


def test_bench_factors_follow_from_the_times(result: dict) -> None:
    duration = result["workload"]["machining_s"]
    assert result["replay_realtime_factor"] == pytest.approx(duration / result["replay_warm_s"])
    assert result["twin_over_analytic"] == pytest.approx(result["replay_warm_s"] / result["analytic_replay_s"])
    assert "replay_warm_s" in result["replay_realtime_factor_basis"]


def test_bench_records_the_machine(result: dict) -> None:
    machine = result["machine"]
    assert machine["cpu_count"] >= 1
    assert machine["python"].count(".") == 2 and machine["mujoco"]
    assert machine["blas"] and machine["git_commit"]
    assert "ready Twin" in format_table(result)


def test_analytic_replay_tracks_the_twin_within_a_few_micrometres(first_pass_path) -> None:
    """The linear model misses only gravity-free second-order terms: same tool tip within 5 µm."""
    t_s, p_cmd = first_pass_path
    t_tracker = np.linspace(t_s[0], t_s[-1], 40)
    run = Run(
        directory=None,
        meta={},
        commanded=Stream(t_s, p_cmd),
        tracker=Stream(t_tracker, np.zeros((40, 3))),
        forces=None,
        part_profile=None,
    )
    twin = TwinSpec(joint_friction_nm=np.zeros(6)).build()  # the linear model J K^-1 J^T F has no friction term
    linear = analytic_replay(run, twin=twin)
    sim = replay(run, twin=twin).sim
    assert linear.forces_pred_n is None and linear.tracker_pred_m.shape == (40, 3)
    assert np.max(np.abs(sim.deflection_sheet_m)) > 1e-4  # the pass deflects the robot by > 0.1 mm
    np.testing.assert_allclose(linear.p_sheet_m, sim.p_sheet_m, atol=5e-6)
    np.testing.assert_allclose(linear.f_sheet_n, sim.f_sheet_n, atol=0.02 * np.max(np.abs(sim.f_sheet_n)))


def test_analytic_replay_tracks_the_twin_through_the_reversals_where_the_tool_sticks() -> None:
    """The whole groove: at each reversal the tool sticks on the sheet; both solve it by regimes."""
    path = groove_path()
    run = Run(None, {}, Stream(path.t_s, path.p_sheet_m), Stream(path.t_s, np.zeros_like(path.p_sheet_m)))
    twin = TwinSpec(joint_friction_nm=np.zeros(6)).build()
    linear = analytic_replay(run, twin=twin)
    sim = replay(run, twin=twin).sim
    np.testing.assert_allclose(linear.p_sheet_m, sim.p_sheet_m, atol=2e-5)  # measured 7 µm (gravity terms)


def test_bench_cli_writes_json(tmp_path, result: dict, monkeypatch: pytest.MonkeyPatch) -> None:
    """The command's own part: its options reach `run_benchmarks` and its result is written as JSON (the module's
    smoke result stands in for a second run of it: the run itself is what the other tests check, 16 s each)."""
    asked: list[tuple] = []

    def same_run(repeats: int, samples: int | None, seed: int = 0) -> dict:
        asked.append((repeats, samples))
        return result

    monkeypatch.setattr("twin.apps.bench.run_benchmarks", same_run)
    out = tmp_path / "results.json"
    assert main(["bench", "--json", str(out), "--repeats", "1", "--samples", str(SAMPLES)]) == 0
    payload = json.loads(out.read_text())
    assert asked == [(1, SAMPLES)]
    assert set(TIMES) <= set(payload) and payload["workload"]["commanded_samples"] == SAMPLES


def test_bench_refuses_zero_repeats() -> None:
    with pytest.raises(InputError):
        run_benchmarks(repeats=0, samples=SAMPLES)


def test_bench_reports_the_speed_ratios_of_issue_18(result: dict) -> None:
    """MuJoCo-call floor, fresh real-time factor, sweep rate and cost growth, all from this one run."""
    duration = result["workload"]["machining_s"]
    assert 0.0 < result["mujoco_floor_s"] < result["replay_warm_s"]
    assert result["twin_over_mujoco_floor"] == pytest.approx(result["replay_warm_s"] / result["mujoco_floor_s"])
    assert result["replay_fresh_realtime_factor"] == pytest.approx(duration / result["replay_s"])
    assert result["sweep_replays_per_s_per_core"] > 0.0 and result["sweep"]["draws"] >= 1
    growth = result["path_growth"]
    assert [growth[k]["samples"] for k in ("1x", "4x", "16x")] == [(SAMPLES - 1) * k + 1 for k in (1, 4, 16)]
    assert growth["1x"]["over_1x"] == 1.0 and "cost vs path length" in format_table(result)


def test_bench_reports_the_ratios_of_issue_30(result: dict) -> None:
    """`--help` over `import numpy`, and the cone's twin compensation over one simulation, from this one run."""
    startup = result["cli_startup"]
    assert result["cli_help_over_numpy"] == pytest.approx(startup["help_s"] / startup["numpy_s"])
    comp = result["compensation"]
    assert comp["converged"] and 1 <= comp["simulations"] <= 4 and comp["residual_rms_mm"] <= 0.01
    assert result["compensation_over_simulation"] == pytest.approx(comp["compensate_s"] / comp["simulate_s"])
    assert "--help" in format_table(result) and "cone twin compensation" in format_table(result)
    place = result["placement"]
    assert result["place_over_simulation"] == pytest.approx(place["place_s"] / place["simulate_s"])
    assert place["candidates"] == 64 and 0 < place["feasible"] <= 64
    assert result["place_best_over_default_rms"] == pytest.approx(
        place["best_simulated_rms_mm"] / place["default_simulated_rms_mm"])
    assert "cone placement search" in format_table(result)


def test_bench_reports_the_cli_ratios_of_compensate_and_place_over_replay(result: dict) -> None:
    """Fresh `tx200-twin` processes on one cone: each command's time after its fixed costs over the replay's."""
    cli = result["cli"]
    assert cli["samples"] > 2 and cli["rounds"] == 1 and set(cli["commands"]) == {"replay", "compensate", "place"}
    for key in ("replay", "compensate", "place"):
        assert cli[f"{key}_s"] > 0.0 and cli[f"{key}_fixed_s"] > 0.0, key
    replay_work = cli["replay_s"] - cli["replay_fixed_s"]
    assert result["cli_compensate_over_replay"] == pytest.approx(
        (cli["compensate_s"] - cli["compensate_fixed_s"]) / replay_work)
    assert result["cli_place_over_replay"] == pytest.approx((cli["place_s"] - cli["place_fixed_s"]) / replay_work)
    assert "CLI compensate" in format_table(result) and "CLI place" in format_table(result)


def test_bench_reports_the_isf_cones_of_issue_30(result: dict) -> None:
    """Three cones on the ISF model (the smoke run's small ones), their real-time factors and the cost growth."""
    growth = result["isf_cone_growth"]
    assert list(growth) == ["20mm", "30mm", "40mm"]
    a, b, c = growth.values()
    assert 0 < a["samples"] < b["samples"] < c["samples"]
    for cone in (a, b, c):
        assert cone["realtime_factor"] == pytest.approx(cone["machining_s"] / cone["s"])
        assert 1.0 <= cone["iterations_per_sample"] <= 2.5  # the ISF model's extrapolated start
    assert result["isf_160_realtime_factor"] == c["realtime_factor"]
    per_sample = [(y["s"] - x["s"]) / (y["samples"] - x["samples"]) for x, y in ((a, b), (b, c))]
    assert result["isf_growth_ratio"] == pytest.approx(per_sample[1] / per_sample[0])
    assert "Ø160 cone on the ISF model" in format_table(result)


def test_resampled_path_keeps_every_original_sample() -> None:
    from twin.apps.bench_speed import resample

    t = np.array([0.0, 1.0, 3.0])
    p = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [3.0, 2.0, 1.0]])
    t4, p4 = resample(t, p, 4)
    assert len(t4) == 9 and np.all(np.diff(t4) > 0)
    np.testing.assert_array_equal(t4[::4], t)
    np.testing.assert_allclose(p4[::4], p, atol=1e-15)
    np.testing.assert_allclose(p4[6], [2.0, 2.0, 2.0])  # halfway between samples 1 and 2
    with pytest.raises(InputError):
        resample(t, p, 0)


def test_the_suite_timer_reads_pytests_closing_line() -> None:
    from twin.apps.bench_suite import parse_summary
    from twin.errors import InputError

    got = parse_summary("1172 passed, 1 skipped, 9 xfailed, 11 warnings in 126.85s (0:02:06)")
    assert got == {"counts": {"passed": 1172, "skipped": 1, "xfailed": 9}, "pytest_s": 126.85}
    assert parse_summary("2 failed, 3 passed, 1 error in 4.0s")["counts"] == {"failed": 2, "passed": 3, "error": 1}
    with pytest.raises(InputError, match="not a pytest summary"):
        parse_summary("collected 12 items")
