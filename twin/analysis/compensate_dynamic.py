"""Offline compensation with the dynamic twin: the command iterated until the moving arm's tip follows the path.

The quasi-static compensation (`twin.analysis.compensate.compensate_twin`) settles every sample to rest; at a corner
stop or a pass reversal the real arm moves while the force turns, and its servo lags the reference. This stage
starts from that command and iterates it on the dynamic twin (`twin.sim.dynamic.DynamicTwin`, under a servo learned
from a run, `twin.analysis.learn.servo_fit`), as an iterative learning controller would on the robot itself
(D. A. Bristow, M. Tharayil, A. G. Alleyne, "A survey of iterative learning control", IEEE Control Systems
Magazine 26(3), 2006, pp. 96-114):

    u_{k+1}(t) = u_k(t) + Q * [-G(t)^-1 e_k(t + d)],

e_k the dynamic twin's tip minus U_ID, G the quasi-static twin's tip gain per sample (the learning gain, held in
its trust region as the quasi-static iteration holds it), d the servo's reference delay (the phase lead of the
survey's section "Design": a delayed plant learns from the error d later), and Q a zero-phase Gaussian low-pass
(the survey's Q-filter, which keeps the iteration robust where the model's phase is wrong: above the servo's
bandwidth). Q's σ is set from the servo, not tuned: its half-power frequency sqrt(ln 2) / (2π σ) is the slowest
arm joint's loop bandwidth (β times that joint's first mode, `DynamicTwin.mode_rad_s`); a rigid servo has none.

Each iteration is one quasi-static replay of the command (the force, the formed surface and the sheet's
stiffness the arm is linearised about) and one dynamic replay. The iteration keeps its best command, so the
result is never worse on the dynamic twin than the quasi-static command it starts from (iteration 0); it stops at
the tolerance, when the rms has not improved for `STALL_ITERATIONS` iterations, or at `max_iter`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from scipy.ndimage import gaussian_filter1d

from twin.analysis.compensate import (
    TWIN_TOL_M,
    Compensation,
    compensate_twin,
    formed_residual,
    trust_region_step,
)
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.sim.dynamic import DynamicTwin, without_servo
from twin.sim.dynamic_servo import ServoModel
from twin.sim.giving_frame import frame_compliance_m_per_n
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:
    from twin.sim.quasi_static import Twin

#: Dynamic iterations after the quasi-static start (each one quasi-static and one dynamic replay).
DYNAMIC_MAX_ITER = 8
#: Iterations without a new best rms after which the iteration stops.
STALL_ITERATIONS = 2


class DynamicCompensation(NamedTuple):
    """A command compensated on the dynamic twin.

    Attributes:
        compensation: The command (method `twin`), its dynamic residual and force; `history_m` the dynamic rms
            after each iteration, the first the quasi-static command's.
        quasi_static: The quasi-static compensation it started from.
        servo: The dynamic twin's servo.
        smoothing_s: σ of the learning filter Q [s] (0: none).
    """

    compensation: Compensation
    quasi_static: Compensation
    servo: ServoModel
    smoothing_s: float


def learning_filter_s(dynamic: DynamicTwin, servo: ServoModel) -> float:
    """σ of the learning filter Q [s]: its half-power frequency at the slowest arm joint's loop bandwidth
    (module docstring); 0 for a rigid servo."""
    if servo.rigid:
        return 0.0
    slowest = servo.bandwidth_over_mode * float(np.min(dynamic.mode_rad_s))  # [rad/s]
    return math.sqrt(math.log(2.0)) / slowest


def compensate_dynamic(
    t_s: np.ndarray,
    p_ideal_sheet_m: np.ndarray,
    twin: Twin | TwinSpec,
    servo: ServoModel,
    *,
    start: Compensation | None = None,
    tol_m: float = TWIN_TOL_M,
    max_iter: int = DYNAMIC_MAX_ITER,
    progress: Callable[[int, float], None] | None = None,
) -> DynamicCompensation:
    """Compensate U_ID on the dynamic twin, starting from the quasi-static compensation (module docstring).

    Args:
        t_s, p_ideal_sheet_m: Sample times [s] and the ideal path U_ID [m], shape (n, 3).
        twin: The twin (its servo transient, if any, is used by the quasi-static start only), or its spec.
        servo: The dynamic twin's servo (a model file's `dynamic_servo`, `fit_servo(...).servo`).
        start: The quasi-static compensation to start from; None: `compensate_twin` with the twin.
        tol_m: Stop when the dynamic rms residual is within this [m].
        max_iter: Dynamic iterations, >= 1.
        progress: Called after each iteration with (iteration, dynamic rms residual [m]); iteration 0 is the start.

    Raises:
        InputError: `max_iter` below 1, or a start of another path.
        CompensationError: The quasi-static start diverges (`compensate_twin`).
    """
    if not (isinstance(max_iter, int) and max_iter >= 1):
        raise InputError(f"max_iter = {max_iter!r}: expected an integer >= 1")
    if isinstance(twin, TwinSpec):
        twin = twin.build()
    t, p_id = np.asarray(t_s, dtype=float), np.asarray(p_ideal_sheet_m, dtype=float)
    start = start if start is not None else compensate_twin(t, p_id, twin, tol_m=tol_m)
    if start.p_cmd_sheet_m.shape != p_id.shape:
        raise InputError(f"the start command has shape {start.p_cmd_sheet_m.shape}; the ideal path {p_id.shape}")
    still = without_servo(twin)  # the servo is the dynamic one
    frame = frame_compliance_m_per_n(still.effects)
    step_s = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    cmd, sigma, history = start.p_cmd_sheet_m, 0.0, []
    best: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None
    best_at = 0
    for iteration in range(max_iter + 1):  # bounded: the start, then max_iter steps
        sim = still.simulate(t, cmd)
        dynamic = DynamicTwin(still, sim)
        moving = dynamic.simulate(servo)
        residual = formed_residual(moving, p_id, frame)
        history.append(float(np.sqrt(np.mean(np.sum(residual**2, axis=1)))))
        if progress is not None:
            progress(iteration, history[-1])
        if best is None or history[-1] < best[0]:
            best, best_at = (history[-1], cmd, residual, moving.f_sheet_n), iteration
        if iteration == 0:  # the joints' modes at the path's first pose: sub-millimetre steps hardly move them
            sigma = learning_filter_s(dynamic, servo)
        if history[-1] <= tol_m or iteration - best_at >= STALL_ITERATIONS or iteration == max_iter:
            break
        lead = interp_rows(np.clip(t + servo.delay_s, t[0], t[-1]), t, residual)
        step = -trust_region_step(sim.tip_gain, lead)
        if sigma > 0:
            step = gaussian_filter1d(step, sigma / step_s, axis=0, mode="nearest")
        cmd = cmd + step
    assert best is not None  # the loop ran at least once
    comp = Compensation("twin", t, p_id, best[1], len(history) - 1, best[2], tuple(history), best[0] <= tol_m, best[3])
    return DynamicCompensation(comp, start, servo, sigma)


__all__ = ["DYNAMIC_MAX_ITER", "DynamicCompensation", "compensate_dynamic", "learning_filter_s"]
