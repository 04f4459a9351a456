"""The robot's joints with friction that sticks: each joint's spring and friction refined as the twin replays them.

The linear fit (`twin.analysis.learn.robot`) takes a joint's friction as a torque that flips with the sign of the
joint's speed. The twin's equilibrium (`twin.sim.equilibrium`) holds a link still while the torque its friction
must supply stays within τ_f, so the link follows the motor through a play: turning one way it lags by τ_f/K_q,
and where the command turns back, or the load turns while the joint hardly moves, it holds until the motor has
wound its spring through 2·τ_f/K_q. On a part whose joints turn slowly back and forth (a cone's wrist) the link
sticks for long stretches while its load turns, and the linear fit reads the stuck phases as a stiffer spring.

Here each observable joint's link angle is the play operator (half-width c·τ_f, c = 1/K_q) of the angle it would
take without friction, q_cmd + c·τ, τ = J_jᵀF the measured force's torque on the joint (the command is taught
under gravity); the tool tip's deflection is Σ_j J_j (q_link − q_cmd), plus the servo's transient and a tracker
offset per run (linear: solved at every trial, a variable projection). c and τ_f of the observable joints come from
`scipy.optimize.least_squares`, started at the linear fit's values and positive by construction (their logs are
fitted). Their spread is the Jacobian's covariance scaled by the residual's variance and by its correlation in
time: the effective sample count N / (1 + 2 Σ_k ρ_k) over lags up to `CORRELATION_S` (a run's residuals are not
white, and the least-squares spread alone understates it), or, where larger, the spread of the mean of the values
`BLOCKS` contiguous parts of the runs give on their own (each part sees other poses and loads: what the model does
not hold shows there as a disagreement, where no statistical spread sees it).
"""

# mypy: disable-error-code="misc"
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.optimize import least_squares

#: Longest lag of the residual's autocorrelation counted in the effective sample count [s].
CORRELATION_S = 2.0
#: Contiguous blocks of each run refitted apart for the spread of what a part of the run says.
BLOCKS = 4
#: Bounds of a joint's compliance, relative to the prior's 1/K_q (a choice, wider than the class's spread seen so far:
#: the plant's K_q lie 0.35-1.38x the twin's priors; a fit that goes beyond is taken as pulled by what its columns
#: lack), and of the friction [N·m] (a joint the run hardly moves can trade a stiffer spring for more friction
#: without end: the twin would then never let it slide).
COMPLIANCE_RANGE = (0.25, 4.0)
FRICTION_MIN_NM, FRICTION_MAX_NM = 0.1, 2000.0
#: Where a joint's friction starts when the linear fit found less [N·m].
FRICTION_START_NM = 50.0


@njit(cache=True)
def play(u: np.ndarray, half_width: float) -> np.ndarray:
    """The play (backlash) operator: an output that follows `u` only once `u` is more than `half_width` away,
    starting at `u[0]`."""
    out = np.empty_like(u)
    y = u[0]
    for i in range(len(u)):
        if u[i] - y > half_width:
            y = u[i] - half_width
        elif y - u[i] > half_width:
            y = u[i] + half_width
        out[i] = y
    return out


class JointRows(NamedTuple):
    """One run at its tracker samples, for the play model."""

    t_s: np.ndarray  # (m,) [s]
    q: np.ndarray  # (m, dof) commanded joint angles [rad]
    jacobian: np.ndarray  # (m, 3, dof) tool tip's translational Jacobian, sheet frame [m/rad]
    torque: np.ndarray  # (m, dof) the measured force's torque on each joint [N·m]
    deflection_m: np.ndarray  # (m, 3) tracker minus the command [m]
    linear: np.ndarray  # (3m, k) the linear part's columns (the servo's transient per joint)
    nuisance: np.ndarray | None = None  # (3m, r) the run's own columns beside its offset (the tracker's rotation, clock)


def play_deflection(rows: JointRows, c: np.ndarray, friction_nm: np.ndarray) -> np.ndarray:
    """The tool tip's deflection (m, 3) [m] of joints with compliance `c` [rad/(N·m)] and friction [N·m]."""
    dq = rows.torque * c
    for j in np.flatnonzero(friction_nm > 0.0):
        u = rows.q[:, j] + dq[:, j]
        dq[:, j] = play(u, float(c[j] * friction_nm[j])) - rows.q[:, j]
    return np.asarray(np.einsum("nij,nj->ni", rows.jacobian, dq))


class StickSlip(NamedTuple):
    """`refine`'s result (fitted)."""

    c: np.ndarray  # (dof,) compliance [rad/(N·m)]
    c_std: np.ndarray  # (dof,) its spread (0 where held)
    friction_nm: np.ndarray  # (dof,) [N·m]
    linear: np.ndarray  # (k,) the linear part's coefficients
    own: list[np.ndarray]  # per run, its own columns' coefficients: the tracker offset [m], then its nuisance's
    rms_mm: tuple[float, ...]  # per run, RMS of the tracker minus the model [mm]


def nuisance_width(run: JointRows) -> int:
    """The number of a run's own columns: a tracker offset per axis, then its `nuisance` columns."""
    return 3 + (0 if run.nuisance is None else run.nuisance.shape[1])


def _linear_columns(runs: list[JointRows]) -> np.ndarray:
    """The linear part's columns over the stacked runs: the runs' shared ones (the servo's), then each run's own (a
    tracker offset per axis, its `nuisance` columns), zero on the other runs' rows. They do not depend on the spring
    or the friction: built once per fit."""
    widths = [nuisance_width(run) for run in runs]
    starts = np.concatenate([[0], np.cumsum(widths)])
    blocks = []
    for k, run in enumerate(runs):
        m = len(run.t_s)
        own = np.zeros((3 * m, int(starts[-1])))
        for a in range(3):
            own[a * m:(a + 1) * m, starts[k] + a] = 1.0
        if run.nuisance is not None:
            own[:, starts[k] + 3:starts[k + 1]] = run.nuisance
        blocks.append(np.hstack([run.linear, own]))
    return np.vstack(blocks)


def _split(runs: list[JointRows], X: np.ndarray, c: np.ndarray, friction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The residual with the linear part (`X`, `_linear_columns`) projected out, and that part's coefficients."""
    r = np.concatenate([(run.deflection_m - play_deflection(run, c, friction)).T.reshape(-1) for run in runs])
    beta = np.linalg.lstsq(X, r, rcond=None)[0]
    return r - X @ beta, beta


def refine(runs: list[JointRows], c: np.ndarray, friction_nm: np.ndarray, free: np.ndarray,
           c_prior: np.ndarray) -> StickSlip:
    """Refine the compliance and friction of the `free` joints (module docstring), within `COMPLIANCE_RANGE` of
    `c_prior` and `FRICTION_MAX_NM`; the others are held."""
    idx = np.flatnonzero(free)
    n = len(idx)
    low = np.concatenate([np.log(COMPLIANCE_RANGE[0] * c_prior[idx]), np.full(n, np.log(FRICTION_MIN_NM))])
    high = np.concatenate([np.log(COMPLIANCE_RANGE[1] * c_prior[idx]), np.full(n, np.log(FRICTION_MAX_NM))])

    def unpack(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cc, ff = c.copy(), friction_nm.copy()
        cc[idx], ff[idx] = np.exp(p[:n]), np.exp(p[n:])
        return cc, ff

    start = np.log(np.maximum(friction_nm[idx], FRICTION_START_NM))  # inside its bounds: a start on one stalls
    p0 = np.clip(np.concatenate([np.log(c[idx]), start]), low + 1e-9, high - 1e-9)
    X = _linear_columns(runs)
    sol = least_squares(lambda p: _split(runs, X, *unpack(p))[0], p0, diff_step=1e-3, bounds=(low, high))
    cc, ff = unpack(sol.x)
    residual, beta = _split(runs, X, cc, ff)
    dof_fit = max(len(residual) - len(sol.x) - len(beta), 1)
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * float(residual @ residual) / dof_fit * _correlation_factor(runs,
                                                                                                            residual)
    c_std = np.zeros(len(c))
    c_std[idx] = cc[idx] * np.sqrt(np.maximum(np.diag(cov)[:n], 0.0))  # d c = c d log c
    c_std = np.maximum(c_std, _block_spread(runs, cc, ff, free, (low, high)))
    k = runs[0].linear.shape[1]
    rms, start = [], 0
    for run in runs:
        m = 3 * len(run.t_s)
        rms.append(1e3 * float(np.sqrt(np.sum(residual[start:start + m] ** 2) / len(run.t_s))))
        start += m
    own = np.split(beta[k:], np.cumsum([nuisance_width(run) for run in runs])[:-1])
    return StickSlip(cc, c_std, ff, beta[:k], own, tuple(rms))


def _part(run: JointRows, sl: slice) -> JointRows:
    """The samples `sl` of a run (its linear columns are axis-major: x of all samples, then y, then z)."""
    m, n = len(run.t_s), sl.stop - sl.start
    def cut(columns: np.ndarray) -> np.ndarray:
        return columns.reshape(3, m, -1)[:, sl, :].reshape(3 * n, -1)

    return JointRows(run.t_s[sl], run.q[sl], run.jacobian[sl], run.torque[sl], run.deflection_m[sl],
                     cut(run.linear), None if run.nuisance is None else cut(run.nuisance))


def _block_spread(runs: list[JointRows], c: np.ndarray, friction_nm: np.ndarray, free: np.ndarray,
                  bounds: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The spread of the mean of the compliances the `BLOCKS` parts of the runs give apart (part b: the b-th of
    each run's contiguous blocks), each refitted from the whole runs' values."""
    idx = np.flatnonzero(free)
    n = len(idx)
    p0 = np.clip(np.concatenate([np.log(c[idx]), np.log(friction_nm[idx])]), bounds[0] + 1e-9, bounds[1] - 1e-9)
    values = []
    for b in range(BLOCKS):
        parts = [_part(r, slice(b * len(r.t_s) // BLOCKS, (b + 1) * len(r.t_s) // BLOCKS)) for r in runs]
        X = _linear_columns(parts)

        def residual(p: np.ndarray, parts: list[JointRows] = parts, X: np.ndarray = X) -> np.ndarray:
            cc, ff = c.copy(), friction_nm.copy()
            cc[idx], ff[idx] = np.exp(p[:n]), np.exp(p[n:])
            return _split(parts, X, cc, ff)[0]

        values.append(np.exp(least_squares(residual, p0, diff_step=1e-3, max_nfev=20, bounds=bounds).x[:n]))
    spread = np.zeros(len(c))
    spread[idx] = np.std(np.array(values), axis=0, ddof=1) / np.sqrt(BLOCKS)
    return spread


def _correlation_factor(runs: list[JointRows], residual: np.ndarray) -> float:
    """1 + 2 Σ_k ρ_k of the residual over lags up to `CORRELATION_S` (each run's axes, averaged): N / N_eff."""
    factors, start = [], 0
    for run in runs:
        m = len(run.t_s)
        dt = float(np.median(np.diff(run.t_s))) if m > 1 else 1.0
        lags = max(1, min(m // 4, int(CORRELATION_S / dt)))
        for a in range(3):
            e = residual[start + a * m:start + (a + 1) * m]
            e = e - e.mean()
            var = float(e @ e)
            if var <= 0.0:
                continue
            rho = np.array([float(e[:-k] @ e[k:]) / var for k in range(1, lags + 1)])
            factors.append(1.0 + 2.0 * float(np.sum(rho)))
        start += 3 * m
    return max(float(np.mean(factors)), 1.0) if factors else 1.0
