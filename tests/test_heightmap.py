"""Tests of the formed-surface height map (twin/process/part/heightmap.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import InputError
from twin.process.part.heightmap import SUBSTEPS, HeightMap

R = 7.5e-3


def _brute_envelope(hm: HeightMap, tips: np.ndarray) -> np.ndarray:
    X, Y = np.meshgrid(hm.x_m, hm.y_m)
    z = np.zeros_like(X)
    for x, y, zt in tips:
        rho2 = R * R - (X - x) ** 2 - (Y - y) ** 2
        cap = np.where(rho2 > 0, zt + R - np.sqrt(np.clip(rho2, 0, None)), np.inf)
        z = np.minimum(z, cap)
    return z


def test_loaded_surface_is_the_lower_envelope_of_the_tool_sphere():
    rng = np.random.default_rng(3)
    hm = HeightMap(R, 0.5e-3, (0.03, 0.03))
    tips = np.column_stack([rng.uniform(-0.02, 0.02, 25), rng.uniform(-0.02, 0.02, 25), rng.uniform(-4e-3, 0, 25)])
    for p in tips:
        hm.commit(p)
    # tip positions snap to 1/SUBSTEPS of the grid: the envelope moves by at most that much sideways
    snapped = tips.copy()
    snapped[:, :2] = np.round((tips[:, :2] + 0.03) / (0.5e-3 / SUBSTEPS)) * (0.5e-3 / SUBSTEPS) - 0.03
    np.testing.assert_allclose(hm.z_loaded_m, _brute_envelope(hm, snapped), atol=1e-12)
    assert np.max(np.abs(hm.z_loaded_m - _brute_envelope(hm, tips))) < 5e-5  # steep rims move most
    assert hm.z_loaded_m.min() == pytest.approx(tips[:, 2].min(), abs=1e-5)  # nodes miss the tip by <= h/√2


def test_met_surface_lags_the_tool_by_the_lag_length():
    hm = HeightMap(R, 0.5e-3, (0.05, 0.02), lag_m=10e-3)
    xs = np.arange(0, 41) * 0.5e-3  # 20 mm straight run at 1 mm depth
    for x in xs:
        hm.commit((x, 0.0, -1e-3))
    met_depth = -hm.met_height(0.0, 0.0)[0]
    assert met_depth == pytest.approx(1e-3, abs=1e-9)  # formed 20 mm back: met
    assert hm.met_height(20e-3, 0.0)[0] == 0.0  # the last 10 mm are not met yet
    assert hm.z_loaded_m[np.argmin(np.abs(hm.y_m)), np.argmin(np.abs(hm.x_m - 20e-3))] == pytest.approx(-1e-3)
    owner = hm.met_owner(0.0, 0.0)
    assert hm.owner_point(owner)[0] == pytest.approx(0.0, abs=0.5e-3)
    hm.flush()
    np.testing.assert_array_equal(hm.z_met_m, hm.z_loaded_m)


def test_parent_is_the_commit_that_formed_the_surface_below():
    hm = HeightMap(R, 0.5e-3, (0.02, 0.02), lag_m=0.0)
    hm.commit((0.0, 0.0, -1e-3))
    hm.commit((0.0, 0.0, -2e-3))
    assert hm.owner_point(0)[4] == -1 and hm.owner_point(1)[4] == 0


def test_elastic_recovery_is_force_over_unloading_stiffness_and_never_above_the_sheet():
    hm = HeightMap(R, 0.5e-3, (0.02, 0.02))
    hm.commit((0.0, 0.0, -2e-3), f_z_n=1000.0)
    z = hm.unloaded_z_m(1e6)  # 1 mm back
    iy, ix = np.argmin(np.abs(hm.y_m)), np.argmin(np.abs(hm.x_m))
    assert z[iy, ix] == pytest.approx(-1e-3, abs=1e-12)
    assert z.max() <= 0.0
    with pytest.raises(InputError):
        hm.unloaded_z_m(0.0)


def test_commits_off_the_grid_are_clipped_and_reset_flattens():
    hm = HeightMap(R, 0.5e-3, (0.01, 0.01))
    hm.commit((0.009, 0.0, -1e-3))
    hm.commit((0.5, 0.5, -1e-3))  # far outside: no effect
    assert hm.z_loaded_m.min() == pytest.approx(-1e-3)
    assert hm.met_owner(0.5, 0.5) == -1
    hm.reset()
    assert hm.z_loaded_m.min() == 0.0 and len(hm.track_m) == 0


@pytest.mark.parametrize("kwargs", [{"spacing_m": 1e-3}, {"radius_m": -1.0}, {"half_size_m": (0.0, 0.1)}, {"lag_m": -1.0}])
def test_heightmap_rejects_bad_settings(kwargs):
    with pytest.raises(InputError):
        HeightMap(**kwargs)
