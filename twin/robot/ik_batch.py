"""Batched inverse kinematics (numpy): many points at once, for `twin.robot.kinematics.Kinematics`.

* `solve_points`: the damped Newton of `Kinematics.ik` for independent points, each from its seed, with the
  chain's vectorised kinematics (`twin.robot.chain_fk.ChainFK`). Given the error and Jacobian at the seeds
  (`first`), its first step needs no evaluation of the chain.
* `BatchSolution`: a path's targets, solution and Jacobians. A path near it (the next command of a compensation,
  which moves by micrometres to millimetres) starts from it with `warm_first_step`: at a converged solution the
  chain's error is the targets' change and its Jacobian is known, so the first Newton step is taken from them;
  the same iterates to rounding (the residual errors of a converged solution are below 1e-12).
* `breaks_branch`: whether a batch solution of a path leaves the branch a point-by-point solve follows: a step
  between consecutive solutions of more than `JUMP_RAD` is kept where Newton from the previous point's solution
  reaches the same solution (`SAME_RAD`); a path sampled coarsely (a placement screen's subsample) moves its
  joints that much between samples on one branch.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from twin.robot.chain_fk import ChainFK, rotation_log_batch

#: A batch IK: targets (n, 3) [m] and seeds (n, dof) [rad] -> solutions (n, dof) [rad] and which converged
#: within the robot's limits (n,), or None (`Kinematics.ik_points`).
PointSolver = Callable[[np.ndarray, np.ndarray], "tuple[np.ndarray, np.ndarray] | None"]
#: Largest joint step between consecutive solutions of a path accepted without a check [rad].
JUMP_RAD = 0.1
#: Two converged solutions of one point closer than this are the same solution [rad].
SAME_RAD = 1e-8
#: Largest joint step of one Newton iteration [rad] (larger ones are scaled down to it).
STEP_LIMIT_RAD = 0.2


class BatchSolution(NamedTuple):
    """A path's batch solution: targets P (n, 3) [m], solutions Q (n, dof) [rad], Jacobians J at Q (n, 6, dof)."""

    P: np.ndarray
    Q: np.ndarray
    J: np.ndarray


def warm_first_step(last: BatchSolution | None, P: np.ndarray, q_near: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The error (n, 6) [m; rad] and Jacobian (n, 6, dof) at `q_near` when it is `last`'s solution (the chain then
    need not be evaluated there), else None.

    Args:
        last: The last batch solution kept, or None.
        P: The new targets (n, 3) [m].
        q_near: The seeds (n, dof) [rad].
    """
    if last is None or last.Q.shape != q_near.shape or not np.array_equal(last.Q, q_near):
        return None
    return np.concatenate([P - last.P, np.zeros_like(P)], axis=1), last.J


def solve_points(
    chain: ChainFK, R_tool_down: np.ndarray, damping: np.ndarray, P: np.ndarray, q_seed: np.ndarray,
    max_iter: int = 30, first: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Damped Newton for independent points (position and the tool's orientation `R_tool_down`), each from its seed.

    Args:
        chain: The arm's vectorised kinematics.
        R_tool_down: The tool's orientation every point asks, base frame (3, 3).
        damping: Levenberg damping added to JᵀJ (dof, dof).
        P: Targets (n, 3) [m], base frame.
        q_seed: One seed (dof,) or one per point (n, dof) [rad].
        max_iter: Newton iterations at most.
        first: The error (n, 6) [m; rad] and Jacobian (n, 6, dof) at the seeds (`warm_first_step`), or None.

    Returns:
        The solutions (n, dof) [rad], whether each converged (error below 1e-12 m and rad) (n,), and the
        Jacobians at the converged ones (n, 6, dof); None where a rotation is near pi (use the scalar solver).
    """
    n, dof = P.shape[0], chain.dof
    Q = np.broadcast_to(q_seed, (n, dof)).copy()
    J_final, ok = np.empty((n, 6, dof)), np.zeros(n, dtype=bool)
    R_tT = R_tool_down.T
    active = np.arange(n)
    for iteration in range(max_iter):
        if iteration == 0 and first is not None:
            e, J = first
        else:
            p, R, J = chain(Q[active])
            # R_t R^T = (R R_t^T)^T, one BLAS call for all points
            M = (R.reshape(-1, 3) @ R_tT).reshape(-1, 3, 3).transpose(0, 2, 1)
            log = rotation_log_batch(M)
            if log is None:
                return None
            e = np.concatenate([P[active] - p, log], axis=1)
        converged = (np.sum(e[:, :3] ** 2, axis=1) < 1e-24) & (np.sum(e[:, 3:] ** 2, axis=1) < 1e-24)
        J_final[active[converged]], ok[active[converged]] = J[converged], True
        keep = ~converged
        active, e, J = active[keep], e[keep], J[keep]
        if active.size == 0:
            break
        Jt = J.transpose(0, 2, 1)
        dq = np.linalg.solve(Jt @ J + damping, (Jt @ e[:, :, None]))[:, :, 0]
        step = np.max(np.abs(dq), axis=1)
        dq *= np.where(step > STEP_LIMIT_RAD, STEP_LIMIT_RAD / np.maximum(step, 1e-300), 1.0)[:, None]
        Q[active] += dq
    return Q, ok, J_final


def breaks_branch(ik_points: PointSolver, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Which paths' batch solutions leave the branch a point-by-point solve follows (module docstring).

    Args:
        ik_points: The robot's batch solver (`Kinematics.ik_points`).
        P: Targets of k paths of m points (k, m, 3) [m].
        Q: Their converged batch solutions (k, m, dof) [rad].

    Returns:
        (k,) True where a step of more than `JUMP_RAD` between consecutive solutions is not the solution Newton
        reaches from the previous point's.
    """
    jumps = np.max(np.abs(np.diff(Q, axis=1)), axis=2) > JUMP_RAD  # (k, m - 1)
    path, point = np.nonzero(jumps)
    if path.size == 0:
        return np.zeros(len(Q), dtype=bool)
    solved = ik_points(P[path, point + 1], Q[path, point])
    bad = np.ones(path.size, dtype=bool)
    if solved is not None:
        bad = ~solved[1] | (np.max(np.abs(solved[0] - Q[path, point + 1]), axis=1) > SAME_RAD)
    out = np.zeros(len(Q), dtype=bool)
    out[path[bad]] = True
    return out
