"""Tests of the ISF height-map force model (twin/process/isf_force.py) and its calibration
(twin/process/isf_calibration.py). The reference formula is recomputed here, independently of the model."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from twin.analysis.compensate import compensate_twin
from twin.base.csvio import write_table
from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe_history import generate_history
from twin.process.forces import default_force_history, load_force_history
from twin.process.isf_calibration import calibrate_isf, fitted_scale, groove_errors
from twin.process.isf_force import IsfForceField, IsfForceParams
from twin.process.shapes import PartSpec, part_path
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec


def aerens_fz(step_down_mm: float, wall_angle_deg: float) -> float:
    """Aerens et al., CIRP Annals 59 (2010): Fz = 0.0716 Rm t^1.57 d_t^0.41 Δh^0.09 α cos α (AA5086, t 1, Ø 15)."""
    rm, t, d_t = 275.0, 1.0, 15.0
    return 0.0716 * rm * t**1.57 * d_t**0.41 * step_down_mm**0.09 * wall_angle_deg * math.cos(math.radians(wall_angle_deg))


def steady_cone_fz(wall_angle_deg: float, step_down_mm: float) -> float:
    spec = PartSpec(shape="cone", wall_angle_deg=wall_angle_deg, step_down_m=step_down_mm * 1e-3, depth_m=10e-3,
                    top_half_width_m=0.025)
    path = part_path(spec)
    forces = IsfForceField().rigid_forces(path)
    steady = path.p_sheet_m[:, 2] < -7e-3  # build-up (D0 ~ 2 mm) done to within 3 %
    return float(np.median(forces[steady, 2]))


def test_groove_fz_and_fx_reproduce_the_fe_history_within_5_percent_rms_of_peak():
    rms_fz, rms_fx, forces = groove_errors(IsfForceParams(), default_force_history())
    assert rms_fz < 0.05  # 2.85 % measured
    assert rms_fx < 0.05  # 3.08 % measured
    assert np.all(forces[:, 2] >= 0.0) and np.all(forces[:, 1] == 0.0)


def test_fx_against_the_old_acausal_stand_in_is_what_its_taper_costs(tmp_path):
    """An acausal stand-in that tapers Fx before each reversal too (fx_taper="nearest"); no causal model
    follows that: the same constants leave 6.6 % there (6.5 % refitted, experiments/fx_causal_taper.py)."""
    old = load_force_history(write_table(tmp_path / "nearest.csv", generate_history(fx_taper="nearest")),
                             symmetry="half")
    rms_fz, rms_fx, _ = groove_errors(IsfForceParams(), old)
    assert rms_fz < 0.05 and 0.05 < rms_fx < 0.09


@pytest.mark.parametrize("angle", [30.0, 45.0, 60.0])
@pytest.mark.parametrize("step_mm", [0.2, 0.5, 1.0])
def test_cone_steady_state_fz_is_within_25_percent_of_aerens(angle, step_mm):
    fz = steady_cone_fz(angle, step_mm)
    assert fz == pytest.approx(aerens_fz(step_mm, angle), rel=0.25)


def test_forces_rise_with_wall_angle_and_step_down_as_the_formula_says():
    f30, f45 = steady_cone_fz(30.0, 0.5), steady_cone_fz(45.0, 0.5)
    assert f45 > 1.1 * f30  # Aerens: +22 % from 30 to 45 deg (its α·cos α peaks at 49.3 deg)
    assert steady_cone_fz(45.0, 1.0) > steady_cone_fz(45.0, 0.2)


def test_in_plane_force_opposes_the_travel_with_the_calibrated_ratio():
    path = part_path(PartSpec(shape="cone", depth_m=4e-3, step_down_m=0.5e-3, top_half_width_m=0.025))
    field = IsfForceField()
    forces = field.rigid_forces(path)
    travel = np.gradient(path.p_sheet_m[:, :2], axis=0)
    late = slice(len(path) // 2, None)
    cos = np.sum(forces[late, :2] * travel[late], axis=1) / (
        np.linalg.norm(forces[late, :2], axis=1) * np.linalg.norm(travel[late], axis=1))
    assert np.all(cos < -0.99)
    ratio = np.linalg.norm(forces[late, :2], axis=1) / forces[late, 2]
    np.testing.assert_allclose(ratio, IsfForceParams().mu_eff, rtol=0.02)


def test_stiffness_matches_central_differences():
    path = part_path(PartSpec(shape="pyramid", top_half_width_m=0.025, depth_m=5e-3, step_down_m=0.5e-3))
    field = IsfForceField()
    field.rigid_forces(replace(path, t_s=path.t_s[:-30], p_sheet_m=path.p_sheet_m[:-30],
                               pass_index=path.pass_index[:-30], direction=path.direction[:-30]))
    p = path.p_sheet_m[-30] + np.array([3e-5, -2e-5, 1e-4])
    force, stiffness = field.force_and_stiffness(p)
    np.testing.assert_allclose(force, field.force(p))
    step, numeric = 1e-7, np.zeros((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = step
        numeric[:, j] = (field.force(p + e) - field.force(p - e)) / (2 * step)
    np.testing.assert_allclose(stiffness, numeric, rtol=1e-4, atol=50.0)


def test_a_lifted_tool_unloads_elastically_to_zero():
    path = part_path(PartSpec(shape="cone", depth_m=4e-3, step_down_m=0.5e-3, top_half_width_m=0.025))
    field = IsfForceField()
    field.rigid_forces(path)
    p = path.p_sheet_m[-1]  # where the tool stands: the met surface is the last revolution's, 0.5 mm up
    f0 = field.force(p)[2]
    lifted = [field.force(p + np.array([0.0, 0.0, dz]))[2] for dz in (0.4e-3, 0.55e-3, 0.65e-3, 1.5e-3)]
    assert f0 > 1000.0
    assert lifted[0] > 0.5 * f0  # still below the surface it meets: forming
    assert lifted[1] > lifted[2] > lifted[3] and lifted[3] < 1.0  # above it: elastic unloading, then free
    k = (lifted[1] - lifted[2]) / 0.1e-3
    k_unload = IsfForceParams().k_unload_n_per_m
    assert k_unload < k < 1.2 * k_unload  # k_unload plus the build-up's slope (the tool rises: less depth)


def test_fitted_scale_follows_a_scaled_history_and_twin_takes_the_factory(first_pass_path):
    history = default_force_history()
    double = replace(history, f_sheet_n=2.0 * history.f_sheet_n)
    s1, s2 = fitted_scale(IsfForceParams(), history), fitted_scale(IsfForceParams(), double)
    assert s1 == pytest.approx(1.0, abs=0.02) and s2 == pytest.approx(2.0 * s1, rel=1e-9)
    t_s, p_cmd = first_pass_path
    twin_isf = TwinSpec(process=Process(force_model="isf")).build()
    assert isinstance(twin_isf.sheet_field, IsfForceField)
    sim = twin_isf.simulate(t_s, p_cmd)
    sim_ref = Twin().simulate(t_s, p_cmd)
    # same history, two force models; on pass 1 the ISF model's build-up follows the tool's real depth (the
    # table field's the planned one), so it presses less: measured 0.33 mm apart, Fz peak 486 vs 640 N
    assert np.max(np.abs(sim.p_sheet_m - sim_ref.p_sheet_m)) < 0.5e-3
    assert 0.6 * np.max(sim_ref.f_sheet_n[:, 2]) < np.max(sim.f_sheet_n[:, 2]) <= np.max(sim_ref.f_sheet_n[:, 2])


@pytest.mark.parametrize("shape", ["cone", "pyramid"])
def test_twin_compensation_brings_a_cone_and_a_pyramid_onto_the_target_path(shape):
    spec = PartSpec(shape=shape, top_half_width_m=0.02, depth_m=5e-3, step_down_m=1e-3, spacing_m=1e-3)
    path = part_path(spec)
    twin = TwinSpec(process=Process(force_model="isf")).build()
    nominal = twin.simulate(path.t_s, path.p_sheet_m)
    comp = compensate_twin(path.t_s, path.p_sheet_m, twin, tol_m=50e-6)
    compensated = twin.simulate(path.t_s, comp.p_cmd_sheet_m)

    def rms(sim):
        return float(np.sqrt(np.mean(np.sum((sim.p_sheet_m - path.p_sheet_m) ** 2, axis=1))))

    assert rms(compensated) < 0.1e-3
    assert rms(nominal) > 10 * rms(compensated)


def test_params_reject_bad_values():
    with pytest.raises(InputError):
        IsfForceParams(mu_eff=-0.1)
    with pytest.raises(InputError):
        IsfForceParams(wall_angle_max_deg=95.0)


@pytest.mark.slow
def test_calibration_from_a_perturbed_start_recovers_the_history():
    start = replace(IsfForceParams(), wall_angle_max_deg=58.0, build_up_m=3e-3, mu_eff=0.2, direction_length_m=1e-3)
    fit = calibrate_isf(default_force_history(), start)
    assert fit.rms_fz < 0.05 and fit.rms_fx < 0.10
    assert fit.params.wall_angle_max_deg == pytest.approx(63.8, abs=1.0)
