"""Tests of replay (twin/analysis/replay.py, `tx200-twin replay`): clean gap, the gap of each effect, bad runs."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.replay import ReplayResult, replay, replay_metrics
from twin.cli import main
from twin.errors import InputError
from twin.lab.virtual import run_lab
from twin.process.toolpath.placement import Placement
from twin.runs.format import Run, Stream, run_placement
from twin.sim.effects import Effects
from twin.sim.measure import predict_part_profile
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec

EFFECT_SEED = 11  # the effect runs use other noise than the clean run (seed 1)
GAP_FACTOR = 3.0

# effect -> (moderate value in its unit, the metric that must open, metrics the effect must leave alone)
EFFECT_CASES: dict[str, tuple[float, str, tuple[str, ...]]] = {
    "lost_motion": (0.5, "position_rms_mm", ()),
    "force_scale": (1.5, "force_rms_n", ()),
    "stream_time_offset": (0.2, "force_rms_n", ("position_rms_mm", "profile_rms_mm")),
    "tracker_drift": (0.02, "position_rms_mm", ("force_rms_n", "profile_rms_mm")),
    "tool_length_offset": (1.0, "position_rms_mm", ()),
    "sheet_springback": (0.13, "profile_rms_mm", ("position_rms_mm", "force_rms_n")),
}


def profile_rms_mm(twin: Twin, run: Run, sim: SimResult) -> float:
    """RMS of the measured part profile minus the twin's predicted one (no effects) [mm]."""
    assert run.part_profile is not None
    x_m, z_m = run.part_profile
    x_pred, z_pred = predict_part_profile(twin, sim, Effects())
    return 1e3 * float(np.sqrt(np.mean((z_m - np.interp(x_m, x_pred, z_pred)) ** 2)))


def gaps(twin: Twin, run: Run, result: ReplayResult) -> dict[str, float]:
    """The three gap metrics compared across effects."""
    return {
        "position_rms_mm": result.metrics["position_rms_mm"],
        "force_rms_n": result.metrics["force_rms_n"],
        "profile_rms_mm": profile_rms_mm(twin, run, result.sim),
    }


@pytest.fixture(scope="module")
def clean_gaps(twin_nominal: Twin, clean_run: Run, clean_replay: ReplayResult) -> dict[str, float]:
    return gaps(twin_nominal, clean_run, clean_replay)


def test_clean_run_misses_the_path_by_millimetres_and_replays_to_the_noise(
    clean_replay: ReplayResult, clean_gaps: dict[str, float]
) -> None:
    m = clean_replay.metrics
    print(
        f"\nclean lab run: deflection max {m['deflection_max_mm']:.3f} mm, "
        f"peak force {m['force_peak_measured_n']:.0f} N, "
        f"position gap rms {m['position_rms_mm']:.4f} mm, force gap rms {m['force_rms_n']:.2f} N "
        f"({100 * m['force_rms_n'] / m['force_peak_measured_n']:.2f} % of peak), "
        f"profile gap rms {clean_gaps['profile_rms_mm']:.4f} mm"
    )
    assert 1.0 <= m["deflection_max_mm"] <= 4.0  # calibrated: 1.7 mm/kN along x, friction offsets at reversals
    assert 1500.0 <= m["force_peak_measured_n"] <= 2500.0
    assert m["position_rms_mm"] <= 0.05
    assert m["force_rms_n"] <= 0.02 * m["force_peak_measured_n"]
    assert m["samples"] == 990 and m["force_samples"] == 594


@pytest.mark.parametrize("name", list(EFFECT_CASES))
def test_each_effect_opens_a_gap_over_the_clean_replay(
    name: str,
    nominal_path: tuple[np.ndarray, np.ndarray],
    twin_nominal: Twin,
    clean_gaps: dict[str, float],
) -> None:
    value, metric, untouched = EFFECT_CASES[name]
    run, truth = run_lab(
        *nominal_path, scenario="nominal", seed=EFFECT_SEED, spec=TwinSpec(effects=Effects({name: value}))
    )
    assert truth["effects"] == {name: value}
    got = gaps(twin_nominal, run, replay(run, twin=twin_nominal))
    ratio = got[metric] / clean_gaps[metric]
    print(
        f"\n{name}={value}: position rms {got['position_rms_mm']:.4f} mm, "
        f"force rms {got['force_rms_n']:.1f} N, "
        f"profile rms {got['profile_rms_mm']:.4f} mm; {metric} {ratio:.1f}x clean"
    )
    assert ratio >= GAP_FACTOR
    for other in untouched:
        assert got[other] <= 1.5 * clean_gaps[other], other


def test_replay_works_without_truth_json(
    clean_run_dir: Path, clean_replay: ReplayResult, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "no_truth"
    shutil.copytree(clean_run_dir, run_dir)
    (run_dir / "truth.json").unlink()
    assert main(["replay", str(run_dir), "--json", "-"]) == 0
    captured = capsys.readouterr()
    metrics = json.loads(captured.out)  # `--json -`: stdout holds only the JSON, the summary goes to stderr
    assert "position gap rms" in captured.err
    for key in ("position_rms_mm", "force_rms_n", "deflection_max_mm"):
        assert metrics[key] == pytest.approx(clean_replay.metrics[key], rel=1e-9)


def _drop_column(lines: list[str]) -> list[str]:
    return [",".join(line.split(",")[:3]) for line in lines]


def _nan_row(lines: list[str]) -> list[str]:
    parts = lines[5].split(",")
    parts[2] = "nan"
    return [*lines[:5], ",".join(parts), *lines[6:]]


def _swap_rows(lines: list[str]) -> list[str]:
    return [lines[0], lines[1], lines[3], lines[2], *lines[4:]]


def _metres(lines: list[str]) -> list[str]:
    out = [lines[0]]
    for line in lines[1:]:
        t, *xyz = line.split(",")
        out.append(",".join([t, *(f"{float(v) * 1e-3:.7f}" for v in xyz)]))
    return out


BAD_RUNS: dict[str, tuple[str, Callable[[list[str]], list[str]] | None, str]] = {
    "missing file": ("tracker.csv", None, "not found"),
    "wrong columns": ("forces.csv", _drop_column, "fz_n"),
    "nan": ("tracker.csv", _nan_row, "row 5"),
    "time not increasing": ("forces.csv", _swap_rows, "not strictly increasing"),
    "metres in mm": ("commanded.csv", _metres, "metres"),
    "empty file": ("tracker.csv", lambda lines: [], "empty"),
}


@pytest.mark.parametrize("case", list(BAD_RUNS))
def test_replay_cli_fails_clearly_on_a_bad_run(
    case: str, clean_run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    name, edit, text = BAD_RUNS[case]
    run_dir = tmp_path / "bad"
    shutil.copytree(clean_run_dir, run_dir)
    target = run_dir / name
    if edit is None:
        target.unlink()
    else:
        lines = edit(target.read_text().splitlines())
        target.write_text("\n".join(lines) + ("\n" if lines else ""))
    assert main(["replay", str(run_dir)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tx200-twin replay: error:")
    assert name in err and text in err, err


def test_replay_cli_reports_a_missing_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(tmp_path / "nowhere")]) == 2
    assert "nowhere" in capsys.readouterr().err


def test_replay_refuses_a_twin_at_another_placement(clean_run: Run, twin_nominal: Twin) -> None:
    elsewhere = TwinSpec(placement=Placement(yaw_rad=0.1)).build()
    assert elsewhere.placement != run_placement(clean_run.meta)
    with pytest.raises(InputError, match="placement"):
        replay(clean_run, elsewhere)
    assert twin_nominal.effects == Effects()


def test_replay_metrics_measure_a_known_offset() -> None:
    t_cmd = np.linspace(0.0, 2.0, 21)
    commanded = Stream(t_cmd, np.column_stack([0.035 * t_cmd, 0 * t_cmd, 0 * t_cmd]))
    t_trk = np.linspace(0.0, 2.0, 101)
    truth = np.column_stack([0.035 * t_trk, 0 * t_trk, 0 * t_trk])
    measured = truth + np.array([0.0, 0.0, 0.002])
    t_f = np.linspace(0.0, 2.0, 61)
    f_pred = np.tile([0.0, 0.0, 1000.0], (61, 1))
    run = Run(None, {}, commanded, Stream(t_trk, measured), Stream(t_f, f_pred + np.array([30.0, 40.0, 0.0])))
    m = replay_metrics(run, truth + np.array([0.0, 0.0, 0.0015]), f_pred)
    assert m["position_rms_mm"] == pytest.approx(0.5) and m["position_max_mm"] == pytest.approx(0.5)
    assert m["deflection_max_mm"] == pytest.approx(2.0)
    assert m["force_rms_n"] == pytest.approx(50.0) and m["force_max_n"] == pytest.approx(50.0)
    assert m["force_peak_measured_n"] == pytest.approx(np.hypot(1000.0, 50.0))
    assert m["samples"] == 101 and m["force_samples"] == 61
    assert "force_rms_n" not in replay_metrics(Run(None, {}, commanded, Stream(t_trk, measured)), truth, None)


def test_replay_cli_records_a_run_with_a_lost_motion_model(clean_run_dir: Path, tmp_path: Path) -> None:
    from twin.sim.model_file import write_model_file

    model = write_model_file(tmp_path / "m.json", TwinSpec(effects=Effects({"lost_motion": 0.2})))
    rrd = tmp_path / "replay.rrd"
    assert main(["replay", str(clean_run_dir), "--model", str(model), "--rrd", str(rrd)]) == 0
    assert rrd.stat().st_size > 10_000
