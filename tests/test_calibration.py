"""The calibrated twin against the thesis's measurements, and the reproduction table.

Measured at the shipped values (`pytest -s` prints them; docs/calibration.json holds them): C_R(1) and C_R(2) off
the thesis (Frobenius, noise-free twin experiments), peak Fz, CNC depth after springback, failed-run gain.
`tx200-twin calibrate` (slow test) refits from the pre-calibration model; `calibrate --loo` (slow test) repeats the
13 leave-one-out refits.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from doc_numbers import page_differences

from twin.analysis.calibration.fit import PARAMETERS, TwinEvaluator, calibrate, to_values
from twin.analysis.calibration.loo import leave_one_out
from twin.analysis.calibration.targets import TARGETS, TwinMeasurements
from twin.analysis.identify.cartesian import (
    THESIS_CR1_MM_PER_KN,
    THESIS_CR2_MM_PER_KN,
    THESIS_TABLE_4_2_LOADS_N,
    fit_kr_load_cases,
)
from twin.cli import main
from twin.errors import InputError
from twin.process.part.springback import last_contact_force, unloaded_profile
from twin.runs.read import read_run
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

REPO = Path(__file__).resolve().parents[1]


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(np.asarray(a) - b) / np.linalg.norm(b))


@pytest.fixture(scope="module")
def shipped() -> TwinMeasurements:
    evaluator = TwinEvaluator()
    return evaluator.measure(evaluator.start_vector())


def test_shipped_twin_reproduces_the_thesis_measurements(shipped: TwinMeasurements) -> None:
    cr1 = rel(shipped.cr1_mm_per_kn, THESIS_CR1_MM_PER_KN)
    cr2 = rel(shipped.cr2_mm_per_kn, THESIS_CR2_MM_PER_KN)
    v = shipped.values
    print(
        f"\nC_R(1) {100 * cr1:.1f} % off, C_R(2) {100 * cr2:.1f} % off, peak Fz {v['peak_fz']:.0f} N, "
        f"CNC depth {v['depth_cnc']:.2f} mm, failed-run gain {v['gain_failed_run']:.3f}"
    )
    assert cr1 < 0.20 and cr2 < 0.20
    assert 1600.0 <= v["peak_fz"] <= 2400.0
    assert v["depth_cnc"] == pytest.approx(8.7, abs=0.4)
    assert v["gain_failed_run"] == pytest.approx(0.5, abs=0.1)
    # every target within 3 sigma
    for t in TARGETS:
        assert abs(v[t.name] - t.thesis) < 3.0 * t.sigma, t.name


def test_no_reciprocal_robot_comes_within_20_percent_of_the_thesis_cr1() -> None:
    """The antisymmetric part of C_R(1) is orthogonal to every symmetric matrix: it alone is 21 % of it."""
    antisymmetric = 0.5 * (THESIS_CR1_MM_PER_KN - THESIS_CR1_MM_PER_KN.T)
    floor = float(np.linalg.norm(antisymmetric) / np.linalg.norm(THESIS_CR1_MM_PER_KN))
    assert floor == pytest.approx(0.21, abs=0.005)
    best_symmetric = 0.5 * (THESIS_CR1_MM_PER_KN + THESIS_CR1_MM_PER_KN.T)
    assert rel(best_symmetric, THESIS_CR1_MM_PER_KN) == pytest.approx(floor, rel=1e-12)


def test_joint_friction_is_what_makes_the_load_test_stiffness_asymmetric() -> None:
    frictionless = TwinSpec(joint_friction_nm=np.zeros(6)).build()
    calibrated = Twin(TwinSpec())
    asym = []
    for twin in (frictionless, calibrated):
        d = np.array([twin.static_deflection(f) for f in THESIS_TABLE_4_2_LOADS_N])
        k = fit_kr_load_cases(THESIS_TABLE_4_2_LOADS_N, d).k_r_n_per_m
        c_xz = np.linalg.inv(k[np.ix_([0, 2], [0, 2])])
        asym.append(abs(c_xz[0, 1] - c_xz[1, 0]) / np.linalg.norm(c_xz))
    print(f"\nC_R(1) x-z asymmetry |c_xz - c_zx|/|C|: frictionless {asym[0]:.4f}, calibrated {asym[1]:.3f}")
    assert asym[0] < 0.01  # Maxwell-Betti: a frictionless robot's load test is reciprocal
    assert asym[1] > 0.05  # the thesis's: |0.19 - 0.79| / 2.02 = 0.30


def test_cnc_scenario_writes_a_part_8_7_mm_deep(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cnc"
    assert main(["lab", "--scenario", "cnc", "--seed", "1", "--out", str(out), "--json", "-"]) == 0
    summary = json.loads(capsys.readouterr().out)
    run = read_run(out)
    assert run.part_profile is not None and run.forces is not None
    depth_mm = -1e3 * float(np.min(run.part_profile[1]))
    assert depth_mm == pytest.approx(8.7, abs=0.4)
    assert summary["formed_depth_mm"] == pytest.approx(depth_mm, abs=1e-3)
    assert run.meta["sensor_rate_hz"] == 10.0 and run.scenario == "cnc"
    np.testing.assert_allclose(np.diff(run.forces.t_s), 0.1, atol=1e-9)
    # the rigid machine is where it was commanded, within its 15 µm accuracy
    tracker_cmd = np.interp(run.tracker.t_s, run.commanded.t_s, run.commanded.values[:, 2])
    assert np.max(np.abs(run.tracker.values[:, 2] - tracker_cmd)) < 1e-4
    assert main(["lab", "--scenario", "cnc", "--seed", "1", "--effect", "force_scale=2", "--out",
                 str(tmp_path / "x")]) == 2


def test_springback_lifts_the_bottom_by_the_last_force_over_the_unloading_stiffness() -> None:
    x_grid = np.linspace(-0.02, 0.02, 401)
    loaded = np.where(np.abs(x_grid) < 0.01, -0.005, 0.0)
    x_tool = np.array([-0.01, 0.0, 0.01, 0.0])
    fz = np.array([100.0, 200.0, 300.0, 1000.0])  # the last pass over x = 0 pressed with 1000 N
    last = last_contact_force(x_grid, x_tool, fz, 7.5e-3)
    assert last[np.argmin(np.abs(x_grid))] == 1000.0
    assert last[0] == 0.0  # never touched
    after = unloaded_profile(x_grid, loaded, x_tool, fz, k_unload_n_per_m=1e6, radius_m=7.5e-3)
    assert after[np.argmin(np.abs(x_grid))] == pytest.approx(-0.005 + 1e-3)
    assert np.all(after <= 0.0)  # never above the flat sheet
    with pytest.raises(InputError, match="k_unload"):
        unloaded_profile(x_grid, loaded, x_tool, fz, k_unload_n_per_m=0.0, radius_m=7.5e-3)
    with pytest.raises(InputError, match="equal-length"):
        last_contact_force(x_grid, x_tool, fz[:2], 7.5e-3)


def test_the_shipped_reproduction_document_is_the_generated_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = tmp_path / "reproduction.md"
    calibration = REPO / "docs" / "calibration.json"
    assert main(["reproduce", "--calibration", str(calibration), "--markdown", str(doc), "--json", "-"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    shipped = (REPO / "docs" / "thesis-reproduction.md").read_text(encoding="utf-8")
    assert page_differences(shipped, doc.read_text(encoding="utf-8")) == [], (
        "docs/thesis-reproduction.md is stale: run `tx200-twin reproduce --calibration docs/calibration.json "
        "--markdown docs/thesis-reproduction.md`"
    )
    by_name = {r["quantity"]: r for r in rows}
    assert by_name["C_R(2) (Eq. 4.27b)"]["relative_difference"] < 0.2
    assert by_name["C_R(1) x–z, y held (Eq. 4.27a)"]["relative_difference"] < 0.2
    assert by_name["residual of the corrected run, rms (§5.1.2)"]["fitted"].startswith("no")
    assert by_name["C_R(2) (Eq. 4.27b)"]["fitted"].startswith("yes")
    assert np.shape(by_name["C_R(2) (Eq. 4.27b)"]["leave_one_out"]) == (2, 2)


def shipped_calibration() -> dict[str, Any]:
    return json.loads((REPO / "docs" / "calibration.json").read_text(encoding="utf-8"))


def test_the_shipped_calibration_file_is_the_shipped_model_and_its_fitted_values(shipped: TwinMeasurements) -> None:
    """docs/calibration.json (`calibrate --loo --json`): its parameters are the model's, its fitted values the
    noise-free twin experiments at them; the leave-one-out rows cover every target, two held at their prior."""
    cal = shipped_calibration()
    assert cal["targets_count"] == len(TARGETS) == 13 and cal["degrees_of_freedom"] == 13 - len(PARAMETERS) == 4
    model = to_values(TwinEvaluator().start_vector())
    for name, value in zip(PARAMETERS, model, strict=True):
        assert abs(cal["parameters"][name] - value) <= max(0.1 * cal["sigma"][name], 1e-3 * value), name
    loo = {p["target"]: p for p in cal["leave_one_out"]}
    assert list(loo) == [t.name for t in TARGETS]
    for t in TARGETS:
        assert loo[t.name]["fitted"] == pytest.approx(shipped.values[t.name], rel=1e-6, abs=1e-9), t.name
        assert loo[t.name]["thesis"] == t.thesis
    sole = {name: tuple(p["sole"]) for name, p in loo.items() if p["sole"]}
    assert sole == {"c_yy": ("k_q1_nm_per_rad",), "depth_cnc": ("k_unload_n_per_m",)}
    residual = np.array([(shipped.values[t.name] - t.thesis) / t.sigma for t in TARGETS])
    assert cal["chi2_reduced"] == pytest.approx(float(residual @ residual) / 4, rel=0.02)


@pytest.mark.slow
def test_the_leave_one_out_predictions_repeat() -> None:
    """The 13 refits (about 3 minutes on 2 cores) give the shipped file's predictions."""
    fresh = leave_one_out()
    shipped_loo = {p["target"]: p for p in shipped_calibration()["leave_one_out"]}
    assert fresh.dof == 4
    for p, t in zip(fresh.predictions, TARGETS, strict=True):
        print(f"{p.target:16s} thesis {p.thesis:9.3f} fitted {p.fitted:9.3f} left out {p.predicted:9.3f} {p.sole}")
        assert p.predicted == pytest.approx(shipped_loo[p.target]["predicted"], abs=0.05 * t.sigma), p.target
        assert tuple(p.sole) == tuple(shipped_loo[p.target]["sole"])


@pytest.mark.slow
def test_calibration_from_the_old_default_lands_on_the_shipped_values() -> None:
    start = np.array([2.234e6, 2.110e6, 1.210e6, 2.002e6, 1.3e6, 0.15e6, 0.0, 0.0, 0.0])
    cal = calibrate(start=start)
    shipped = TwinEvaluator()
    values = to_values(shipped.start_vector())
    for name, value in zip(PARAMETERS, values, strict=True):
        assert abs(cal.values[name] - value) <= max(cal.sigma[name], 1e-3 * value), name
    assert cal.chi2_reduced < 3.0
