"""Batched IK (`twin.robot.ik_batch`): the warm start from the last path, and the branch check that lets a coarsely
sampled path be solved in one batch, each giving the point-by-point solution."""

from __future__ import annotations

import numpy as np
import pytest

from twin.robot.chain_fk import ChainFK
from twin.robot.ik_batch import breaks_branch
from twin.robot.kinematics import Kinematics


class _Counted:
    """A chain that counts the points it evaluates."""

    def __init__(self, chain: ChainFK) -> None:
        self.chain, self.supported, self.dof, self.points = chain, chain.supported, chain.dof, 0

    def __call__(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.points += Q.shape[0]
        return self.chain(Q)


def _circle(kin: Kinematics, radius_m: float, n: int) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return kin.p_base_sheet_origin + np.column_stack([radius_m * np.cos(a), radius_m * np.sin(a), np.full(n, -0.02)])


def test_a_path_near_the_last_one_starts_from_its_solution_and_jacobians() -> None:
    kin, cold = Kinematics(), Kinematics()
    n = 2000
    a = np.linspace(0.0, 4.0 * np.pi, n)
    P = kin.p_base_sheet_origin + np.column_stack([0.06 * np.cos(a), 0.06 * np.sin(a), np.linspace(0, -0.01, n)])
    Q = kin.ik_path(P)
    moved = P + 1e-3 * np.column_stack([np.sin(a), np.cos(a), np.ones(n)])  # a compensation's next command
    counted_warm, counted_cold = _Counted(kin._chain), _Counted(cold._chain)
    kin._chain, cold._chain = counted_warm, counted_cold  # type: ignore[assignment]
    warm = kin.ik_path(moved, q_near=Q)
    reference = cold.ik_path(moved, q_near=Q)  # no last path: the chain evaluated at the seeds
    np.testing.assert_allclose(warm, reference, rtol=0.0, atol=1e-10)
    assert counted_cold.points - counted_warm.points == n  # the seeds' evaluation saved
    for q, p in zip(warm[::250], moved[::250], strict=True):
        np.testing.assert_allclose(cold.fk(q)[0], p, rtol=0.0, atol=1e-11)


def test_a_coarse_path_is_solved_in_one_batch_as_point_by_point(monkeypatch: pytest.MonkeyPatch) -> None:
    kin = Kinematics()
    P = _circle(kin, 0.25, 6)  # joints move up to 0.4 rad from sample to sample
    reference = Kinematics()._ik_sequential(P, kin.q_home.copy())
    assert np.max(np.abs(np.diff(reference, axis=0))) > 0.1

    def refused(*_: object) -> np.ndarray:
        raise AssertionError("solved point by point")

    monkeypatch.setattr(kin, "_ik_sequential", refused)
    np.testing.assert_allclose(kin.ik_path(P), reference, rtol=0.0, atol=1e-9)


def test_a_solution_on_another_branch_is_caught() -> None:
    kin = Kinematics()
    P = _circle(kin, 0.25, 6)
    Q = kin.ik_path(P)
    flipped = Q.copy()
    flipped[2, 3] += np.pi  # the wrist flipped: the same pose of the tool
    flipped[2, 4] = -flipped[2, 4]
    flipped[2, 5] += np.pi
    np.testing.assert_allclose(kin.fk(flipped[2])[0], P[2], rtol=0.0, atol=1e-12)
    assert list(breaks_branch(kin.ik_points, np.stack([P, P]), np.stack([Q, flipped]))) == [False, True]
