"""Monte Carlo sweep (`twin.apps.sweep`, `tx200-twin sweep`): seeded draws, calibration input, results."""

from __future__ import annotations

import json

import numpy as np
import pytest

from twin.apps.sweep import PARAMETERS, Uncertainty, model_uncertainty, run_sweep
from twin.base.csvio import write_table
from twin.cli import main
from twin.errors import InputError
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.sim.quasi_static import Twin


@pytest.fixture(scope="module")
def short_path() -> ToolPath:
    """Passes 1-2 of the groove (~280 samples): a cheap ideal path."""
    path = groove_path()
    keep = path.pass_index <= 2
    return ToolPath(t_s=path.t_s[keep], p_sheet_m=path.p_sheet_m[keep], pass_index=path.pass_index[keep],
                    direction=path.direction[keep])


def test_draws_are_seeded_and_clipped_to_physical_values(twin_nominal: Twin) -> None:
    u = model_uncertainty(twin_nominal)
    wide = Uncertainty(u.mean, 3.0 * u.mean, "wide")  # σ = 300 %: many draws would go negative
    a, b, c = wide.draw(400, seed=1), wide.draw(400, seed=1), wide.draw(400, seed=2)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    friction = np.array([name.startswith("friction") for name in PARAMETERS])
    assert np.all(a[:, friction] >= 0.0) and np.any(a[:, friction & (u.mean > 0)] == 0.0)
    assert np.all(a[:, ~friction] >= 0.1 * u.mean[~friction] - 1e-12)


def test_model_uncertainty_takes_the_calibration_values_it_names(twin_nominal: Twin) -> None:
    calibration = {"parameters": {"k_q2_nm_per_rad": 1.5e6, "friction3_nm": 250.0},
                   "sigma": {"k_q2_nm_per_rad": 2e5, "friction3_nm": 40.0}}
    u = model_uncertainty(twin_nominal, calibration, "cal.json")
    j, f = PARAMETERS.index("k_q2_nm_per_rad"), PARAMETERS.index("friction3_nm")
    assert (u.mean[j], u.sigma[j], u.mean[f], u.sigma[f]) == (1.5e6, 2e5, 250.0, 40.0)
    k1 = PARAMETERS.index("k_q1_nm_per_rad")  # not named: the model's value, default relative σ
    assert u.mean[k1] == twin_nominal.joint_stiffness[0] and u.sigma[k1] == pytest.approx(0.1 * u.mean[k1])
    assert u.source == "cal.json"


@pytest.mark.parametrize(
    ("calibration", "message"),
    [({"parameters": {}}, "'sigma'"), ({"parameters": {"friction2_nm": 1.0}, "sigma": {}}, "friction2_nm"),
     ({"parameters": {"k_load_n_per_m": -1.0}, "sigma": {"k_load_n_per_m": 1.0}}, "k_load_n_per_m")],
)
def test_bad_calibration_names_the_file_and_the_parameter(twin_nominal: Twin, calibration, message) -> None:
    with pytest.raises(InputError, match=message) as err:
        model_uncertainty(twin_nominal, calibration, "cal.json")
    assert "cal.json" in str(err.value)


def test_without_uncertainty_every_draw_is_the_nominal_prediction(short_path: ToolPath,
                                                                    twin_nominal: Twin) -> None:
    u = model_uncertainty(twin_nominal)
    result = run_sweep(2, workers=1, uncertainty=Uncertainty(u.mean, 0.0 * u.sigma, "exact"), path=short_path)
    # equal to far below the Newton tolerance (1e-9 rad): 5e-18 m apart with the sliding tool's stick band
    np.testing.assert_allclose(result.rms_m, result.nominal_rms_m, rtol=1e-9, atol=1e-15)
    assert result.nominal_rms_m < 5e-5  # the compensated short path lands within 0.05 mm (friction stalls it)


def test_sweep_result_does_not_depend_on_the_number_of_workers(short_path: ToolPath) -> None:
    one = run_sweep(4, seed=3, workers=1, path=short_path)
    two = run_sweep(4, seed=3, workers=2, chunk=1, path=short_path)
    np.testing.assert_array_equal(one.parameters, two.parameters)
    np.testing.assert_allclose(two.rms_m, one.rms_m, rtol=1e-12)
    assert np.ptp(one.rms_m) > 0.0 and np.all(one.max_m >= one.rms_m)
    summary = two.summary()
    assert summary["draws"] == 4 and summary["workers"] == 2 and summary["replays_per_s_per_core"] > 0.0
    assert summary["rms_mm"]["p5"] <= summary["rms_mm"]["p50"] <= summary["rms_mm"]["p95"]


def test_sweep_cli_writes_json_and_figure(tmp_path, short_path: ToolPath) -> None:
    ideal = tmp_path / "ideal.csv"
    write_table(ideal, {"t_s": short_path.t_s, "x_mm": 1e3 * short_path.p_sheet_m[:, 0],
                        "y_mm": 1e3 * short_path.p_sheet_m[:, 1], "z_mm": 1e3 * short_path.p_sheet_m[:, 2]})
    out, figure = tmp_path / "sweep.json", tmp_path / "sweep.png"
    code = main(["sweep", "--draws", "3", "--workers", "1", "--ideal", str(ideal), "--figure", str(figure),
                 "--json", str(out)])
    payload = json.loads(out.read_text())
    assert code == 0 and figure.stat().st_size > 10_000
    assert payload["draws"] == 3 and len(payload["per_draw"]["rms_mm"]) == 3
    assert payload["uncertainty"]["source"] == "model defaults"


def test_scaled_pass_tables_equal_a_refit_of_the_scaled_history() -> None:
    """The sweep rescales the history's tables per draw instead of refitting them (PCHIP is homogeneous)."""
    from dataclasses import replace

    from twin.process.fe.load import default_force_history
    from twin.process.force.pass_tables import scaled_tables
    from twin.process.force.table import SheetForceField

    history = default_force_history()
    base = SheetForceField(history).pass_tables
    for scale in (0.7, 1.3):
        refit = SheetForceField(replace(history, f_sheet_n=scale * history.f_sheet_n)).pass_tables
        for a, b in zip(scaled_tables(base, scale), refit, strict=True):
            np.testing.assert_allclose(a.fz, b.fz, rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(a.ratio, b.ratio, rtol=1e-12, atol=1e-12)
            np.testing.assert_array_equal(a.delta_plan, b.delta_plan)
