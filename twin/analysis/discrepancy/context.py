"""The twin's replay of a run, linearised: what every effect family needs to predict its change.

One simulation of the run's command with the effects the twin already has gives the prediction of each
stream and, at every commanded sample, the quantities that turn a robot-side change into a change of what the
sensors see:

- C = J K^-1 J^T, the robot's Cartesian compliance at the loaded pose [m/N];
- G = (I - C S)^-1, the tip gain of the twin (`SimResult.tip_gain`), S = df/dp the sheet's stiffness [N/m]
  (recovered from G and C: S = C^-1 (I - G^-1));
- the deflection, the sheet force, the joint Jacobian and the tool axis.

A robot-side effect that moves the unloaded tip by dp_free and adds a direct force change dF moves the loaded
tip by dp = G (dp_free + C dF) and changes the force by dF + S dp (first order, exact for small effects).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from twin.base.signals import interp_rows
from twin.robot.model import lost_motion_schedule
from twin.runs.format import Run
from twin.sim.effects import Effects
from twin.sim.measure import predict_forces, predict_part_profile, predict_tracker
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult

#: Passes closer than this in the sheet's plane (median over a pass) form over the same place [m].
SAME_PLACE_M = 0.005


@dataclass
class Context:
    """A run and its linearised replay (all arrays in SI units, sheet frame).

    Attributes:
        run: The measured run.
        effects: Effects the twin had for this replay.
        twin: The twin.
        sim: Its simulation of the run's command.
        pred: Predicted `position` (m, 3) [m], `force` (k, 3) [N], `profile` (p,) [m].
        profile_x_m: Profile abscissae [m], shape (p,).
        gain: Tip gain G per commanded sample, shape (n, 3, 3).
        compliance: C [m/N], shape (n, 3, 3).
        stiffness: S [N/m], shape (n, 3, 3).
        jac: Translational Jacobian of the arm joints, the robot base's frame [m/rad], shape (n, 3, dof).
        tool_axis: Tool axis (tool z) in the sheet frame [-], shape (n, 3).
        level: Lost-motion level, +/-1 with the direction, ramped after reversals [-], shape (n,).
        force_cmd: Predicted sensor force at the commanded samples [N], shape (n, 3).
        joint_sign: Sign of d x_tcp / d q of each arm joint at the start (1 where it is nearly 0), shape (dof,).
    """

    run: Run
    effects: Effects
    twin: Twin
    sim: SimResult
    pred: dict[str, np.ndarray]
    profile_x_m: np.ndarray
    gain: np.ndarray
    compliance: np.ndarray
    stiffness: np.ndarray
    jac: np.ndarray
    tool_axis: np.ndarray
    level: np.ndarray
    force_cmd: np.ndarray
    joint_sign: np.ndarray

    @property
    def has_forces(self) -> bool:
        """Whether the run has a force stream."""
        return self.run.forces is not None

    @property
    def has_profile(self) -> bool:
        """Whether the run has a part profile."""
        return self.run.part_profile is not None

    @property
    def t_cmd(self) -> np.ndarray:
        """Commanded sample times [s]."""
        return self.sim.t_s

    def at_tracker(self, values: np.ndarray) -> np.ndarray:
        """Rows at the commanded samples interpolated to the tracker times."""
        return interp_rows(self.run.tracker.t_s, self.sim.t_s, values)

    def at_force(self, values: np.ndarray) -> np.ndarray:
        """Rows at the commanded samples interpolated to the force-sensor times (`SimResult.force_at`: a
        force steps across a pass change of the per-pass table field)."""
        assert self.run.forces is not None
        return self.sim.force_at(self.run.forces.t_s, values)

    def profile_change(self, dp_cmd: np.ndarray) -> np.ndarray:
        """Profile change caused by a tip change (n, 3) [m]: the last (deepest) pass's z change along x, where the
        twin's own profile is formed (`predict_part_profile` clamps the sheet's recovery at its plane, z <= 0: where
        it has recovered to it, a tip change does not show), scaled as the twin scales its profile (the model's
        `depth_ratio`, the `sheet_springback` effect)."""
        last = self.sim.pass_index == self.sim.pass_index.max()
        x, dz = self.sim.p_sheet_m[last, 0], dp_cmd[last, 2]
        order = np.argsort(x, kind="stable")  # ties (the stops) in time order on every machine
        inside = (self.profile_x_m >= x.min()) & (self.profile_x_m <= x.max())
        if "profile" in self.pred:
            inside &= self.pred["profile"] < 0.0
        out = np.where(inside, np.interp(self.profile_x_m, x[order], dz[order]), 0.0)
        depth_ratio = float(getattr(getattr(self.twin.sheet_field, "params", None), "depth_ratio", 1.0))
        return out * depth_ratio * (1.0 - self.effects.springback_ratio)

    @cached_property
    def jac_sheet(self) -> np.ndarray:
        """`jac` (the base frame's) turned into the sheet frame [m/rad], shape (n, 3, dof)."""
        return np.einsum("ki,nkj->nij", self.twin.R_base_sheet, self.jac)

    @property
    def cs(self) -> np.ndarray:
        """C S per commanded sample, shape (n, 3, 3)."""
        return self.compliance @ self.stiffness

    @cached_property
    def below(self) -> np.ndarray:
        """Per commanded sample, the sample of the latest earlier pass over the same place (-1: none), shape (n,).

        A groove's previous stroke runs along the same line; a cone's or a pyramid's passes are half laps
        (`label_passes` splits at the reversals of x), so the surface a sample meets was left a lap before, two
        passes back. The pass over the same place is the latest whose nearest samples lie within SAME_PLACE_M
        (median, in the sheet's plane); the sample matched is the nearest one of that pass.
        """
        passes, xy = self.sim.pass_index, self.sim.p_cmd_sheet_m[:, :2]
        out = np.full(len(passes), -1)
        ks = np.unique(passes)
        trees = {int(k): (np.flatnonzero(passes == k), cKDTree(xy[passes == k])) for k in ks}
        for i, k in enumerate(ks):
            rows = trees[int(k)][0]
            for a in ks[:i][::-1]:
                prev, tree = trees[int(a)]
                distance, nearest = tree.query(xy[rows])
                if np.median(distance) <= SAME_PLACE_M:
                    out[rows] = prev[nearest]
                    break
        return out

    def _previous_pass(self, dp: np.ndarray, rows: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Tip change of the previous pass over the same place (`below`; zero where none) at `rows`, (len, 3)."""
        below = self.below[rows]
        return np.where(below[:, None] >= 0, dp[np.maximum(below, 0)], 0.0)

    def robot_response(
        self, dp_free: np.ndarray, df_direct: np.ndarray | None = None, *, sheet_answers: bool = True
    ) -> tuple[
        np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None
    ]:
        """Loaded tip and force change of a robot-side effect, at the commanded samples and the streams.

        Args:
            dp_free: Unloaded tip change [m], shape (n, 3).
            df_direct: Direct change of the sheet force at the same tip [N], shape (n, 3), or None.
            sheet_answers: Whether the sheet answers the tip change against the surface the previous pass
                left (False: the tip moves by dp_free + C dF and the force changes by dF only, as in data
                edited by hand or when the twin's sheet stiffness is wrong).

        Returns:
            (dp at commanded samples (n, 3) [m], dp at tracker times (m, 3), df at sensor times (k, 3) [N] or
            None, profile change (p,) [m] or None).
        """
        drive = dp_free if df_direct is None else dp_free + np.einsum("nij,nj->ni", self.compliance, df_direct)
        if not sheet_answers:
            df0 = np.zeros_like(drive) if df_direct is None else df_direct
            return (drive, self.at_tracker(drive), self.at_force(df0) if self.has_forces else None,
                    self.profile_change(drive) if self.has_profile else None)
        dp = np.zeros_like(drive)
        passes = self.sim.pass_index
        for k in np.unique(passes):
            rows = np.flatnonzero(passes == k)
            # the sheet answers the change against the surface the pass below it left (`below`)
            drive_k = drive[rows] - np.einsum("nij,nj->ni", self.cs[rows], self._previous_pass(dp, rows))
            dp[rows] = np.einsum("nij,nj->ni", self.gain[rows], drive_k)
        prev_all = self._previous_pass(dp)
        df = np.einsum("nij,nj->ni", self.stiffness, dp - prev_all)
        if df_direct is not None:
            df = df + df_direct
        force = self.at_force(df) if self.has_forces else None
        profile = self.profile_change(dp) if self.has_profile else None
        return dp, self.at_tracker(dp), force, profile


def build_context(run: Run, twin: Twin, sim: SimResult, effects: Effects) -> Context:
    """Linearise the replay `sim` of `run` on `twin` (which carries `effects.robot`)."""
    q_arm = sim.qpos[:, twin.robot.addresses(twin.model).qpos]
    jac6 = twin.kinematics.jacobians(q_arm)
    jac = jac6[:, :3, :]
    k_q = twin.joint_stiffness
    compliance = (jac / k_q) @ jac.transpose(0, 2, 1)
    eye = np.eye(3)
    stiffness = np.linalg.solve(compliance, eye - np.linalg.inv(sim.tip_gain))
    axis = np.array([twin.kinematics.fk(q)[1][:, 2] for q in q_arm[:: max(1, len(q_arm) // 50)]])
    axis_all = interp_rows(sim.t_s, sim.t_s[:: max(1, len(q_arm) // 50)], axis)
    level = -lost_motion_schedule(
        sim.p_cmd_sheet_m[:, 0], sim.direction, np.ones(1), 1.0, effects.lost_motion_takeup_m
    )[:, 0]
    jac0 = twin.kinematics.jacobian(sim.q_ik[0])[0]
    joint_sign = np.where(np.abs(jac0) > 1e-3, np.sign(jac0), 1.0)
    pred = predicted_streams(run, twin, sim, effects)
    force_cmd = np.zeros((len(sim.t_s), 3)) if run.forces is None else predict_forces(twin, sim, sim.t_s, effects)
    x_prof = np.zeros(0) if run.part_profile is None else np.asarray(run.part_profile[0], dtype=float)
    return Context(
        run, effects, twin, sim, pred, x_prof, sim.tip_gain, compliance, stiffness, jac, axis_all, level,
        force_cmd, joint_sign,
    )


def predicted_streams(run: Run, twin: Twin, sim: SimResult, effects: Effects) -> dict[str, np.ndarray]:
    """What the twin's simulation `sim` of `run`, with `effects`, predicts of the run's streams: `position` at the
    tracker times [m], `force` at the sensor times [N] and `profile` at the scan's abscissae [m] (where the run has
    them)."""
    out = {"position": predict_tracker(sim, run.tracker.t_s, effects)}
    if run.forces is not None:
        out["force"] = predict_forces(twin, sim, run.forces.t_s, effects)
    if run.part_profile is not None:
        x_pred, z_pred = predict_part_profile(twin, sim, effects)
        out["profile"] = np.interp(np.asarray(run.part_profile[0], dtype=float), x_pred, z_pred)
    return out


def replay_streams(ctx: Context, effects: Effects) -> dict[str, np.ndarray]:
    """`predicted_streams` of the twin of `ctx` replayed with `effects` instead: a new simulation for a change the
    linearisation does not hold."""
    twin = ctx.twin.spec.replace(effects=effects.simulated()).build()
    return predicted_streams(ctx.run, twin, twin.simulate(ctx.sim.t_s, ctx.sim.p_cmd_sheet_m, q_ik=ctx.sim.q_ik),
                             effects)
