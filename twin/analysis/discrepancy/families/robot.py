"""Families acting on the robot and the process: their change reaches the sensors through the loaded robot.

Each gives the unloaded tip change dp_free and/or a direct change dF of the sheet force; `Context.robot_response`
turns them into what the tracker, the force sensor and the profile see (tip gain G, sheet stiffness S). The last
parameter of each, `sheet_answer_ratio` w in [0, 1], weighs the sheet's answer to the tip change: 1 is the
twin's physics (the tool pressing into the surface the previous pass left), 0 a purely kinematic change (data
edited by hand, or a sheet much softer than the twin's); the change is linear in the other parameters for a
given w.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from twin.analysis.discrepancy.context import Context, replay_streams
from twin.analysis.discrepancy.families.base import Delta, Family, register
from twin.analysis.discrepancy.families.sensors import negligible
from twin.sim.effects import EFFECTS, GEAR_PLAY
from twin.sim.gear_play import load_flank

# joints 2 and 3 count as "alike" (the effect `lost_motion`) within this fraction of their sum: the linearised
# replay under-states an alternating offset's force change, biasing the two by up to ~25 %; the replay
# refinement of the search then fits the lab form exactly and keeps it only if it fits better
LAB_MATCH = 0.15
CLAMP_DECAYS_M = (0.003, 0.008)  # decay lengths of the force rise near the stroke ends (sec. 2.3.1)
FRAME_STEP = 0.2  # the frame compliance `FrameCompliance` replays with [mm/kN]


ANSWER = ("sheet_answer_ratio",)  # last parameter of every robot family: w in [0, 1]


def _delta(ctx: Context, theta: np.ndarray, dp_free: np.ndarray, df_direct: np.ndarray | None = None) -> Delta:
    """Kinematic change plus w x (what the sheet's answer adds), w = theta[-1]."""
    w = float(theta[-1])
    _, p0, f0, z0 = ctx.robot_response(dp_free, df_direct, sheet_answers=False)
    if w == 0.0:
        return Delta(position=p0, force=f0, profile=z0)
    _, p1, f1, z1 = ctx.robot_response(dp_free, df_direct)

    def mix(a: np.ndarray | None, b: np.ndarray | None) -> np.ndarray | None:
        return None if a is None or b is None else a + w * (b - a)

    return Delta(position=mix(p0, p1), force=mix(f0, f1), profile=mix(z0, z1))


@register
class ForceScale(Family):
    """The real sheet forces are k times the FE history's, per axis (k equal on all axes: a scalar error)."""

    name = "force_scale"
    parameters = ("scale_x_ratio", "scale_y_ratio", "scale_z_ratio", *ANSWER)
    neutral = (1.0, 1.0, 1.0, 1.0)
    bounds = ((0.05, 0.05, 0.05, 0.0), (5.0, 5.0, 5.0, 1.0))
    scale = (0.02, 0.02, 0.02, 0.1)
    bilinear = True
    description = "real sheet forces = k x the FE history (per axis)"
    effect = "force_scale"

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Direct force change (k - 1) f and the deflection it causes."""
        return _delta(ctx, theta, np.zeros_like(ctx.sim.f_sheet_n), (theta[:3] - 1.0) * ctx.sim.f_sheet_n)

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """`force_scale` (a factor on the twin's own) when x and z agree within 3 sigma (y carries no force)."""
        if covariance is None:
            return None
        var = covariance[0, 0] + covariance[2, 2] - 2.0 * covariance[0, 2]
        if abs(theta[0] - theta[2]) > 3.0 * np.sqrt(max(var, 0.0)) + 0.02 * abs(theta[2]):
            return None
        w = np.array([covariance[2, 2], covariance[0, 0]])
        return float((w @ theta[[0, 2]]) / w.sum()) if w.sum() > 0 else float(theta[2])

    def to_increments(self, theta: np.ndarray, ctx: Context) -> dict[str, Any] | None:
        """Where x and z differ: `force_scale` k_z and `force_scale_in_plane` k_xy / k_z, k_xy the x scale, or the
        mean of x and y where the sheet pushes along y too (a sheet's in-plane force has no preferred axis)."""
        f = ctx.sim.f_sheet_n
        rms = np.sqrt(np.mean(f[:, :2] ** 2, axis=0))
        k_xy = float(theta[0]) if rms[1] < 0.2 * rms[0] else float(np.mean(theta[:2]))
        return {"force_scale": float(theta[2]), "force_scale_in_plane": k_xy / float(theta[2])}


@register
class DirectionDependentCompliance(Family):
    """The robot is more (or less) compliant in one travel direction than the other (thesis sec. 3.3.1)."""

    name = "direction_dependent_compliance"
    parameters = ("extra_compliance_forward_ratio", "extra_compliance_backward_ratio", *ANSWER)
    neutral = (0.0, 0.0, 1.0)
    bounds = ((-0.9, -0.9, 0.0), (5.0, 5.0, 1.0))
    scale = (0.02, 0.02, 0.1)
    bilinear = True
    description = "compliance x (1 + c) with c depending on the travel direction"

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Unloaded-equivalent tip change c_dir C f."""
        c = np.where(ctx.sim.direction > 0, theta[0], theta[1])
        free = c[:, None] * np.einsum("nij,nj->ni", ctx.compliance, ctx.sim.f_sheet_n)
        return _delta(ctx, theta, free)


@register
class JointCompliance(Family):
    """A gear softer (or stiffer) than the cell's: joint j's compliance 1/K_j grows by s_j, one joint at a time.

    The arm's compliance at the tip is C = sum_j J_j J_j^T / K_j (J_j joint j's column of the position Jacobian,
    sheet frame); a gear worn or replaced changes one term, so the tip moves by s_j J_j (J_j . f) / K_j under the
    sheet's force f, and the sheet answers the moved tip. The tip's change and the force's are coupled through the
    arm, which a tracker drift and a re-calibrated force sensor fitted apart are not. Joints 4 and 6 (the wrist's
    rolls) are left out: a forming force hardly loads them. The sheet always answers (no `sheet_answer_ratio`: a
    gear that gives moves the tool in the sheet; free, the fit traded a kinematic tip change against a sensor gain).
    The learned robot carries it (`carried_by_learning`); named only first (`search`).
    """

    name = "joint_compliance"
    parameters = ("softer_j1_ratio", "softer_j2_ratio", "softer_j3_ratio", "softer_j5_ratio")
    neutral = (0.0, 0.0, 0.0, 0.0)
    bounds = ((-0.8, -0.8, -0.8, -0.8), (4.0, 4.0, 4.0, 4.0))
    scale = (0.02, 0.02, 0.02, 0.02)
    description = "joint j's compliance x (1 + s_j), one value per loaded joint (1, 2, 3, 5), against the learned K_q"
    carried_by_learning = True
    JOINTS: ClassVar[tuple[int, ...]] = (0, 1, 2, 4)

    def applicable(self, ctx: Context) -> bool:
        """Against a learned robot only (a model file with its K_q): a declared robot's stiffness is the robot
        learner's to find (`unexplained`, then learned), not a change since the cell was learned."""
        return ctx.has_forces and ctx.twin.spec.joint_stiffness is not None

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Tip change sum_j s_j J_j (J_j . f) / K_j (sheet frame), the sheet answering it: a gear really gives."""
        joints = list(self.JOINTS)
        jac = ctx.jac_sheet[:, :, joints]
        k = np.asarray(ctx.twin.joint_stiffness, dtype=float)[joints]
        torque = np.einsum("nij,ni->nj", jac, ctx.sim.f_sheet_n)  # J_j . f per joint [N·m]
        _, position, force, profile = ctx.robot_response(np.einsum("nij,nj->ni", jac, theta[None, :] * torque / k))
        return Delta(position=position, force=force, profile=profile)


@register
class LostMotion(Family):
    """Backlash in joints 1-3: each link lags by its dead band, flipping at reversals over a take-up travel."""

    name = "lost_motion"
    parameters = ("joint1_mrad", "joint2_mrad", "joint3_mrad", *ANSWER)
    neutral = (0.0, 0.0, 0.0, 1.0)
    bounds = ((-20.0, -20.0, -20.0, 0.0), (20.0, 20.0, 20.0, 1.0))
    scale = (0.05, 0.05, 0.05, 0.1)
    bilinear = True
    description = "lost motion (half dead band) per joint, flipping with the travel direction"
    effect: ClassVar[str | None] = "lost_motion"

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Joint offsets -b level sign(dx/dq) moved to the tip through the arm Jacobian."""
        dq = -1e-3 * theta[None, :3] * ctx.level[:, None] * ctx.joint_sign[None, :3]
        return _delta(ctx, theta, np.einsum("nij,nj->ni", ctx.jac[:, :, :3], dq))

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """The effect `lost_motion` [mrad] (joints 2 and 3 alike, joint 1 free of play)."""
        if covariance is None or not negligible(theta[0], covariance, 0):
            return None
        var = covariance[1, 1] + covariance[2, 2] - 2.0 * covariance[1, 2]
        if abs(theta[1] - theta[2]) > 3.0 * np.sqrt(max(var, 0.0)) + LAB_MATCH * abs(theta[1] + theta[2]):
            return None
        return float(0.5 * (theta[1] + theta[2]))


@register
class ToolLengthOffset(Family):
    """The real tool tip lies further along the tool axis than the nominal tool length."""

    name = "tool_length_offset"
    parameters = ("length_mm", *ANSWER)
    neutral = (0.0, 1.0)
    bounds = ((-20.0, 0.0), (20.0, 1.0))
    scale = (0.05, 0.1)
    bilinear = True
    description = "tool longer than nominal along its axis"
    effect = "tool_length_offset"

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Unloaded tip moved by length x tool axis."""
        return _delta(ctx, theta, 1e-3 * theta[0] * ctx.tool_axis)

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """The effect `tool_length_offset` [mm]."""
        del covariance
        return float(theta[0])


@register
class FrameCompliance(Family):
    """The clamping frame gives along the sheet's normal by c f_z (`twin.sim.giving_frame`): a spring in series with
    the sheet. The tip sits c f_z higher against the yielded sheet, which answers it (less force, a shallower formed
    depth); the tracker sees the tip that much lower than that, where the frame let it go.

    Its change is the sheet's answer to a shallower depth (without it only the profile would move), so it has no
    `sheet_answer_ratio`, and it is taken from a replay with the frame (linear in c): the context's local sheet
    stiffness S does not hold it, since the twin's sheet pushes with the depth itself (a groove 0.3 mm shallower
    by the frame loses several times the force S gives).
    """

    name = "frame_compliance"
    parameters = ("compliance_mm_per_kn",)
    neutral = (0.0,)
    bounds = ((0.0,), (5.0,))
    scale = (0.05,)
    description = "the clamping frame gives along the sheet's normal by c x the axial force"
    effect = "frame_compliance"

    def __init__(self) -> None:
        self._last: tuple[Context, dict[str, np.ndarray]] | None = None

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """c / FRAME_STEP times the change a replay with the frame FRAME_STEP softer makes (stiffer where the twin's
        frame is already within a step of the effect's bound), cached per context."""
        now = ctx.effects.get(self.name)
        step = FRAME_STEP if now + FRAME_STEP <= EFFECTS[self.name].bounds[1] else -FRAME_STEP
        if self._last is None or self._last[0] is not ctx:
            effects = ctx.effects.with_value(self.name, now + step)
            self._last = (ctx, {k: v - ctx.pred[k] for k, v in replay_streams(ctx, effects).items()})
        change, k = self._last[1], float(theta[0]) / step
        return Delta(**{s: k * v for s, v in change.items()})

    def start(self, ctx: Context, residual: dict[str, np.ndarray]) -> np.ndarray:
        """One typical size in from the bound c = 0 (its neutral): `least_squares`' trust region starts on the bound
        with a step scaled by the square root of the distance to it, and stops there."""
        del ctx, residual
        return np.asarray(self.scale, dtype=float)

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """The effect `frame_compliance` [mm/kN]."""
        del covariance
        return float(theta[0])


@register
class ClampProximity(Family):
    """The sheet is stiffer near the clamped stroke ends: the force rises there (thesis sec. 2.3.1).

    The rise is a sum of two decays away from the end, 3 mm and 8 mm, so that any decay length in between is
    matched closely while the family stays linear.
    """

    name = "clamp_proximity"
    parameters = ("rise_3mm_ratio", "rise_8mm_ratio", *ANSWER)
    neutral = (0.0, 0.0, 1.0)
    bounds = ((-2.0, -2.0, 0.0), (5.0, 5.0, 1.0))
    scale = (0.02, 0.02, 0.1)
    description = "force x (1 + a3 exp(-d / 3 mm) + a8 exp(-d / 8 mm)), d the distance to the nearest stroke end"
    bilinear = True

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Direct force change (a3 w3 + a8 w8) f and the deflection it causes."""
        x = ctx.sim.p_cmd_sheet_m[:, 0]
        distance = np.max(np.abs(x)) - np.abs(x)
        weight = sum(a * np.exp(-distance / decay) for a, decay in zip(theta[:2], CLAMP_DECAYS_M, strict=True))
        return _delta(ctx, theta, np.zeros((len(x), 3)), weight[:, None] * ctx.sim.f_sheet_n)


@register
class LostMotionUnderLoad(LostMotion):
    """Backlash in joints 1-3 under the forming load: each link rests on the flank its torque pushes it against.

    `lost_motion` flips the flank with the travel direction. Under a forming load the flank is set by the
    torque the gear transmits: the dead-zone backlash of the control literature (Nordin & Gutman 2002,
    "Controlling mechanical systems with backlash - a survey", Automatica 38(10), 1633-1649), the link lagging the
    motor by -b s(tau), b the half dead band, s a smooth sign (`twin.sim.gear_play.load_flank`, the twin's own) and
    tau = g(q) + M(q) q'' + c(q, q') - J^T F + f_c sign(q') the torque that holds and moves the links (the twin's
    own model), the forming force's moment and the link side's friction. The robot is calibrated and taught under
    gravity, so the flank gravity alone sets is the reference: the offset is -b (s(tau) - s(g)). Where gravity's
    torque is large and one-signed the play hardly shows; where the forming force's moment outweighs it, or on the
    vertical axis (no gravity torque), it flips with the load.

    The twin carries it as its gear play (`Effects.gear_play_rad`, `to_increments`): it replays with each joint on
    the flank the same `load_flank` sets.
    """

    name = "lost_motion_under_load"  # `lost_motion`'s parameters, bounds and scales
    description = "lost motion (half dead band) per joint, flipping with the sign of the joint's torque"
    effect = None

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """No scalar effect: the play per joint is carried by `to_increments`."""
        return None

    def __init__(self) -> None:
        self._last: tuple[Context, np.ndarray] | None = None

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Joint offsets -b (s(tau) - s(g)) moved to the tip through the arm Jacobian (sheet frame)."""
        if self._last is None or self._last[0] is not ctx:
            sim = ctx.sim
            self._last = (ctx, load_flank(ctx.twin, sim.t_s, sim.q_ik, sim.qpos, sim.f_sheet_n))
        dq = -1e-3 * theta[None, :3] * self._last[1][:, :3]
        return _delta(ctx, theta, np.einsum("nij,nj->ni", ctx.jac_sheet[:, :, :3], dq))

    def to_increments(self, theta: np.ndarray, ctx: Context) -> dict[str, Any] | None:
        """The twin's gear play (`twin.sim.effects.GEAR_PLAY`): b per arm joint [rad], the joints beyond this
        family's free of play."""
        fitted = 1e-3 * np.asarray(theta[:-1], dtype=float)
        play = np.zeros(ctx.twin.robot.dof)
        play[:len(fitted)] = fitted
        return {GEAR_PLAY: tuple(float(b) for b in play)}
