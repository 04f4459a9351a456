"""The servo's transient compliance: what a joint's position loop lets the tool give way by while a force changes.

A joint's controller closes its loop on the motor; a change of the load torque first winds the motor off its
set-point, and the loop's integrator brings it back over its own time. The gear spring K_q holds the steady part;
the servo adds a transient part, a compliance c_s per joint acting on the force's high-pass F − lag_τ(F) (a
first-order lag of time constant τ, the loop's recovery):

    δp_servo(t) = Σ_j c_s,j · J_j(q) · J_j(q)ᵀ · (F(t) − lag_τ(F)(t)).

It is learned from a cell's runs (`twin.analysis.learn.robot`) and added by the twin to each simulated tool tip
(`twin.sim.quasi_static.Twin.simulate`) after the quasi-static solve: the sheet's formed state does not see it
(a transient of tens of milliseconds at the reversals, where the force steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.errors import InputError


def lagged(t_s: np.ndarray, values: np.ndarray, lag_s: float) -> np.ndarray:
    """First-order lag of sampled channels (exact for a signal held between samples) [units of `values`]."""
    if lag_s <= 0.0:
        return values
    out = np.empty_like(values)
    out[0] = values[0]
    decay = np.exp(-np.diff(t_s) / lag_s)
    for i in range(1, len(t_s)):  # bounded: one pass over the samples
        out[i] = decay[i - 1] * out[i - 1] + (1.0 - decay[i - 1]) * values[i - 1]
    return out


@dataclass(frozen=True)
class ServoTransient:
    """The servo's transient compliance (module docstring).

    Attributes:
        compliance_rad_per_nm: c_s per arm joint [rad/(N·m)]; negative where the deflection lags the force (the
            arm's inertia answers a force step later than its spring would).
        time_constant_s: τ, the loop's recovery [s].
    """

    compliance_rad_per_nm: tuple[float, ...]
    time_constant_s: float

    def __post_init__(self) -> None:
        values = tuple(float(v) for v in self.compliance_rad_per_nm)
        if not values or not all(math.isfinite(v) for v in values):
            raise InputError(f"ServoTransient.compliance_rad_per_nm = {self.compliance_rad_per_nm!r}: expected "
                             "finite numbers, one for each of the arm's joints")
        if not (math.isfinite(self.time_constant_s) and 0 < self.time_constant_s <= 10.0):
            raise InputError(f"ServoTransient.time_constant_s = {self.time_constant_s!r}: expected (0, 10] s")
        object.__setattr__(self, "compliance_rad_per_nm", values)

    def deflection_m(self, t_s: np.ndarray, f_n: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        """δp_servo at the samples [m], (n, 3), in the frame of `f_n` and `jacobian`.

        Args:
            t_s: Sample times [s], (n,).
            f_n: Force on the tool [N], (n, 3).
            jacobian: Tool tip's translational Jacobian in the same frame [m/rad], (n, 3, dof).
        """
        c = np.asarray(self.compliance_rad_per_nm)
        if jacobian.shape[2] != len(c):
            raise InputError(f"the servo has {len(c)} joints, the Jacobian {jacobian.shape[2]}")
        high = f_n - lagged(t_s, f_n, self.time_constant_s)
        torque = np.einsum("nij,ni->nj", jacobian, high)
        return np.einsum("nij,nj->ni", jacobian, c * torque)
