"""The result of one simulated run (`twin.sim.quasi_static.Twin.simulate`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.base.signals import interp_rows


@dataclass(frozen=True)
class SimResult:
    """One simulated run, at the commanded samples.

    Attributes:
        t_s: Sample times [s], shape (n,).
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], shape (n, 3).
        p_unloaded_sheet_m: Tool tip of the unloaded robot (gravity only), sheet frame [m], shape (n, 3).
        p_sheet_m: Tool tip at equilibrium under the sheet force, sheet frame [m], shape (n, 3).
        f_sheet_n: Force exerted by the sheet on the tool, sheet frame [N], shape (n, 3).
        qpos: Equilibrium joint positions (all model joints) [rad], shape (n, nq).
        q_ik: Rigid IK solution of the commanded path [rad], shape (n, 6).
        pass_index: Pass number per sample (1-based), shape (n,).
        direction: Travel direction along x per sample (+1/-1), shape (n,).
        formed_x_m: Grid of the formed groove profile [m].
        formed_z_m: Formed groove bottom under load at the end of the run [m].
        iterations: Newton iterations per sample, shape (n,).
        tip_gain: d p_tcp / d p_cmd at each equilibrium, (I + C S)^-1 with C the robot's Cartesian compliance
            and S = -df/dp the sheet's stiffness [-], shape (n, 3, 3); for a tool sticking on the sheet at a
            reversal, S is that of the sliding tool (`twin.process.force.tool_friction`).
        force_steps: The field's force steps from one pass to the next (the per-pass table field), so forces
            are not interpolated across a pass change (`force_at`).
    """

    t_s: np.ndarray
    p_cmd_sheet_m: np.ndarray
    p_unloaded_sheet_m: np.ndarray
    p_sheet_m: np.ndarray
    f_sheet_n: np.ndarray
    qpos: np.ndarray
    q_ik: np.ndarray
    pass_index: np.ndarray
    direction: np.ndarray
    formed_x_m: np.ndarray
    formed_z_m: np.ndarray
    iterations: np.ndarray
    tip_gain: np.ndarray
    force_steps: bool = False

    @property
    def deflection_sheet_m(self) -> np.ndarray:
        """Loaded minus unloaded tool tip [m], shape (n, 3)."""
        return self.p_sheet_m - self.p_unloaded_sheet_m

    def force_at(self, t_s: np.ndarray, values: np.ndarray | None = None) -> np.ndarray:
        """Forces (or a force change) given at the samples, at other times: linear within a pass; with
        `force_steps`, between a pass's last sample (its reversal) and the next pass's first the next sample's
        value, not a ramp (a pass starts right after its reversal sample, as the labs' control ticks take it).

        Args:
            t_s: Query times [s], shape (m,).
            values: Per-sample values, shape (n, k); None for `f_sheet_n`.

        Returns:
            The values at `t_s`, shape (m, k).
        """
        t_s = np.asarray(t_s, dtype=float)
        v = self.f_sheet_n if values is None else np.asarray(values, dtype=float)
        out = interp_rows(t_s, self.t_s, v)
        if self.force_steps and len(self.t_s) > 1:
            after = np.clip(np.searchsorted(self.t_s, t_s, side="left"), 1, len(self.t_s) - 1)
            inside = (self.pass_index[after] != self.pass_index[after - 1]) & (t_s > self.t_s[after - 1]) & (
                t_s < self.t_s[after]
            )
            out[inside] = v[after[inside]]
        return out


@dataclass(frozen=True)
class LoopOutput:
    """What the per-sample loop (compiled or Python) gives `Twin.simulate`; shapes as in `SimResult`.

    Attributes:
        qpos: Equilibrium joint positions [rad], (n, nq).
        p_sheet_m: Tool tip at equilibrium, sheet frame [m], (n, 3).
        p_unloaded_sheet_m: Tool tip of the unloaded robot [m], (n, 3).
        f_sheet_n: Force of the sheet on the tool [N], (n, 3).
        iterations: Newton iterations per sample, (n,).
        jac: Translational tcp Jacobian of the last Newton iteration [m/rad], (n, 3, nv).
        stiffness: The sheet's ∂f/∂p of that iteration, a sliding tool's [N/m], (n, 3, 3).
    """

    qpos: np.ndarray
    p_sheet_m: np.ndarray
    p_unloaded_sheet_m: np.ndarray
    f_sheet_n: np.ndarray
    iterations: np.ndarray
    jac: np.ndarray
    stiffness: np.ndarray
