"""The placement search's two models of a part's error at a candidate placement: a fast screen and the twin.

A candidate is one row [x, y, z, yaw] [m, m, m, rad]: the sheet origin in the base frame and the sheet's yaw
(`twin.process.toolpath.placement.Placement`; the sheet stays horizontal, the tool vertical).

**Screen** (`screen_chunk`): the part is simulated ONCE, at the cell's default placement, for the force the sheet
exerts on the tool along the path, in the sheet frame F_sheet. For a candidate, the IK is solved along a subsample
of the path (`Kinematics.ik_path`), and at each subsampled point the tool tip deflects by

    d_sheet = Rᵀ C R F_sheet,    C = J_v K_q⁻¹ J_vᵀ,

with R the candidate's yaw (sheet to base), J_v the translational Jacobian at the IK solution and K_q the twin's
joint stiffnesses. The screened error is the rms (and the largest) of |d_sheet| over the subsample. What the
screen neglects: (1) the force's change with the placement, through the sheet's own stiffness (a stiffer or
softer robot presses the tool to another depth, `SimResult.tip_gain`) and the tool's sliding friction; (2) the
joints' Coulomb friction, which takes up part of each joint torque; (3) the gravity gradient of the joint
stiffness matrix; (4) effects carried as extra joints (lost motion) and anything else the twin's equilibrium
adds beyond the linear compliance; (5) the path between the subsampled points (a reach, joint-margin or
singularity problem there is caught only by the confirmation, which solves the IK along the whole path).

**Confirm** (`confirm_one`): the twin itself, `Twin.simulate` of the ideal path at that placement (spec's
placement replaced), after `check_reach` along the whole path; the error is the simulated tool tip minus the
ideal path. Both run as jobs of `twin.base.jobs.Jobs` (module-level functions; their setups are picklable).
"""

from __future__ import annotations

__all__ = ["STATUSES", "ConfirmSetup", "ScreenSetup", "confirm_one", "placement_of", "prepare_screen",
           "screen_chunk", "screen_rows", "seeded_reach"]

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from twin.errors import SingularityError, UnreachableError
from twin.process.toolpath.groove import ToolPath
from twin.process.toolpath.placement import Placement, ReachReport, check_reach
from twin.robot.facts import RobotDescription
from twin.robot.ik_batch import breaks_branch
from twin.robot.tool import ToolSpec
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:
    from twin.robot.kinematics import Kinematics

#: A candidate's status, by code: 0 feasible; else why it was skipped.
STATUSES = ("feasible", "unreachable", "singular", "joint_margin")
#: Columns of a screened (or confirmed) row: rms and largest error [m], status code, smallest joint margin [rad],
#: smallest |det J| [m^3].
COLUMNS = ("rms_m", "max_m", "status", "joint_margin_rad", "min_abs_det_j")


class ScreenSetup(NamedTuple):
    """What every screening job shares.

    Attributes:
        robot: The robot.
        k_q_nm_per_rad: The twin's joint stiffnesses (dof,) [N·m/rad].
        p_sheet_m: The subsampled ideal path, sheet frame (m, 3) [m].
        f_sheet_n: The sheet's force on the tool at those samples, sheet frame (m, 3) [N], from one simulation.
        joint_margin_rad: Smallest distance to a joint limit a feasible candidate keeps [rad].
        tool: The twin's declared tool (`TwinSpec.tool`); None: the robot model's.
    """

    robot: RobotDescription
    k_q_nm_per_rad: np.ndarray
    p_sheet_m: np.ndarray
    f_sheet_n: np.ndarray
    joint_margin_rad: float
    tool: ToolSpec | None = None


class ConfirmSetup(NamedTuple):
    """What every confirmation job shares: the twin (its placement replaced per job), the ideal path, the margin."""

    spec: TwinSpec
    path: ToolPath
    joint_margin_rad: float


def placement_of(row: np.ndarray) -> Placement:
    """The `Placement` of a candidate row [x, y, z, yaw] [m, m, m, rad]."""
    return Placement(origin_base_m=(float(row[0]), float(row[1]), float(row[2])), yaw_rad=float(row[3]))


def _infeasible(status: str) -> np.ndarray:
    return np.array([math.nan, math.nan, float(STATUSES.index(status)), math.nan, math.nan])


def _path_ik(kinematics: Kinematics, P: np.ndarray) -> np.ndarray | str:
    """One candidate's IK along the subsample by `ik_path` (a candidate the batch did not solve), or why it is
    infeasible."""
    try:
        return kinematics.ik_path(P)
    except UnreachableError:
        return "unreachable"
    except SingularityError:
        return "singular"


def screen_rows(kinematics: Kinematics, setup: ScreenSetup, rows: np.ndarray) -> np.ndarray:
    """The screen (module docstring) of candidate rows (k, 4) with `kinematics`; returns (k, len(COLUMNS)).

    The IK of all candidates' subsamples is solved in one batch (`Kinematics.ik_points`, each point seeded at its
    candidate's solution at the subsample's centre, itself from `q_home`); a candidate whose batch solution fails
    or leaves its branch (`twin.robot.ik_batch.breaks_branch`, checked for all candidates in one batch too) is
    solved again by `ik_path`, which names the reason.
    """
    rows = np.asarray(rows, dtype=float)
    m = len(setup.p_sheet_m)
    placements = [placement_of(row) for row in rows]
    P = np.concatenate([p.to_base(setup.p_sheet_m, kinematics) for p in placements]).reshape(len(rows), m, 3)
    batch, accepted = np.empty((len(rows), m, len(kinematics.q_home))), np.zeros(len(rows), dtype=bool)
    if len(rows):  # each candidate's points seeded at its own solution at the subsample's centre (fewer steps)
        centre = kinematics.ik_points(P.mean(axis=1), kinematics.q_home)
        solved = None if centre is None else kinematics.ik_points(P.reshape(-1, 3), np.repeat(centre[0], m, axis=0))
        if solved is not None:
            batch, accepted = solved[0].reshape(batch.shape), np.all(solved[1].reshape(len(rows), m), axis=1)
            accepted[accepted] = ~breaks_branch(kinematics.ik_points, P[accepted], batch[accepted])
    out = np.empty((len(rows), len(COLUMNS)))
    solutions: dict[int, np.ndarray] = {}
    for i in range(len(rows)):
        Q = batch[i] if accepted[i] else _path_ik(kinematics, P[i])
        if isinstance(Q, str):
            out[i] = _infeasible(Q)
        else:
            solutions[i] = Q
    if not solutions:
        return out
    Q_all = np.concatenate(list(solutions.values()))
    J_all = kinematics.jacobians(Q_all).reshape(len(solutions), m, 6, -1)  # one batch for every candidate
    dets = np.abs(np.linalg.det(J_all)).min(axis=1)
    K = np.asarray(setup.k_q_nm_per_rad, dtype=float)
    for (i, Q), J, min_det in zip(solutions.items(), J_all, dets, strict=True):
        margin = float(np.minimum(Q - kinematics.q_min, kinematics.q_max - Q).min())
        if margin < setup.joint_margin_rad:
            out[i] = _infeasible("joint_margin")
            out[i, 3:] = margin, min_det
            continue
        J_v = J[:, :3]
        C_base = (J_v / K) @ J_v.transpose(0, 2, 1)
        R = placements[i].R_base_sheet
        d_sheet = np.einsum("nij,nj->ni", C_base, setup.f_sheet_n @ R.T) @ R
        norm = np.linalg.norm(d_sheet, axis=1)
        out[i] = math.sqrt(float(np.mean(norm**2))), float(norm.max()), 0.0, margin, min_det
    return out


def prepare_screen(setup: ScreenSetup) -> tuple[Kinematics, ScreenSetup]:
    """A worker's state for screening: the robot's kinematics with the twin's tool (loaded once per worker)."""
    from twin.robot.kinematics import Kinematics
    from twin.robot.model import build_model

    if setup.tool is None:
        return Kinematics(robot=setup.robot), setup
    return Kinematics(build_model(setup.robot, tool=setup.tool), robot=setup.robot), setup


def screen_chunk(state: tuple[Kinematics, ScreenSetup], rows: np.ndarray) -> np.ndarray:
    """A screening job: `screen_rows` of a chunk of candidates."""
    kinematics, setup = state
    return screen_rows(kinematics, setup, rows)


def seeded_reach(path: ToolPath, placement: Placement, kinematics: Kinematics) -> ReachReport:
    """`check_reach` along the whole path, its IK seeded by that of every `IK_COARSE_STRIDE`-th sample
    (`twin.robot.kinematics`, interpolated): a Newton step or two a sample instead of a solve from `q_home` (the
    same solutions)."""
    return check_reach(path, placement, kinematics)


def confirm_one(setup: ConfirmSetup, row: np.ndarray) -> np.ndarray:
    """A confirmation job: the twin at the candidate's placement; returns one row of `COLUMNS` (its error from
    `Twin.simulate`, or the reason the whole path is infeasible there)."""
    placement = placement_of(row)
    twin = setup.spec.replace(placement=placement).build()
    path = setup.path
    try:
        reach = seeded_reach(path, placement, twin.kinematics)
    except UnreachableError:
        return _infeasible("unreachable")
    except SingularityError:
        return _infeasible("singular")
    margin = float(reach.joint_margin_rad.min())
    if margin < setup.joint_margin_rad:
        out = _infeasible("joint_margin")
        out[3:] = margin, reach.min_abs_det_j
        return out
    sim = twin.simulate(path.t_s, path.p_sheet_m, q_ik=reach.q_rad)
    norm = np.linalg.norm(sim.p_sheet_m - path.p_sheet_m, axis=1)
    return np.array([math.sqrt(float(np.mean(norm**2))), float(norm.max()), 0.0, margin, reach.min_abs_det_j])
