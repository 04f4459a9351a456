"""Across the travel, the online correction is taken in proportion to the sheet's side force as a share of its
normal force (`OnlineSettings.side_share`): a wall on one side pushes the tool with a fair share of Fz (a load to
correct); a groove's walls hold it from both sides with none (their reaction, not a load). Written against the
twin's own kinematics: the travel's direction is the planned tip's, whatever the robot's pose."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from twin.errors import InputError
from twin.robot.kinematics import Kinematics
from twin.sim.online import OnlineCompensator, OnlineSettings
from twin.sim.spec import TwinSpec

CYCLE_S = 0.004
N = 200
STEP_M = 1.2e-4  # 30 mm/s in a 4 ms cycle


def _setup() -> tuple[TwinSpec, np.ndarray, np.ndarray, np.ndarray]:
    """The twin, the joints of a straight travel along a direction of the sheet plane (the twin's IK), that
    direction and its normal in the sheet plane."""
    spec = TwinSpec()
    twin = spec.build()
    kin = Kinematics(robot=twin.robot)
    q0 = np.asarray(twin.robot.q_home_rad, dtype=float)
    d = np.array([math.cos(0.5), math.sin(0.5), 0.0])  # not along an axis of the sheet
    R = twin.R_base_sheet
    p0 = kin.fk(q0)[0]
    path = np.array([p0 + R @ (STEP_M * k * d) for k in range(N)])
    Q = kin.ik_path(path, q0)
    return spec, Q, d, np.array([-d[1], d[0], 0.0])


def _correction(spec: TwinSpec, Q: np.ndarray, f_n: np.ndarray, side_share: float) -> np.ndarray:
    """The correction after a steady force while the planned (and measured) joints travel [m]."""
    comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0, side_share=side_share))
    for k, q in enumerate(Q):
        comp.step(CYCLE_S * k, CYCLE_S * k, f_n, q, q)
    return comp.correction_m.copy()


@pytest.mark.parametrize("share", [0.2, 0.02, 0.0])
def test_the_correction_across_the_travel_is_taken_in_proportion_to_the_side_force(share: float) -> None:
    """A side force of 0.2 Fz (a one-sided wall): all of it, as with the gate off. 0.02 Fz: a fifth of the
    correction across the travel, the rest unchanged. None (a groove): nothing across, the rest unchanged."""
    spec, Q, d, a = _setup()
    f = -150.0 * d + share * 1500.0 * a + np.array([0.0, 0.0, 1500.0])
    side_share = OnlineSettings().side_share
    full, gated = _correction(spec, Q, f, 0.0), _correction(spec, Q, f, side_share)
    kept = min(share / side_share, 1.0)
    assert gated @ a == pytest.approx(kept * (full @ a), abs=1e-7)
    assert gated @ d == pytest.approx(full @ d, abs=1e-9) and gated[2] == pytest.approx(full[2], abs=1e-9)
    assert abs(full @ a) > 1e-6 or share == 0.0  # there is something across to take (or to leave)


def test_without_travel_nothing_is_gated() -> None:
    """A robot that stands (no direction yet): the whole correction, whatever the side force."""
    spec, Q, _, _ = _setup()
    q0 = Q[0]
    f = np.array([30.0, -20.0, 1500.0])
    outs = []
    for side_share in (0.0, OnlineSettings().side_share):
        comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0, side_share=side_share))
        for k in range(100):
            comp.step(CYCLE_S * k, CYCLE_S * k, f, q0, q0)
        outs.append(comp.correction_m.copy())
    np.testing.assert_allclose(outs[1], outs[0], atol=1e-12)


@pytest.mark.parametrize("value", [-0.1, 1.5, float("nan"), float("inf")])
def test_a_bad_side_share_is_named(value: float) -> None:
    with pytest.raises(InputError, match="side_share"):
        OnlineSettings(side_share=value)


def side_share_median(run_dir: Path) -> float:
    """The side force across the tracker's travel over the F/T stream's Fz, median where the tool presses
    (Fz > 100 N) and travels (> 5 mm/s), of a run folder [-]."""
    from twin.base.signals import interp_rows
    from twin.runs.read import read_run

    run = read_run(run_dir)
    t, p = run.tracker.t_s, run.tracker.values
    v = np.gradient(p[:, :2], t, axis=0)
    speed = np.linalg.norm(v, axis=1)
    f = interp_rows(t, run.forces.t_s, run.forces.values)
    ok = (speed > 5e-3) & (f[:, 2] > 100.0)
    a = np.column_stack([-v[ok, 1], v[ok, 0]]) / speed[ok, None]
    return float(np.median(np.abs(np.sum(f[ok, :2] * a, axis=1)) / f[ok, 2]))


def test_the_plants_side_force_is_a_share_of_fz_on_a_wall(tmp_path) -> None:
    """docs/online.md's shares of a cone's and a pyramid's nominal runs on the plant (default knobs, seed 1); the
    groove's is held by `tests/test_online.py`, which runs its nominal groove anyway."""
    from doc_numbers import quoted

    from twin.cli import main

    said = quoted("online.md", "default knobs, seed 1: TX200 cone 40 x 6", 2)  # the cone's, the pyramid's
    shares = []
    for name, shape in (("cone", ["--shape", "cone", "--top-width-mm", "40", "--depth-mm", "6"]),
                        ("pyramid", ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "6"])):
        path = tmp_path / f"{name}.csv"
        assert main(["path", *shape, "--out", str(path)]) == 0
        assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--commanded", str(path), "--seed", "1",
                     "--out", str(tmp_path / name)]) == 0
        shares.append(side_share_median(tmp_path / name))
    print(f"side force / Fz, median: cone {shares[0]:.3f}, pyramid {shares[1]:.3f}")
    for quoted_share, share in zip(said, shares, strict=True):
        quoted_share.check(share, slack=2.0)
    assert min(shares) > OnlineSettings().side_share  # a one-sided wall: the correction across taken in full
