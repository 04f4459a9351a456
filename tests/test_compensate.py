"""Tests of the offline compensation (twin/analysis/compensate.py): Eq. 4.28, the twin iteration and the gain.

The whole-groove pipeline (lab runs of the compensated paths, the 0.5 regression) is in
tests/test_gain_regression.py; here the twin iteration runs on the groove's first pass only (142 samples).
"""

from __future__ import annotations

import numpy as np
import pytest

from twin.analysis.compensate import (
    TWIN_TOL_M,
    Compensation,
    compensate_formula,
    compensate_twin,
    compliance_from_stiffness,
    gain_of,
)
from twin.errors import CompensationError, InputError
from twin.process.fe.load import default_force_history
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

XZ = np.ix_([0, 2], [0, 2])


def first_pass() -> ToolPath:
    """The groove's first pass (x from -35 to 35 mm, z from 0 to -1 mm)."""
    path = groove_path()
    keep = path.pass_index == 1
    return ToolPath(path.t_s[keep], path.p_sheet_m[keep], path.pass_index[keep], path.direction[keep])


@pytest.fixture(scope="module")
def twin() -> Twin:
    return Twin(TwinSpec())


@pytest.fixture(scope="module")
def short_path() -> ToolPath:
    return first_pass()


@pytest.fixture(scope="module")
def short_compensation(twin: Twin, short_path: ToolPath) -> Compensation:
    return compensate_twin(short_path.t_s, short_path.p_sheet_m, twin)


# --- compliance_from_stiffness ---------------------------------------------------------------------------


def test_2x2_stiffness_is_inverted_and_embedded_in_xz_with_zero_y() -> None:
    k_xz = np.array([[1.9e6, -1.2e6], [-1.2e6, 1.7e6]])  # [N/m], the twin's x-z block at home, rounded
    c = compliance_from_stiffness(k_xz)
    assert c.shape == (3, 3)
    np.testing.assert_allclose(c[XZ], np.linalg.inv(k_xz), rtol=1e-12)
    assert np.all(c[1, :] == 0.0) and np.all(c[:, 1] == 0.0)


def test_3x3_stiffness_is_inverted_whole() -> None:
    k = np.array([[1.92e6, -4e3, -1.18e6], [-4e3, 8.1e5, 4e3], [-1.18e6, 4e3, 1.71e6]])
    c = compliance_from_stiffness(k)
    np.testing.assert_allclose(c @ k, np.eye(3), atol=1e-10)
    assert c[1, 1] > 0  # y is free, not clamped to zero as in the 2x2 case


@pytest.mark.parametrize(
    "k",
    [
        np.array([[1e6, 2e6], [0.5e6, 1e6]]),  # rank 1
        np.ones((3, 3)) * 1e6,  # rank 1
        np.zeros((2, 2)),  # all zero (raised numpy's LinAlgError before the <= fix)
        np.zeros((3, 3)),
    ],
)
def test_singular_stiffness_raises_input_error(k: np.ndarray) -> None:
    with pytest.raises(InputError, match="singular"):
        compliance_from_stiffness(k)


@pytest.mark.parametrize("k", [np.eye(4), np.eye(3)[:2], np.array([[1e6, np.nan], [0.0, 1e6]])])
def test_stiffness_of_wrong_shape_or_nan_raises_input_error(k: np.ndarray) -> None:
    with pytest.raises(InputError, match=r"2x2 .* or 3x3"):
        compliance_from_stiffness(k)


# --- formula (Eq. 4.28) ----------------------------------------------------------------------------------


def test_formula_commands_against_the_sheet_force() -> None:
    t = np.array([0.0, 0.1])
    p_ideal = np.array([[0.0, 0.0, 0.0], [0.001, 0.0, -0.001]])
    f = np.array([[0.0, 0.0, 1000.0], [500.0, 0.0, 1000.0]])  # sheet pushes the tool up (+z)
    c = np.diag([1e-6, 0.0, 2e-6])  # [m/N]
    comp = compensate_formula(t, p_ideal, f, c)
    # U_ALG = U_ID - C f: 1 kN up -> command 2 mm deeper; 500 N along +x -> command 0.5 mm back
    np.testing.assert_allclose(comp.correction_m, [[0.0, 0.0, -0.002], [-0.0005, 0.0, -0.002]], atol=1e-15)
    assert comp.method == "formula" and comp.iterations == 0 and comp.predicted_residual_m is None


def test_formula_rejects_mismatched_shapes() -> None:
    with pytest.raises(InputError, match=r"must both be \(n, 3\)"):
        compensate_formula(np.zeros(3), np.zeros((3, 3)), np.zeros((2, 3)), np.eye(3))


# --- gain -------------------------------------------------------------------------------------------------


def test_gain_is_one_for_the_physical_force_and_half_for_the_half_model_force() -> None:
    path = groove_path()
    f_physical = SheetForceField(default_force_history()).rigid_forces(path)
    c = compliance_from_stiffness(np.array([[1.9e6, -1.2e6], [-1.2e6, 1.7e6]]))
    right = compensate_formula(path.t_s, path.p_sheet_m, f_physical, c)
    halved = compensate_formula(path.t_s, path.p_sheet_m, 0.5 * f_physical, c)
    assert gain_of(right, f_physical, c) == pytest.approx(1.0, abs=1e-12)
    assert gain_of(halved, f_physical, c) == pytest.approx(0.5, abs=1e-12)


# --- twin iteration ---------------------------------------------------------------------------------------


def test_twin_compensation_converges_below_tolerance(short_compensation: Compensation) -> None:
    comp = short_compensation
    assert comp.method == "twin"
    assert 2 <= comp.iterations <= 12
    assert comp.predicted_residual_m is not None
    assert np.max(np.abs(comp.predicted_residual_m)) < TWIN_TOL_M
    assert len(comp.history_m) == comp.iterations
    assert comp.history_m[-1] < 1e-3 * comp.history_m[0]  # from ~mm to well below the tolerance
    print(
        f"\nfirst pass: twin iterations {comp.iterations}, rms residual per iteration [mm] "
        f"{[round(1e3 * h, 5) for h in comp.history_m]}"
    )


def test_twin_command_makes_the_twin_tip_follow_the_ideal_path(
    twin: Twin, short_path: ToolPath, short_compensation: Compensation
) -> None:
    sim = twin.simulate(short_compensation.t_s, short_compensation.p_cmd_sheet_m)
    assert np.max(np.abs(sim.p_sheet_m - short_path.p_sheet_m)) < TWIN_TOL_M
    # the correction is of the order of the uncompensated deflection (about a millimetre on pass 1)
    assert 0.3e-3 < np.max(np.linalg.norm(short_compensation.correction_m, axis=1)) < 3e-3


def test_twin_compensation_gain_is_near_one_with_the_twin_compliance(
    twin: Twin, short_path: ToolPath, short_compensation: Compensation
) -> None:
    f_ref = SheetForceField(default_force_history()).rigid_forces(short_path)
    c_home = twin.kinematics.compliance(twin.kinematics.q_home)
    # 1.059 measured (1.031 on a frictionless robot): the twin's compliance changes with the pose along the
    # pass, while the reference is the constant home compliance, and the command also cancels the joint-
    # friction offsets, whose size follows J(q) rather than a constant per direction. A force-scale mistake
    # would be 0.5 or 2.
    assert gain_of(short_compensation, f_ref, c_home) == pytest.approx(1.0, abs=0.08)


def test_twin_compensation_raises_when_iterations_run_out(twin: Twin, short_path: ToolPath) -> None:
    # the first pass converges in 2 iterations (0.24 mm, then 8e-5 mm rms); one is not enough
    with pytest.raises(CompensationError, match=r"did not reach 0\.01 mm rms in 1 iterations"):
        compensate_twin(short_path.t_s, short_path.p_sheet_m, twin, max_iter=1)
