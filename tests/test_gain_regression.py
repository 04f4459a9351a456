"""THE GAIN REGRESSION TEST: the whole pipeline compensates with gain 1, and the thesis's mistake
(a half-symmetric FE history used as full, thesis sec. 5.1) gives 0.5 and is caught by `check`.

Pipeline, in process: shipped FE history -> force field -> lab load test (Table 4.2 loads, tracker noise)
-> Method 1 K_R -> Eq. 4.28 formula compensation; and history -> twin compensation. The compensated paths
are then run in the virtual lab (no hidden effects) and checked against the ideal path.

`pytest -s` prints what this pipeline measures on the calibrated robot (seed 1 load test, seed 2 lab runs):
the gains of both compensations, the lab residuals after each, `check`'s gains, and the mistake's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pytest

from twin.analysis.check import CheckResult, check_run
from twin.analysis.compensate import (
    Compensation,
    compensate_formula,
    compensate_twin,
    compliance_from_stiffness,
    gain_of,
)
from twin.analysis.compensation_record import CompensationRecord
from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N, fit_kr_load_cases
from twin.base.resources import data_file
from twin.errors import SymmetryError
from twin.lab.virtual import load_test, run_lab
from twin.process.description import Process
from twin.process.fe.load import ForceHistory, default_force_history, load_force_history
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.sim.spec import TwinSpec

GAIN_TOL = 0.02
# Bounds on the lab residual (tracker noise 0.02 mm per axis alone gives 0.035 mm rms of the 3-D norm). The
# calibrated robot's joint friction flips its offset within one sample at each reversal: the twin's command
# cannot follow a step there, so its largest residual sits on those few samples, while 95 %
# of the samples stay within TWIN_P95_MM.
TWIN_RMS_MM, TWIN_MAX_MM, TWIN_P95_MM = 0.06, 0.4, 0.08
# The formula keeps the home compliance along the whole groove, its K_R carries the load test's noise, and a
# linear C cannot cancel the friction offsets: bounds with margin over what it leaves (`pytest -s`).
FORMULA_RMS_MM, FORMULA_MAX_MM = 0.5, 1.5
# Method 1's load test starts from rest, so each joint's friction holds back the first τ_f of its torque and
# the robot reads stiffer than it is while forming (joints sliding): `check` finds the formula run
# under-corrected (`pytest -s` prints the gain); a gain this far from 0.5 is no force-scale mistake.
FORMULA_CHECK_GAIN = (0.75, 0.95)


@dataclass(frozen=True)
class Pipeline:
    path: ToolPath
    history: ForceHistory
    f_reference_n: np.ndarray
    c_method1_m_per_n: np.ndarray
    c_twin_m_per_n: np.ndarray
    formula: Compensation
    twin: Compensation


def lab_check(
    comp: Compensation, path: ToolPath, seed: int, record: CompensationRecord | None = None
) -> CheckResult:
    """Run a compensated path in the lab (no hidden effects) and check it against the ideal path; with `record`,
    the run carries what the compensation used (as `lab --commanded` writes it)."""
    run, _truth = run_lab(comp.t_s, comp.p_cmd_sheet_m, scenario="compensated", seed=seed)
    if record is not None:
        run = replace(run, meta={**run.meta, "compensation": record.to_json()})
    return check_run(run, path.t_s, path.p_sheet_m)


@pytest.fixture(scope="module")
def pipeline() -> Pipeline:
    path = groove_path()
    history = default_force_history()  # shipped half-model file, declared half: forces doubled
    f_reference = SheetForceField(history).rigid_forces(path)
    loads, deflections = load_test(THESIS_TABLE_4_2_LOADS_N, seed=1)
    c_method1 = compliance_from_stiffness(fit_kr_load_cases(loads, deflections).k_r_n_per_m)
    f_ideal = SheetForceField(history).rigid_forces(path)
    formula = compensate_formula(path.t_s, path.p_sheet_m, f_ideal, c_method1)
    twin = TwinSpec(process=Process(history=history)).build()
    twin_comp = compensate_twin(path.t_s, path.p_sheet_m, twin)
    c_twin = twin.kinematics.compliance(twin.kinematics.q_home)
    return Pipeline(path, history, f_reference, c_method1, c_twin, formula, twin_comp)


@pytest.fixture(scope="module")
def half_as_full() -> ForceHistory:
    """The thesis's mistake: the half-symmetric export declared full, column check skipped."""
    return load_force_history(data_file("fe_force_history.csv"), symmetry="full", trust_columns=False)


@pytest.fixture(scope="module")
def mistaken_twin_compensation(pipeline: Pipeline, half_as_full: ForceHistory) -> Compensation:
    return compensate_twin(
        pipeline.path.t_s, pipeline.path.p_sheet_m, TwinSpec(process=Process(history=half_as_full)).build()
    )


# --- gain 1 -----------------------------------------------------------------------------------------------


def test_formula_pipeline_has_gain_one(pipeline: Pipeline) -> None:
    gain = gain_of(pipeline.formula, pipeline.f_reference_n, pipeline.c_method1_m_per_n)
    print(f"\nformula (Method 1 K_R from the lab load test) gain {gain:.4f}")
    assert gain == pytest.approx(1.0, abs=GAIN_TOL)


def test_twin_pipeline_has_gain_one(pipeline: Pipeline) -> None:
    gain = gain_of(pipeline.twin, pipeline.f_reference_n, pipeline.c_twin_m_per_n)
    print(f"\ntwin gain {gain:.4f} after {pipeline.twin.iterations} iterations")
    assert gain == pytest.approx(1.0, abs=GAIN_TOL)
    # 14 measured: it stalls 0.013-0.019 mm rms above its 2 µm goal (friction's dead band at the reversals)
    assert pipeline.twin.iterations <= 15


def test_lab_runs_of_both_compensations_meet_the_ideal_path(pipeline: Pipeline) -> None:
    twin = lab_check(pipeline.twin, pipeline.path, seed=2)
    formula = lab_check(pipeline.formula, pipeline.path, seed=2)
    s_twin: dict[str, Any] = twin.summary()
    s_formula: dict[str, Any] = formula.summary()
    print(
        f"\nlab residual: formula {s_formula['residual_rms_mm']:.4f} mm rms / "
        f"{s_formula['residual_max_mm']:.4f} mm max (check gain {formula.gain:.4f}); "
        f"twin {s_twin['residual_rms_mm']:.4f} mm rms / "
        f"{s_twin['residual_max_mm']:.4f} mm max (check gain {twin.gain:.4f})"
    )
    assert s_twin["residual_rms_mm"] <= TWIN_RMS_MM
    assert s_twin["residual_max_mm"] <= TWIN_MAX_MM
    assert twin.gain == pytest.approx(1.0, abs=GAIN_TOL)
    assert s_formula["residual_rms_mm"] <= FORMULA_RMS_MM
    assert s_formula["residual_max_mm"] <= FORMULA_MAX_MM
    assert FORMULA_CHECK_GAIN[0] < formula.gain < FORMULA_CHECK_GAIN[1]
    assert float(np.percentile(np.linalg.norm(twin.residual_m, axis=1), 95)) * 1e3 <= TWIN_P95_MM
    assert s_twin["residual_rms_mm"] < s_formula["residual_rms_mm"]


# --- the thesis's mistake: gain 0.5 ------------------------------------------------------------------------


def test_half_file_declared_full_is_refused_without_the_escape_hatch() -> None:
    with pytest.raises(SymmetryError, match="half-symmetric"):
        load_force_history(data_file("fe_force_history.csv"), symmetry="full")


def test_half_file_declared_full_carries_half_the_physical_force(
    pipeline: Pipeline, half_as_full: ForceHistory
) -> None:
    np.testing.assert_allclose(half_as_full.f_sheet_n[:, [0, 2]], 0.5 * pipeline.history.f_sheet_n[:, [0, 2]])


def test_formula_with_the_mistaken_history_has_gain_one_half(
    pipeline: Pipeline, half_as_full: ForceHistory
) -> None:
    f_half = SheetForceField(half_as_full).rigid_forces(pipeline.path)
    comp = compensate_formula(pipeline.path.t_s, pipeline.path.p_sheet_m, f_half, pipeline.c_method1_m_per_n)
    assert gain_of(comp, pipeline.f_reference_n, pipeline.c_method1_m_per_n) == pytest.approx(0.5, abs=0.05)


def test_twin_with_the_mistaken_history_has_gain_one_half(
    pipeline: Pipeline, mistaken_twin_compensation: Compensation
) -> None:
    gain = gain_of(mistaken_twin_compensation, pipeline.f_reference_n, pipeline.c_twin_m_per_n)
    print(f"\nmistaken (half as full) twin compensation gain {gain:.4f}")
    assert gain == pytest.approx(0.5, abs=0.05)


def test_check_catches_the_mistake_on_the_lab_run(
    pipeline: Pipeline, mistaken_twin_compensation: Compensation, half_as_full: ForceHistory
) -> None:
    comp = mistaken_twin_compensation
    f_used = TwinSpec(process=Process(history=half_as_full)).build().simulate(comp.t_s, comp.p_cmd_sheet_m).f_sheet_n
    record = CompensationRecord("twin", comp.t_s, f_used, half_as_full.symmetry, half_as_full.column_symmetry)
    result = lab_check(comp, pipeline.path, seed=3, record=record)
    summary: dict[str, Any] = result.summary()
    print(
        f"\nmistaken run: check gain {result.gain:.4f}, residual {summary['residual_rms_mm']:.3f} mm rms; "
        f"{result.diagnosis}"
    )
    assert result.gain == pytest.approx(0.5, abs=0.1)
    assert result.cause == "half_history_as_full" and "force scale of 0.5" in result.diagnosis
    assert summary["residual_rms_mm"] > 5 * TWIN_RMS_MM  # half the deflection (~1.4 mm) left in the part
