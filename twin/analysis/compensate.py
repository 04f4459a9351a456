"""Offline compensation of the tool path (thesis sec. 4.3, Eq. 4.28) and its gain.

Sign convention: forces here are exerted BY THE SHEET ON THE TOOL (Fz > 0 while forming), and the robot
gives way along them: deflection d = C_R f. The compensated command therefore goes against the force,

    U_ALG = U_ID - C_R f_ID,

which is the thesis's Eq. 4.28 U_ALG = U_ID + C_R F_ID written with the force the tool exerts on the sheet.
The compensation gain g is the least-squares factor with (U_ALG - U_ID) = g (-C_R f_ref), f_ref being the
physical reference force: a correct compensation has g = 1; the thesis's run, made with the half-model FE
forces, had g = 0.5 (sec. 5.1).

Two methods:
- `formula`: Eq. 4.28 with a constant compliance C_R (from an identified K_R).
- `twin`: fixed-point iteration with the twin (force field feedback, formed-surface state, pose-dependent
  Jacobian, and any effects the twin model carries): U_cmd <- U_cmd - G^-1 (U_sim - U_ID), G the tip's gain per
  sample, Anderson-accelerated (`twin.analysis.anderson`), until the rms of U_sim - U_ID is within the tolerance.

The tolerance, 0.01 mm rms, is half the tracker's noise (σ 0.02 mm per axis, the Krypton K-610 class of the
thesis's lab, §3.2.1, `twin.lab.virtual`): a residual below it cannot be told from zero in a measured run.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from twin.analysis.anderson import Anderson
from twin.errors import CompensationError, IdentificationError, InputError
from twin.process.toolpath.groove import label_passes
from twin.sim.giving_frame import frame_compliance_m_per_n
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:  # the twin (MuJoCo, numba) loads when a spec is built
    from twin.sim.quasi_static import Twin
    from twin.sim.result import SimResult

TWIN_TOL_M = 1e-5  # rms residual [m]: half the tracker's noise sigma (module docstring)
TWIN_MAX_ITER = 20
ANDERSON_MEMORY = 3  # earlier iterates the acceleration mixes
STEP_LIMIT = 1.5  # largest command step of one iteration, in units of that sample's residual [-]
# Stalled: the last STALL_ITERATIONS iterations did not bring the rms residual below STALL_RATIO times the best
# before them. Joint friction flips with the joints' motion at each reversal, a discontinuity no command removes.
STALL_ITERATIONS = 3
STALL_RATIO = 0.95
# Out of iterations with its best within this many tolerances (the tracker's noise sigma, module docstring): the best
# command, not converged, as a stall; beyond it an error.
NOISE_TOL_RATIO = 2.0


@dataclass(frozen=True)
class Compensation:
    """A compensated path.

    Attributes:
        method: `formula` or `twin`.
        t_s: Sample times [s].
        p_ideal_sheet_m: Ideal path U_ID [m], shape (n, 3).
        p_cmd_sheet_m: Compensated command U_ALG [m], shape (n, 3).
        iterations: Twin iterations (0 for the formula).
        predicted_residual_m: Predicted tool tip (where the sheet meets it) minus U_ID with the twin used [m],
            shape (n, 3), or None.
        history_m: RMS residual after each twin iteration [m].
        converged: True when the twin iteration's rms residual reached its tolerance; False when it stalled
            above it and returned its best command (the remainder is in `predicted_residual_m`, typically a few
            samples at the reversals, where joint friction flips).
        predicted_force_n: The sheet's force on the tool the twin predicts along the returned command [N],
            shape (n, 3) (the simulation that gave `predicted_residual_m`), or None (the formula).
    """

    method: str
    t_s: np.ndarray
    p_ideal_sheet_m: np.ndarray
    p_cmd_sheet_m: np.ndarray
    iterations: int
    predicted_residual_m: np.ndarray | None
    history_m: tuple[float, ...] = ()
    converged: bool = True
    predicted_force_n: np.ndarray | None = None

    @property
    def correction_m(self) -> np.ndarray:
        """U_ALG - U_ID [m], shape (n, 3)."""
        return self.p_cmd_sheet_m - self.p_ideal_sheet_m


def compliance_from_stiffness(k_r_n_per_m: np.ndarray) -> np.ndarray:
    """3x3 compliance [m/N] from a 2x2 (x-z) or 3x3 K_R [N/m].

    A 2x2 x-z stiffness is inverted and embedded with zero y row and column; a 3x3 one is inverted whole
    (y free, the right choice when Fy = 0 and the groove does not hold the tool in y).
    """
    k = np.asarray(k_r_n_per_m, dtype=float)
    if k.shape not in ((2, 2), (3, 3)) or not np.all(np.isfinite(k)):
        raise InputError(f"K_R must be a finite 2x2 (x-z) or 3x3 matrix [N/m], got shape {k.shape}")
    if abs(np.linalg.det(k)) <= 1e-12 * np.max(np.abs(k)) ** k.shape[0]:  # <=: an all-zero K is singular too
        raise InputError(f"K_R is singular: {k.tolist()}")
    if k.shape == (3, 3):
        return np.asarray(np.linalg.inv(k))
    c = np.zeros((3, 3))
    c[np.ix_([0, 2], [0, 2])] = np.linalg.inv(k)
    return c


def compensate_formula(
    t_s: np.ndarray, p_ideal_sheet_m: np.ndarray, f_ideal_n: np.ndarray, c_r_m_per_n: np.ndarray
) -> Compensation:
    """Eq. 4.28: U_ALG = U_ID - C_R f_ID (forces of the sheet on the tool).

    Args:
        t_s: Sample times [s], shape (n,).
        p_ideal_sheet_m: Ideal path U_ID [m], shape (n, 3).
        f_ideal_n: Ideal (FE) forces along U_ID, physical, sheet on tool [N], shape (n, 3).
        c_r_m_per_n: Compliance C_R [m/N], shape (3, 3).
    """
    p = np.asarray(p_ideal_sheet_m, dtype=float)
    f = np.asarray(f_ideal_n, dtype=float)
    if p.shape != f.shape or p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"ideal path {p.shape} and forces {f.shape} must both be (n, 3)")
    cmd = p - f @ np.asarray(c_r_m_per_n, dtype=float).T
    return Compensation("formula", np.asarray(t_s, dtype=float), p, cmd, 0, None)


def compensate_twin(
    t_s: np.ndarray,
    p_ideal_sheet_m: np.ndarray,
    twin: Twin | TwinSpec,
    *,
    tol_m: float = TWIN_TOL_M,
    max_iter: int = TWIN_MAX_ITER,
    progress: Callable[[int, float], None] | None = None,
    memory: int = ANDERSON_MEMORY,
) -> Compensation:
    """Iterate the command with the twin until its simulated tool tip follows U_ID where the sheet meets it: on a
    clamping frame that gives (`twin.sim.giving_frame`), c f_z above the tip the tracker sees, so that the part is
    formed to U_ID (the tracker then sees the tip that much deeper).

    Args:
        t_s, p_ideal_sheet_m: Sample times [s] and the ideal path U_ID [m], shape (n, 3).
        twin: The twin (with whatever effects and stiffness it carries), or its spec.
        tol_m: Stop when the rms of |U_sim - U_ID| over the path is within this [m].
        max_iter: Iteration limit (each iteration is one simulation).
        progress: Called after each iteration with (iteration, rms residual [m]).
        memory: Earlier iterates the Anderson acceleration mixes (0: the plain iteration).

    Returns:
        The compensation; `converged` is False when the iteration stalled above `tol_m` (joint friction that
        flips with the joints' motion, at reversals and corners, leaves a few samples that no command settles),
        or ran out of iterations still falling with its best within `NOISE_TOL_RATIO` x `tol_m`: the best command
        is returned.

    Raises:
        CompensationError: The iteration diverges, or runs out of iterations with its best rms residual above
            `NOISE_TOL_RATIO` x `tol_m`.
    """
    if isinstance(twin, TwinSpec):
        twin = twin.build()
    p_id = np.asarray(p_ideal_sheet_m, dtype=float)
    t = np.asarray(t_s, dtype=float)
    cmd = p_id.copy()
    history: list[float] = []
    best: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None
    accelerate = Anderson(memory)
    q_ik = None
    frame = frame_compliance_m_per_n(twin.effects)  # a clamping frame that gives [m/N]
    for iteration in range(1, max_iter + 1):
        sim = twin.simulate(t, cmd, q_ik=q_ik)
        residual = formed_residual(sim, p_id, frame)
        history.append(float(np.sqrt(np.mean(np.sum(residual**2, axis=1)))))
        if progress is not None:
            progress(iteration, history[-1])
        if best is None or history[-1] < best[0]:
            best = (history[-1], cmd, residual, sim.f_sheet_n)
        if history[-1] <= tol_m:
            return Compensation("twin", t, p_id, cmd, iteration, residual, tuple(history), True, sim.f_sheet_n)
        bounced = iteration > 2 and history[-1] > 2.0 * min(history)
        if bounced and history[-1] > 0.5 * history[0]:
            raise CompensationError(
                f"twin compensation diverges: its rms residual after each iteration "
                f"{[round(h * 1e3, 3) for h in history]} mm rose from its lowest, {min(history) * 1e3:.3f} mm, to "
                f"more than twice that and half its start: this twin cannot hold the path")
        stalled = iteration > STALL_ITERATIONS and min(history[-STALL_ITERATIONS:]) > STALL_RATIO * min(
            history[:-STALL_ITERATIONS]
        )
        if bounced or stalled:  # bouncing well below the start: the friction flips at the reversals
            return Compensation("twin", t, p_id, best[1], iteration, best[2], tuple(history), False, best[3])
        if iteration > 1 and history[-1] > history[-2]:  # the mixed step went too far: start the memory anew
            accelerate.clear()
        cmd = accelerate.next(cmd, -trust_region_step(sim.tip_gain, residual))
        # the command moved by micrometres to millimetres: its IK starts from the last one's
        q_ik = twin.kinematics.ik_path(twin.p_base_sheet_origin + cmd @ twin.R_base_sheet.T, q_near=sim.q_ik)
    if best is not None and best[0] <= NOISE_TOL_RATIO * tol_m:  # still falling, under what a tracker can see
        return Compensation("twin", t, p_id, best[1], max_iter, best[2], tuple(history), False, best[3])
    raise CompensationError(
        f"twin compensation did not reach {tol_m * 1e3:g} mm rms in {max_iter} iterations "
        f"(rms residual after each: {[round(h * 1e3, 4) for h in history]} mm)"
    )


def formed_residual(sim: SimResult, p_ideal_sheet_m: np.ndarray, frame_m_per_n: float) -> np.ndarray:
    """Where the sheet meets the simulated tip, minus U_ID [m], (n, 3): the tip, and on a clamping frame that gives
    (`twin.sim.giving_frame`, `frame_m_per_n` [m/N]) c f_z above it, where the part is formed."""
    residual = sim.p_sheet_m - p_ideal_sheet_m
    residual[:, 2] += frame_m_per_n * sim.f_sheet_n[:, 2]
    return residual


def trust_region_step(tip_gain: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """The command change of one iteration: a local Newton step per sample, held within a trust region.

    The tip moves by tip_gain @ d_cmd when the command moves by d_cmd. The sheet's force law has a kink where the
    tool lifts off the surface it meets, and joint friction flips with the joints' motion: there the local gain
    can ask for a step several times the residual, so each sample's step is held within STEP_LIMIT times its
    residual.

    Args:
        tip_gain: d p_tcp / d p_cmd per sample [-], shape (n, 3, 3).
        residual: Simulated tool tip minus the ideal path [m], shape (n, 3).

    Returns:
        The step to subtract from the command [m], shape (n, 3).
    """
    step = np.linalg.solve(tip_gain, residual[..., None])[..., 0]
    ratio = np.linalg.norm(step, axis=1) / np.maximum(np.linalg.norm(residual, axis=1), 1e-12)
    return step * np.minimum(1.0, STEP_LIMIT / np.maximum(ratio, 1e-12))[:, None]


def gain_of(compensation: Compensation, f_reference_n: np.ndarray, c_r_m_per_n: np.ndarray) -> float:
    """Compensation gain g: (U_ALG - U_ID) ~ g (-C_R f_ref) + b·direction, least squares over x and z.

    Args:
        compensation: The compensated path.
        f_reference_n: Physical reference forces along U_ID, sheet on tool [N], shape (n, 3).
        c_r_m_per_n: Reference compliance [m/N], shape (3, 3).
    """
    predicted = -np.asarray(f_reference_n, dtype=float) @ np.asarray(c_r_m_per_n, dtype=float).T
    _, direction = label_passes(compensation.p_ideal_sheet_m[:, 0])
    return compensation_gain(compensation.correction_m[:, [0, 2]], predicted[:, [0, 2]], direction)


def compensation_gain(
    delta_m: np.ndarray, predicted_m: np.ndarray, direction: np.ndarray | None = None
) -> float:
    """Least-squares gain g with (U_ALG − U_ID) ≈ g·C_R·F_ID (Eq. 4.28 scaled): g = ⟨Δ, P⟩ / ⟨P, P⟩.

    With `direction`, an offset b per axis that flips with the travel direction is fitted jointly,
    Δ ≈ g·P + b·direction: joint friction and lost motion shift the tool by such an offset, and a compensation
    that cancels it is no force-scale error. Fx flips with the direction too, so without the offset term it
    would pass for a gain.

    Args:
        delta_m: Observed corrections or deflections Δ, shape (n, k) [m].
        predicted_m: Predicted deflections P = C_R·F_ID, same shape [m].
        direction: Travel direction per sample (+1/-1), shape (n,); None fits the gain alone.

    Returns:
        The gain g (1 when the correction is what the prediction asks for; 0.5 for the thesis's run, whose
        correction used the half-model FE forces, §5.1).

    Raises:
        InputError: Shapes differ or values are not finite.
        IdentificationError: P is zero (all below 1 nm), so no gain is determined.
    """
    delta = np.asarray(delta_m, dtype=float)
    predicted = np.asarray(predicted_m, dtype=float)
    if delta.shape != predicted.shape or delta.size == 0:
        raise InputError(
            f"delta {delta.shape} and predicted {predicted.shape} must have the same non-empty shape"
        )
    if not (np.all(np.isfinite(delta)) and np.all(np.isfinite(predicted))):
        raise InputError("delta and predicted must be finite (found NaN or inf)")
    if float(np.max(np.abs(predicted))) < 1e-9:
        raise IdentificationError(
            f"predicted deflections are all below 1 nm (largest {np.max(np.abs(predicted)):.3g} m): "
            "the gain is undetermined; are the forces zero?"
        )
    if direction is None:
        return float(np.vdot(delta, predicted) / np.vdot(predicted, predicted))
    d = np.asarray(direction, dtype=float)
    if d.shape != (delta.shape[0],):
        raise InputError(f"direction has shape {d.shape}, expected ({delta.shape[0]},)")
    n, k = delta.shape
    design = np.zeros((n * k, 1 + k))
    design[:, 0] = predicted.ravel()
    for j in range(k):
        design[j::k, 1 + j] = d
    solution, *_ = np.linalg.lstsq(design, delta.ravel(), rcond=None)
    return float(solution[0])
