"""Tests of the virtual lab (twin/lab/virtual.py) and `tx200-twin lab` (twin/cli/lab.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N, load_cases_csv
from twin.cli import main
from twin.lab.virtual import LabSettings, load_test, run_lab
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.runs.format import RUN_FORMAT, Run
from twin.runs.read import read_run
from twin.runs.write import write_path_csv, write_run
from twin.sim.effects import EFFECTS, Effects
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

RUN_FILES = ("meta.json", "commanded.csv", "tracker.csv", "forces.csv", "part_profile.csv", "truth.json")


@pytest.fixture
def commanded_csv(tmp_path: Path) -> Path:
    """The first pass of the groove as a commanded.csv-format file (cheap to simulate)."""
    path = groove_path()
    keep = path.pass_index == 1
    first = ToolPath(path.t_s[keep], path.p_sheet_m[keep], path.pass_index[keep], path.direction[keep])
    return write_path_csv(first, tmp_path / "commanded.csv")


def test_same_seed_gives_identical_files(clean_run_dir: Path, clean_seed: int, tmp_path: Path) -> None:
    again = tmp_path / "again"
    assert main(["lab", "--scenario", "nominal", "--seed", str(clean_seed), "--out", str(again)]) == 0
    for name in RUN_FILES:
        assert (again / name).read_bytes() == (clean_run_dir / name).read_bytes(), name


def test_different_seed_gives_different_noise_only(
    clean_run: Run, clean_seed: int, nominal_path: tuple[np.ndarray, np.ndarray]
) -> None:
    other, truth = run_lab(*nominal_path, scenario="nominal", seed=clean_seed + 1)
    assert truth["seed"] == clean_seed + 1
    tracker_diff = other.tracker.values - clean_run.tracker.values
    force_diff = other.forces.values - clean_run.forces.values  # type: ignore[union-attr]
    settings = LabSettings()
    # the difference of two independent noise draws: sqrt(2) sigma per axis, within 20 %
    assert np.std(tracker_diff) == pytest.approx(np.sqrt(2) * settings.tracker_noise_m, rel=0.2)
    assert np.std(force_diff) == pytest.approx(np.sqrt(2) * settings.ft_noise_n, rel=0.2)
    np.testing.assert_allclose(other.commanded.values, clean_run.commanded.values, atol=1e-7)


def test_lab_writes_truth_next_to_the_run_and_keeps_it_out_of_meta(
    clean_run_dir: Path, clean_run: Run, clean_seed: int
) -> None:
    truth = json.loads((clean_run_dir / "truth.json").read_text())
    assert truth["effects"] == {}
    assert truth["seed"] == clean_seed
    assert truth["settings"]["tracker_noise_m"] == LabSettings().tracker_noise_m
    assert 1.0 <= truth["max_deflection_mm"] <= 4.0  # calibrated: 1.7 mm/kN along x, friction at reversals
    assert 1500.0 <= truth["peak_force_n"] <= 2500.0
    assert clean_run.meta["format"] == RUN_FORMAT
    assert "effects" not in clean_run.meta and "truth" not in clean_run.meta
    assert clean_run.tracker_rate_hz == 50.0 and clean_run.sensor_rate_hz == 30.0


def test_lab_truth_records_the_hidden_effects(first_pass_path: tuple[np.ndarray, np.ndarray]) -> None:
    effects = Effects({"tool_length_offset": 1.0, "force_scale": 1.5})
    run, truth = run_lab(*first_pass_path, scenario="probe", seed=3, spec=TwinSpec(effects=effects))
    assert truth["effects"] == {"tool_length_offset": 1.0, "force_scale": 1.5}
    assert truth["effect_parameters"]["tool_length_offset"] == {"tool_length_offset_mm": 1.0}
    assert run.scenario == "probe"
    assert "effects" not in run.meta


def test_compensated_scenario_without_commanded_fails_clearly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["lab", "--scenario", "compensated", "--seed", "1", "--out", str(tmp_path / "run")])
    assert code == 2
    assert "--commanded" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_compensated_scenario_runs_a_given_commanded_path(
    commanded_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "comp"
    argv = [
        "lab",
        "--scenario",
        "compensated",
        "--commanded",
        str(commanded_csv),
        "--seed",
        "5",
        "--out",
        str(out),
    ]
    assert main([*argv, "--json", "-"]) == 0
    summary = json.loads(capsys.readouterr().out)  # `--json -`: stdout is pure JSON
    assert summary["scenario"] == "compensated" and summary["tracker_samples"] == 106
    run = read_run(out)
    assert run.scenario == "compensated"
    assert run.commanded.values[-1, 0] == pytest.approx(0.035)


def test_lab_refuses_to_overwrite_a_run_without_the_flag(
    commanded_csv: Path, clean_run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = {name: (clean_run_dir / name).read_bytes() for name in RUN_FILES}
    code = main(["lab", "--scenario", "nominal", "--seed", "9", "--out", str(clean_run_dir)])
    assert code == 2
    err = capsys.readouterr().err
    assert str(clean_run_dir) in err and "--overwrite" in err
    assert {name: (clean_run_dir / name).read_bytes() for name in RUN_FILES} == before
    out = tmp_path / "run"
    base = ["lab", "--scenario", "compensated", "--commanded", str(commanded_csv), "--out", str(out)]
    assert main([*base, "--seed", "1"]) == 0
    first = (out / "tracker.csv").read_bytes()
    assert main([*base, "--seed", "2", "--overwrite"]) == 0
    assert (out / "tracker.csv").read_bytes() != first


def test_lab_rejects_an_unknown_effect_listing_the_valid_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        [
            "lab",
            "--scenario",
            "nominal",
            "--seed",
            "1",
            "--effect",
            "backlash=1",
            "--out",
            str(tmp_path / "r"),
        ]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert all(name in err for name in EFFECTS)


def test_loadtest_writes_the_five_table_4_2_cases(
    twin_nominal: Twin, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "loads.csv"
    assert main(["lab", "--scenario", "loadtest", "--seed", "4", "--out", str(out)]) == 0
    assert "5 load cases" in capsys.readouterr().out
    f_n, d_m = load_cases_csv(out)
    np.testing.assert_allclose(f_n, THESIS_TABLE_4_2_LOADS_N)
    expected = np.array([twin_nominal.static_deflection(f) for f in f_n])  # Hooke with joint friction
    assert np.abs(d_m - expected).max() < 1e-4  # tracker noise, 2 readings of 20 µm
    assert main(["lab", "--scenario", "loadtest", "--seed", "4", "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_load_test_noise_follows_the_seed() -> None:
    loads = THESIS_TABLE_4_2_LOADS_N[:2]
    _, a = load_test(loads, seed=1)
    _, b = load_test(loads, seed=1)
    _, c = load_test(loads, seed=2)
    np.testing.assert_array_equal(a, b)
    assert 0.0 < np.abs(a - c).max() < 2e-4


def test_written_lab_run_reads_back(first_pass_path: tuple[np.ndarray, np.ndarray], tmp_path: Path) -> None:
    run, truth = run_lab(*first_pass_path, scenario="nominal", seed=8)
    back = read_run(write_run(tmp_path / "r", run, truth=truth))
    np.testing.assert_allclose(back.tracker.values, run.tracker.values, atol=1e-7)
    np.testing.assert_allclose(back.forces.values, run.forces.values, atol=1e-3)  # type: ignore[union-attr]
    assert back.part_profile is not None
