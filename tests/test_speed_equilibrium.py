"""The fast paths of the per-sample solve give today's equilibria (speed itself is in `make bench`)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.process.description import Process
from twin.process.force.isf import IsfForceField
from twin.process.force.pass_tables import lerp_slope, lerp_slope3
from twin.process.toolpath.groove import groove_path
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.equilibrium import NEWTON_TOL_RAD, EquilibriumSolver
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

P_TOL_M = 1e-9  # the exactness bound on the tool tip
F_TOL_N = 1e-4  # 1e-9 m times the stiffest sheet sensitivity (1.4 kN/mm) is 1.4e-3 N; measured 7e-9 N


def _both(twin: Twin, t_s: np.ndarray, p_cmd: np.ndarray, monkeypatch: pytest.MonkeyPatch):
    fast = twin.simulate(t_s, p_cmd)
    with monkeypatch.context() as patch:
        patch.setattr(EquilibriumSolver, "predict_active_set", False)  # every frictional joint stuck first
        reference = twin.simulate(t_s, p_cmd, q_ik=fast.q_ik)
    return fast, reference


@pytest.mark.parametrize(
    ("friction_nm", "dz_m"),
    [(None, 0.0), (None, 3e-4), (np.array([0.0, 400.0, 400.0, 0.0, 200.0, 0.0]), -3e-4)],
    ids=["model-friction", "raised-0.3mm", "high-friction-lowered"],
)
def test_predicted_stick_slip_set_reaches_the_same_equilibria_in_fewer_iterations(
    nominal_path: tuple[np.ndarray, np.ndarray], friction_nm: np.ndarray | None, dz_m: float,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Whole groove: same tool tip (<= 1e-9 m) and force as the all-stuck start, with fewer Newton iterations."""
    t_s, p_cmd = nominal_path
    twin = TwinSpec(joint_friction_nm=None if friction_nm is None else tuple(friction_nm)).build()
    assert twin.joint_friction.any()
    fast, reference = _both(twin, t_s, p_cmd + np.array([0.0, 0.0, dz_m]), monkeypatch)
    np.testing.assert_allclose(fast.p_sheet_m, reference.p_sheet_m, rtol=0.0, atol=P_TOL_M)
    np.testing.assert_allclose(fast.f_sheet_n, reference.f_sheet_n, rtol=0.0, atol=F_TOL_N)
    assert fast.iterations.sum() < 0.75 * reference.iterations.sum()


def test_predicted_set_matches_on_a_seeded_jittered_command(monkeypatch: pytest.MonkeyPatch) -> None:
    """A command with seeded 20 µm jitter (joints reverse every few samples): still the same equilibria."""
    path = groove_path()
    keep = path.pass_index <= 2
    rng = np.random.default_rng(7)
    p_cmd = path.p_sheet_m[keep] + rng.normal(0.0, 2e-5, (int(keep.sum()), 3)) * np.array([1.0, 0.0, 1.0])
    fast, reference = _both(Twin(TwinSpec()), path.t_s[keep], p_cmd, monkeypatch)
    np.testing.assert_allclose(fast.p_sheet_m, reference.p_sheet_m, rtol=0.0, atol=P_TOL_M)


@pytest.mark.parametrize(
    "part",
    [PartSpec(depth_m=5e-3, top_half_width_m=20e-3), PartSpec(shape="pyramid", depth_m=4e-3, top_half_width_m=20e-3)],
    ids=["cone", "pyramid"],
)
def test_the_isf_models_extrapolated_start_reaches_the_held_links_equilibria(
    part: PartSpec, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The ISF model's `extrapolated_start`: the held-links start's tool tips and forces to the Newton tolerance
    (a joint step of NEWTON_TOL_RAD over the arm's lever of under 1 m: another equilibrium branch would be
    millimetres away), with at most 60 % of its Newton iterations."""
    twin = TwinSpec(process=Process(force_model="isf")).build()
    assert twin.joint_friction.any() and twin.field.extrapolated_start
    path = part_path(part)
    fast = twin.simulate(path.t_s, path.p_sheet_m)
    with monkeypatch.context() as patch:
        patch.setattr(IsfForceField, "extrapolated_start", False)
        held = twin.simulate(path.t_s, path.p_sheet_m, q_ik=fast.q_ik)
    tol_m = NEWTON_TOL_RAD * 1.0
    np.testing.assert_allclose(fast.p_sheet_m, held.p_sheet_m, rtol=0.0, atol=tol_m)
    np.testing.assert_allclose(fast.f_sheet_n, held.f_sheet_n, rtol=0.0, atol=tol_m * 1.4e6)  # 1.4 kN/mm, above
    assert fast.iterations.sum() <= 0.6 * held.iterations.sum()


def test_three_table_lookup_is_bit_identical_to_three_single_lookups() -> None:
    rng = np.random.default_rng(3)
    tables = [rng.normal(size=11) for _ in range(3)]
    x0, dx, n = -0.01, 0.002, 11
    # inside cells, on nodes, and clamped beyond both ends
    xs = [*rng.uniform(x0, x0 + dx * (n - 1), 50), *(x0 + dx * np.arange(n)), x0 - 1e-3, x0 + dx * n + 1e-3]
    for x in xs:
        fused = lerp_slope3(*tables, x0, dx, n, float(x))
        single = sum((lerp_slope(t, x0, dx, n, float(x)) for t in tables), ())
        assert fused == single, x
