"""Tests of the stateful sheet force field (twin/process/force/table.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from doc_numbers import quoted

from twin.errors import InputError
from twin.process.fe.load import default_force_history
from twin.process.force.pass_tables import build_pass_tables
from twin.process.force.table import K_LOAD_N_PER_M, K_UNLOAD_N_PER_M, SHEET_HALF_LENGTH_M, SheetForceField
from twin.process.part.formed_profile import FormedProfile
from twin.process.toolpath.groove import ToolPath, groove_path

UP = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def history():
    return default_force_history()


@pytest.fixture(scope="module")
def field(history):
    return SheetForceField(history)


def _drive_to(field, path, stop):
    """Reset and commit the samples before `stop` (rigid robot on the path)."""
    field.reset()
    for i in range(stop):
        field.advance(path.p_sheet_m[i], int(path.pass_index[i]))


def _offset(path, dz_m):
    return ToolPath(path.t_s, path.p_sheet_m + np.array([0.0, 0.0, dz_m]), path.pass_index, path.direction)


def test_rigid_run_on_the_history_samples_reproduces_the_history(field, history):
    forces = field.rigid_forces(history.to_path())
    peak = history.f_sheet_n[:, 2].max()
    rms = np.sqrt(np.mean((forces - history.f_sheet_n) ** 2, axis=0)) / peak
    assert np.all(rms < 0.03)
    assert rms.max() < 0.005
    quoted("forces.md", "reproduces the history to", 1)[0].check(100.0 * rms.max())  # [%]


def test_rigid_run_on_the_groove_path_reproduces_the_history(field, history):
    path = groove_path()
    forces = field.rigid_forces(path)
    expected = np.column_stack([np.interp(path.s_m, history.s_m, history.f_sheet_n[:, j]) for j in range(3)])
    rms = np.sqrt(np.mean((forces - expected) ** 2, axis=0)) / history.f_sheet_n[:, 2].max()
    assert np.all(rms < 0.03)
    assert np.all(forces[:, 1] == 0.0) and np.all(forces[:, 2] >= 0.0)


def _depth_below_surface_met(history, path, i):
    """δ_plan at sample i: the surface formed before i's pass (rigid drive) minus the planned tool height [m]."""
    k = int(path.pass_index[i])
    before = SheetForceField(history)
    _drive_to(before, path, int(np.flatnonzero(path.pass_index == k)[0]))
    return float(np.interp(path.p_sheet_m[i, 0], before.x_grid_m, before.formed_z_m)) - path.p_sheet_m[i, 2]


@pytest.mark.parametrize("k", [2, 5, 9])
def test_tool_raised_while_forming_loses_k_load_and_lifted_off_loses_k_unload(field, history, k):
    path = history.to_path()
    i = int(np.flatnonzero(path.pass_index == k)[60])  # mid-stroke
    plan = _depth_below_surface_met(history, path, i)
    assert 0.3e-3 < plan < 2e-3  # the step-down, about 1 mm
    _drive_to(field, path, i)
    p, d = path.p_sheet_m[i], int(path.direction[i])
    f_plan = field.force(p, k, d)
    up = 0.5 * plan  # still below the surface it meets: forming, Aerens's weak sensitivity
    f_up = field.force(p + UP * up, k, d)
    f_down = field.force(p - UP * 0.5e-3, k, d)
    f_lifted = field.force(p + UP * (plan + 0.3e-3), k, d)  # 0.3 mm above that surface: elastic unloading
    assert f_plan[2] - f_up[2] == pytest.approx(K_LOAD_N_PER_M * up, rel=0.03)
    assert f_down[2] - f_plan[2] == pytest.approx(K_LOAD_N_PER_M * 0.5e-3, rel=0.03)
    assert f_plan[2] - f_lifted[2] == pytest.approx(K_LOAD_N_PER_M * plan + K_UNLOAD_N_PER_M * 0.3e-3, rel=0.03)
    assert f_up[0] / f_plan[0] == pytest.approx(f_up[2] / f_plan[2], rel=1e-9)  # Fx scales with Fz
    assert np.sign(f_plan[0]) == -d


def test_force_falls_smoothly_to_zero_above_the_sheet(field, history):
    path = history.to_path()
    i = int(np.flatnonzero(path.pass_index == 4)[60])
    _drive_to(field, path, i)
    p, d = path.p_sheet_m[i], int(path.direction[i])
    heights = np.linspace(0.0, 3e-3, 61)
    fz = np.array([field.force(p + UP * h, 4, d)[2] for h in heights])
    assert np.all(np.diff(fz) <= 0.0) and np.all(fz >= 0.0)
    assert fz[-1] < 1e-3 and abs(field.force(p + UP * 3e-3, 4, d)[0]) < 1e-3
    assert np.max(np.abs(np.diff(fz))) <= 1.001 * K_UNLOAD_N_PER_M * 5e-5  # no jump, slope at most k_unload


def test_force_is_pure_and_direction_sets_the_fx_sign(field, history):
    path = history.to_path()
    i = int(np.flatnonzero(path.pass_index == 3)[50])
    _drive_to(field, path, i)
    before = field.formed_z_m
    p = path.p_sheet_m[i]
    a = field.force(p, 3, 1)
    b = field.force(p, 3, 1)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(field.formed_z_m, before)
    c = field.force(p, 3, -1)
    assert c[0] == -a[0] and c[2] == a[2]


def test_stiffness_matches_the_chosen_k(field, history):
    path = history.to_path()
    i = int(np.flatnonzero(path.pass_index == 6)[60])
    _drive_to(field, path, i)
    plan = _depth_below_surface_met(history, path, i)
    p, d = path.p_sheet_m[i], int(path.direction[i])
    jac_up = field.stiffness(p + UP * (plan + 0.2e-3), 6, d)  # lifted off the surface it meets
    jac_down = field.stiffness(p - UP * 0.2e-3, 6, d)  # forming
    assert jac_up.shape == (3, 3)
    assert jac_up[2, 2] == pytest.approx(-K_UNLOAD_N_PER_M, rel=0.01)
    assert jac_down[2, 2] == pytest.approx(-K_LOAD_N_PER_M, rel=0.01)
    assert np.all(jac_up[:, 1] == 0.0) and np.all(jac_up[1] == 0.0)


def test_advance_updates_the_formed_profile_with_the_sphere_footprint(history):
    field = SheetForceField(history)
    x = field.x_grid_m
    assert np.all(field.formed_z_m == 0.0)
    field.advance(np.array([0.0, 0.0, -1e-3]), 1)
    formed = field.formed_z_m
    r = 7.5e-3
    at = lambda xq: float(np.interp(xq, x, formed))  # noqa: E731
    assert at(0.0) == pytest.approx(-1e-3, abs=1e-12)
    assert at(3e-3) == pytest.approx(-1e-3 + r - math.sqrt(r * r - 9e-6), abs=1e-9)
    assert at(8e-3) == 0.0 and at(-8e-3) == 0.0
    field.advance(np.array([0.5e-3, 0.0, -0.5e-3]), 1)  # shallower: never raises the profile
    assert float(np.interp(0.0, x, field.formed_z_m)) == pytest.approx(-1e-3, abs=1e-12)
    field.reset()
    assert np.all(field.formed_z_m == 0.0) and field.current_pass == 0


def test_rigid_run_forms_the_planned_groove(field):
    field.rigid_forces(groove_path())
    x = field.x_grid_m
    formed = field.formed_z_m
    assert formed.min() == pytest.approx(-10e-3, abs=1e-6)
    assert float(np.interp(0.0, x, formed)) == pytest.approx(-9.5e-3, abs=1e-5)  # last pass at mid-stroke
    assert np.all(formed[np.abs(x) > 0.035 + 7.5e-3] == 0.0)
    # springback after unloading: twin/process/part/springback.py, tested in tests/test_calibration.py


def test_state_forgives_a_steady_offset_but_the_stateless_field_does_not(history):
    """Tool 0.5 mm high on every pass: with state the groove is shallower and passes 3.. push as planned."""
    path = _offset(history.to_path(), 0.5e-3)
    stateful = SheetForceField(history).rigid_forces(path)
    stateless = SheetForceField(history, stateful=False).rigid_forces(path)
    fz_hist = history.f_sheet_n[:, 2]
    later = path.pass_index >= 3
    np.testing.assert_allclose(stateful[later, 2], fz_hist[later], atol=0.03 * fz_hist.max())
    assert np.sqrt(np.mean((stateful[later, 2] - fz_hist[later]) ** 2)) < 0.005 * fz_hist.max()
    drop = fz_hist[later] - stateless[later, 2]
    assert np.median(drop) == pytest.approx(K_UNLOAD_N_PER_M * 0.5e-3, rel=0.01)
    assert np.mean(np.abs(drop - K_UNLOAD_N_PER_M * 0.5e-3) < 0.03 * fz_hist.max()) > 0.99
    first = path.pass_index == 1  # flat sheet: the tool 0.5 mm high forms less (k_load) or lifts off (k_unload)
    assert stateful[first, 2].mean() < fz_hist[first].mean() - K_LOAD_N_PER_M * 0.5e-3


def test_inferred_passes_match_labelled_passes(field, history):
    path = history.to_path()
    field.rigid_forces(path)
    labelled = field.formed_z_m
    field.reset()
    for p in path.p_sheet_m:
        field.advance(p)
    assert field.current_pass == 10
    np.testing.assert_array_equal(field.formed_z_m, labelled)


def test_bad_arguments_raise(field, history):
    p = history.p_sheet_m[10]
    with pytest.raises(InputError, match=r"1\.\.10"):
        field.force(p, 11, 1)
    with pytest.raises(InputError):
        SheetForceField(history, k_unload_n_per_m=-1.0)
    field.reset()
    field.advance(p, 3)
    with pytest.raises(InputError, match="before the current pass"):
        field.advance(p, 2)


def test_the_numbers_docs_forces_md_quotes_are_the_shipped_field_and_history() -> None:
    """The sheet's calibrated stiffnesses [kN/mm] and the stand-in history's physical peaks [N]."""
    quoted("forces.md", "k = **k_unload =", 1)[0].check(1e-6 * K_UNLOAD_N_PER_M)
    quoted("forces.md", "k = **k_load =", 1)[0].check(1e-6 * K_LOAD_N_PER_M)
    f = default_force_history().f_sheet_n
    fz, fx = quoted("forces.md", "Physical peaks: **Fz", 2)
    fz.check(float(np.max(f[:, 2])))
    fx.check(float(np.max(np.abs(f[:, 0]))))
    quoted("forces.md", "history (peak", 1)[0].check(float(np.max(f[:, 2])))


def test_fields_of_one_history_share_its_tables_and_cannot_change_them(history) -> None:
    """Every field built from the same samples gets the tables a fresh build gives, read-only; other samples or
    another tool get their own."""
    first, again = SheetForceField(history), SheetForceField(replace(history, p_sheet_m=history.p_sheet_m.copy()))
    assert again.pass_tables is first.pass_tables
    fresh = build_pass_tables(history, FormedProfile(7.5e-3, 1e-4, SHEET_HALF_LENGTH_M), deadband_m=1e-6)
    for shared, built in zip(first.pass_tables, fresh, strict=True):
        for name in ("fz", "ratio", "z_plan", "delta_plan"):
            np.testing.assert_array_equal(getattr(shared, name), getattr(built, name))
            with pytest.raises(ValueError, match="read-only"):
                getattr(shared, name)[0] = 0.0
    deeper = replace(history, p_sheet_m=history.p_sheet_m - np.array([0.0, 0.0, 1e-4]))
    assert SheetForceField(deeper).pass_tables is not first.pass_tables
    assert SheetForceField(history, tool_radius_m=5e-3).pass_tables is not first.pass_tables
    assert SheetForceField(history).pass_tables is first.pass_tables
