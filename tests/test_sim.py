"""Tests of the quasi-static twin (twin/sim/quasi_static.py): Hooke's law, the force sensor, the groove simulation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from twin.analysis.replay import ReplayResult
from twin.errors import InputError
from twin.robot.model import build_model
from twin.robot.stiffness import set_joint_stiffness
from twin.sim.equilibrium import NEWTON_MAX_ITER
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec


def random_loads(seed: int, count: int, max_n: float) -> np.ndarray:
    """`count` loads in random directions with magnitudes in [0.1, 1] x max_n [N]."""
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return directions * rng.uniform(0.1 * max_n, max_n, (count, 1))


def test_static_deflection_at_home_follows_hooke_within_one_percent(twin_nominal: Twin) -> None:
    frictionless = TwinSpec(joint_friction_nm=(0.0,) * 6).build()
    compliance = twin_nominal.kinematics.compliance(twin_nominal.kinematics.q_home)
    loads = np.vstack([random_loads(seed=42, count=10, max_n=2000.0), [[0.0, 0.0, 2000.0], [-2000.0, 0, 0]]])
    errors = []
    for f in loads:
        got = frictionless.static_deflection(f)
        expected = compliance @ f
        errors.append(np.linalg.norm(got - expected) / np.linalg.norm(expected))
        assert np.linalg.norm(got) > 0.1e-3  # at least 0.1 mm: the check is not trivially satisfied
    print(
        f"\nHooke check at home, {len(loads)} loads <= 2 kN: max |d - J K^-1 J^T F| / |d| = {max(errors):.2e}"
    )
    assert max(errors) < 0.01


def test_load_from_rest_loses_each_joints_friction_before_the_joint_moves(twin_nominal: Twin) -> None:
    """Stick/slip at rest: each joint turns by sign(τ)·max(|τ| - τ_f, 0)/K_q, τ = J^T F its torque change."""
    friction = twin_nominal.joint_friction
    assert friction.max() > 10.0  # the calibrated model has joint friction
    q = twin_nominal.kinematics.q_home
    J = twin_nominal.kinematics.jacobian(q)[:3]
    k = twin_nominal.joint_stiffness
    for f in np.vstack([random_loads(seed=7, count=8, max_n=2000.0), [[0.0, 0.0, 50.0]]]):
        tau = J.T @ f
        expected = J @ (np.sign(tau) * np.maximum(np.abs(tau) - friction, 0.0) / k)
        got = twin_nominal.static_deflection(f)
        np.testing.assert_allclose(got, expected, atol=0.01 * max(float(np.linalg.norm(expected)), 1e-5))
    small = np.array([0.0, 0.0, 50.0])  # 50 N turns joints 3 and 5 by less than their friction: they stick
    tau_small = J.T @ small
    assert np.all(np.abs(tau_small[[2, 4]]) < friction[[2, 4]])


def test_static_deflection_is_zero_without_load_and_halves_with_double_stiffness(twin_nominal: Twin) -> None:
    f = np.array([800.0, 800.0, 1500.0])
    assert np.linalg.norm(twin_nominal.static_deflection(np.zeros(3))) < 1e-12
    stiff = TwinSpec(joint_stiffness_nm_per_rad=tuple(2.0 * twin_nominal.joint_stiffness)).build()
    ratio = np.linalg.norm(stiff.static_deflection(f)) / np.linalg.norm(twin_nominal.static_deflection(f))
    assert ratio == pytest.approx(0.5, rel=0.01)


def test_sensor_reads_the_applied_sheet_force_within_half_a_percent(
    twin_nominal: Twin, clean_replay: ReplayResult
) -> None:
    sim = clean_replay.sim
    t_s = np.arange(0.0, sim.t_s[-1], 1.0 / 30.0)
    read = twin_nominal.sensor_forces(sim, t_s)
    applied = np.column_stack([np.interp(t_s, sim.t_s, sim.f_sheet_n[:, j]) for j in range(3)])
    # the table field's force steps at each reversal: between a reversal sample and the next the force is
    # the next pass's, not a ramp (SimResult.force_at, computed here on its own)
    after = np.searchsorted(sim.t_s, t_s, side="left")
    across = (after > 0) & (sim.pass_index[np.maximum(after - 1, 0)] != sim.pass_index[after]) & (t_s < sim.t_s[after])
    assert 5 <= across.sum() <= 9  # a 30 Hz sensor falls between the two samples at some of the 9 reversals
    applied[across] = sim.f_sheet_n[after[across]]
    magnitude = np.linalg.norm(applied, axis=1)
    assert magnitude.max() > 1500.0
    rel = np.linalg.norm(read - applied, axis=1) / np.maximum(magnitude, 1.0)
    print(f"\nsensor vs applied force on the groove run: max relative error {rel.max():.2e}")
    assert rel.max() < 0.005


def test_sensor_removes_the_tool_weight_and_reports_in_the_sheet_frame(
    twin_nominal: Twin, clean_replay: ReplayResult
) -> None:
    sim = clean_replay.sim
    t_s = sim.t_s[[10, 400, 900]]
    unloaded = dataclasses.replace(sim, f_sheet_n=np.zeros_like(sim.f_sheet_n))
    assert np.abs(twin_nominal.sensor_forces(unloaded, t_s)).max() < 1e-6
    constant = np.array([300.0, -200.0, 1500.0])
    loaded = dataclasses.replace(sim, f_sheet_n=np.tile(constant, (len(sim.t_s), 1)))
    read = twin_nominal.sensor_forces(loaded, t_s)
    np.testing.assert_allclose(
        read, np.tile(constant, (3, 1)), rtol=0, atol=0.005 * float(np.linalg.norm(constant))
    )


def test_groove_run_converges_and_the_unloaded_robot_lands_on_the_path(clean_replay: ReplayResult) -> None:
    sim = clean_replay.sim
    assert isinstance(sim, SimResult)
    # iterations are summed over the friction active set's rounds (one Newton solve each, at most 2-4 rounds)
    assert sim.iterations.max() < 2 * NEWTON_MAX_ITER
    assert sim.iterations.mean() < 6.0
    np.testing.assert_allclose(sim.p_unloaded_sheet_m, sim.p_cmd_sheet_m, rtol=0, atol=1e-6)
    assert sim.pass_index.max() == 10


def test_groove_deflection_is_the_compliance_times_the_sheet_force(
    twin_nominal: Twin, clean_replay: ReplayResult
) -> None:
    """Where the turning joints slide, the deflection is J K^-1 (J^T f - τ_f·sign(q̇)): Hooke plus friction."""
    sim = clean_replay.sim
    qdot = np.gradient(sim.q_ik, sim.t_s, axis=0)
    motion = np.where(np.abs(qdot) > 1e-3, np.sign(qdot), 0.0)  # joints turning faster than 1 mrad/s
    frictional = twin_nominal.joint_friction > 0.0
    sliding = np.all(motion[:, frictional] != 0.0, axis=1)
    forming = np.flatnonzero((np.linalg.norm(sim.f_sheet_n, axis=1) > 300.0) & sliding)[::25]
    assert forming.size > 10
    k = twin_nominal.joint_stiffness
    for i in forming:
        J = twin_nominal.kinematics.jacobian(sim.q_ik[i])[:3]
        expected = J @ ((J.T @ sim.f_sheet_n[i] - twin_nominal.joint_friction * motion[i]) / k)
        np.testing.assert_allclose(
            sim.deflection_sheet_m[i], expected, rtol=0, atol=0.01 * float(np.linalg.norm(expected))
        )
    peak = int(np.argmax(np.linalg.norm(sim.f_sheet_n, axis=1)))
    assert (
        sim.f_sheet_n[peak, 2] > 0.0 and sim.deflection_sheet_m[peak, 2] > 0.0
    )  # the sheet pushes the tool up


def test_formed_groove_is_shallower_than_commanded_by_the_deflection(clean_replay: ReplayResult) -> None:
    sim = clean_replay.sim
    commanded_depth_mm = -1e3 * sim.p_cmd_sheet_m[:, 2].min()
    formed_depth_mm = -1e3 * sim.formed_z_m.min()
    assert commanded_depth_mm == pytest.approx(10.0)
    assert 1.0 <= commanded_depth_mm - formed_depth_mm <= 3.0


def test_simulate_rejects_bad_shapes_and_nan(twin_nominal: Twin) -> None:
    t_s = np.array([0.0, 0.1, 0.2])
    p = np.zeros((3, 3))
    with pytest.raises(InputError, match="n >= 2"):
        twin_nominal.simulate(t_s, p[:, :2])
    with pytest.raises(InputError, match="n >= 2"):
        twin_nominal.simulate(t_s[:2], p)
    p_nan = p.copy()
    p_nan[1, 2] = np.nan
    with pytest.raises(InputError, match="NaN"):
        twin_nominal.simulate(t_s, p_nan)


@pytest.mark.parametrize(
    "stiffness", [np.ones(5), np.array([1e6, 1e6, 1e6, 1e6, 1e6, -1.0]), np.array([1e6] * 5 + [np.nan])]
)
def test_set_joint_stiffness_rejects_bad_values(stiffness: np.ndarray) -> None:
    model = build_model()
    with pytest.raises(InputError, match="joint stiffness"):
        set_joint_stiffness(model, stiffness)
