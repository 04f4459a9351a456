"""The robot learned from a cell's runs: the compliance of every joint a run excites, its friction, its servo.

Driven by the measured forces, a compliant arm's tool tip leaves the unloaded one by δp(t) = Σ_j c_j · J_j(q) · (J_j(q)ᵀ
F(t)) (J_j the tool tip's translational Jacobian column of joint j, c_j its compliance [rad/(N·m)]): linear in the c_j,
whatever the part and whatever the robot. The tracker gives δp (its reading minus the twin's unloaded tool tip), the F/T
sensor F. So the c_j come from one regularised least squares over the runs, each pulled towards the robot's prior 1/K_q
with a prior spread of `PRIOR_SPREAD` (a Gaussian prior; the posterior's standard deviations are the uncertainties). A
joint whose posterior spread is not below `OBSERVABLE_RATIO` of its prior spread is one the runs cannot observe: it is
named and held at its prior in the twin, and in the fit (with `keep_unobserved` it keeps its prior's spread there
instead: held, its prior's error goes to a joint whose column is nearly collinear with its own, with a spread that does
not say so; with the tool vertical and the forearm level, joints 1 and 4 turn the tip alike, and with joint 4 held a
groove's joint 1 came out far from the cell's K_q at a spread that called it learned). One the fit pulls outside
`stick_slip.COMPLIANCE_RANGE` of its prior (a quarter to four times its compliance: no gear of the class is there, the
fit is pulled by what its columns lack, and clipping it there would push its share onto its neighbours) is held in the
fit as well. Beside the gear spring the same solve fits what a real arm adds: each joint's Coulomb friction against its
motion (a deflection J_j·c_j·τ_f,j that flips with the sign of the joint's speed: a column kept free in the spring's fit
whatever its sign, since a deflection that leads the joint's motion is a real cell's too, and only its non-negative part
is the friction the twin takes), the servo's transient compliance c_s,j on the force's high-pass F − lag_τ(F)
(`twin.sim.servo`: the position loop gives way while the force changes and recovers over τ, picked on a grid by the
least residual), and per run the tracker's own errors (`TrackerErrors`): a constant offset per axis and, where asked
(`learn --tracker-errors`), its registration's rotation about the sheet origin and a lateness (`tracker_columns`: the
tracker's latency, or the robot's lag along the path, both read the tip a velocity times a time behind; `learn
--tracker-late`: the lateness alone). Without them a registration's tilt goes into joint 1 and a few milliseconds of
lateness into a friction (joints 2 and 3's on a groove, joint 1's on a cone); with them a lag of the robot along the
path is the tracker's, and no compensation takes it. They are reported, not put into the robot; the model carries the
registration as the instruments' (`twin.analysis.learn.instruments`). That linear fit is the start: the observable
joints' springs and friction are then refined as the twin's equilibrium holds them, a friction that sticks
(`twin.analysis.learn.stick_slip`), which is what their stated spread is of. `truth.json` is never read."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from twin.analysis.learn.stick_slip import COMPLIANCE_RANGE, JointRows, play_deflection, refine
from twin.analysis.learn.tracker import TRACKER_COLUMNS, TRACKER_SPREADS, TrackerErrors, tracker_columns
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.runs.format import Run
from twin.sim.quasi_static import Twin
from twin.sim.servo import ServoTransient, lagged

#: Prior spread of each joint's compliance, relative to its prior 1/K_q [-].
PRIOR_SPREAD = 1.0
#: Prior spread of each joint's friction torque [N·m].
FRICTION_SPREAD_NM = 1000.0
#: A joint is observable where its posterior spread is below this fraction of its prior spread.
OBSERVABLE_RATIO = 0.5
#: Joint speed below which the friction's sign turns smoothly (tanh) [rad/s].
SPEED_SMOOTHING_RAD_S = 2e-4
#: A joint is refined with its friction sticking (`stick_slip`) where the linear fit's spread is below this share of
#: its compliance.
REFINE_SPREAD = 0.1
#: Servo time constants tried [s].
SERVO_TIME_CONSTANTS_S = (0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3)


class RobotRows(NamedTuple):
    """One run's regression rows at its tracker samples (deflection and per-joint columns, sheet frame)."""

    deflection_m: np.ndarray  # (m, 3) tracker minus the twin's unloaded tool tip [m]
    t_s: np.ndarray  # (m,) tracker times [s]
    force_t_s: np.ndarray  # (k,) sensor times [s]
    force_n: np.ndarray  # (k, 3) measured force, sheet frame [N]
    lever: np.ndarray  # (m, dof, 3, 3) per joint J_j J_jᵀ, sheet frame [m²/rad²]
    friction: np.ndarray  # (m, 3, dof) per joint -J_j·s_j, s_j the smoothed sign of the joint's speed [m/rad]
    q: np.ndarray  # (m, dof) the commanded joint angles [rad]
    jacobian: np.ndarray  # (m, 3, dof) the tool tip's translational Jacobian, sheet frame [m/rad]
    nuisance: np.ndarray | None = None  # (3m, r) the tracker's own columns (`tracker_columns`), stacked as `design`'s


class RobotFit(NamedTuple):
    """`fit_robot`'s result (fitted, from the runs' own data).

    Attributes:
        k_q_nm_per_rad: Effective joint stiffness, (dof,) [N·m/rad]: fitted where observable, the prior elsewhere.
        std_nm_per_rad: Its standard deviation (dof,) [N·m/rad] (the prior's spread where unobservable).
        prior_nm_per_rad: The robot's prior K_q (dof,) [N·m/rad].
        prior_friction_nm: The twin's joint friction before learning (dof,) [N·m].
        observable: Whether the runs observe each joint (dof,).
        servo: The servo's transient compliance and time constant (`twin.sim.servo`), None where none is seen.
        friction_nm: Coulomb friction of each joint against its motion, (dof,) [N·m] (0 where unobservable).
        offset_mm: Fitted constant tracker offset per axis, sheet frame [mm].
        rms_prior_mm: Per run, RMS of the tracker minus the twin's tool tip driven by the measured forces, with the
            twin's own K_q, friction and servo: the robot's part of the replay gap [mm].
        rms_after_mm: The same with the learned K_q, friction, servo and tracker offset [mm].
        rotation_mrad: Fitted tracker rotation about the sheet origin, mean over the runs [mrad].
        late_ms: Fitted lateness of the tracker's reading (its clock, or the servo's following error), mean over
            the runs [ms].
    """

    k_q_nm_per_rad: np.ndarray
    std_nm_per_rad: np.ndarray
    prior_nm_per_rad: np.ndarray
    prior_friction_nm: np.ndarray
    observable: np.ndarray
    servo: ServoTransient | None
    friction_nm: np.ndarray
    offset_mm: np.ndarray
    rms_prior_mm: tuple[float, ...]
    rms_after_mm: tuple[float, ...]
    rotation_mrad: tuple[float, ...] = (0.0, 0.0, 0.0)
    late_ms: float = 0.0


def robot_rows(run: Run, twin: Twin, tracker: TrackerErrors = TrackerErrors.OFFSET) -> RobotRows:
    """The twin's unloaded tool tip and per-joint levers along the run's command, at its tracker times, with the
    `tracker`'s columns beyond its offset (`tracker_columns`: its lateness, and its rotation where TURNED)."""
    if run.forces is None or len(run.forces.t_s) < 10:
        raise InputError(f"run {run.directory}: learning the robot needs forces.csv (the F/T sensor on)")
    q_ik = twin.ik_path(run.commanded.values)
    t = run.tracker.t_s
    # the twin teaches its set-points under gravity (as a controller does): its unloaded tip is the command
    unloaded = interp_rows(t, run.commanded.t_s, run.commanded.values)
    q = interp_rows(t, run.commanded.t_s, q_ik)
    J = twin.kinematics.jacobians(q)[:, :3, :]  # base frame
    J_sheet = np.einsum("ki,nkj->nij", twin.R_base_sheet, J)  # R^T J: sheet frame, (n, 3, dof)
    lever = np.einsum("nij,nkj->njik", J_sheet, J_sheet)
    speed = np.gradient(q_ik, run.commanded.t_s, axis=0)
    sign = np.tanh(interp_rows(t, run.commanded.t_s, speed) / SPEED_SMOOTHING_RAD_S)
    velocity = interp_rows(t, run.commanded.t_s, np.gradient(run.commanded.values, run.commanded.t_s, axis=0))
    return RobotRows(run.tracker.values - unloaded, t, run.forces.t_s, run.forces.values, lever,
                     -J_sheet * sign[:, None, :], q, J_sheet,
                     None if tracker is TrackerErrors.OFFSET
                     else tracker_columns(unloaded, velocity, tracker is TrackerErrors.TURNED))


def design(rows: RobotRows, servo_s: float = 0.0) -> np.ndarray:
    """(3m, dof) columns of each joint's compliance for the stacked deflection (x of all samples, then y, z): of
    the measured force, or with `servo_s` > 0 of its high-pass F − lag(F) (the servo's transient)."""
    force = rows.force_n if servo_s <= 0.0 else rows.force_n - lagged(rows.force_t_s, rows.force_n, servo_s)
    cols = np.einsum("njik,nk->nji", rows.lever, interp_rows(rows.t_s, rows.force_t_s, force))  # (m, dof, 3)
    return cols.transpose(2, 0, 1).reshape(-1, cols.shape[1])


def friction_columns(rows: RobotRows) -> np.ndarray:
    """(3m, dof) each joint's friction column (-J_j times the sign of its speed), stacked as `design`'s."""
    return rows.friction.transpose(1, 0, 2).reshape(-1, rows.friction.shape[2])


def own_columns(rows: RobotRows) -> np.ndarray:
    """(3m, 3 + r) a run's own columns: the tracker's offset per axis, then its `nuisance` columns."""
    m = len(rows.t_s)
    offset = np.kron(np.eye(3), np.ones((m, 1)))
    return offset if rows.nuisance is None else np.hstack([offset, rows.nuisance])


def own_precision(rows: RobotRows) -> np.ndarray:
    """The prior precision of a run's own columns: the offset free, the rotation and the lateness within
    `TRACKER_SPREADS` (a tracker registered and clocked to a cell's usual care)."""
    width = 3 if rows.nuisance is None else 3 + rows.nuisance.shape[1]
    return np.concatenate([np.full(3, 1e-12), 1.0 / np.asarray(TRACKER_SPREADS[:width - 3]) ** 2])


def gaussian_posterior(X: np.ndarray, y: np.ndarray, precision: np.ndarray,
                       mean: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(posterior mean, covariance) of y = X beta + noise under a Gaussian prior beta ~ N(mean, diag(1/precision)),
    the noise's level from an unregularised solve's residual, floored at 10 µm."""
    sigma = max(float(np.std(y - X @ np.linalg.lstsq(X, y, rcond=1e-10)[0])), 1e-5)
    cov = np.linalg.inv(X.T @ X / sigma**2 + np.diag(precision))
    return cov @ (X.T @ y / sigma**2 + precision * mean), cov


def _solve(runs: list[RobotRows], servo_s: float, c0: np.ndarray,
           free: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """(coefficients, posterior covariance, RSS) of the regularised fit. Coefficients: the compliances c (dof),
    the friction deflections c_j·τ_f,j (dof) [rad], the servo's transient compliances c_s (dof), then each run's
    own (`own_columns`: the tracker's offset [m], rotation [rad] and lateness [s]). A joint not `free` (default:
    all free) is held at its prior compliance with no friction and no servo term: their columns leave the fit
    (variance 0)."""
    dof = len(c0)
    held = np.zeros(dof, dtype=bool) if free is None else ~np.asarray(free, dtype=bool)
    owns = [own_columns(rows) for rows in runs]
    widths = np.array([o.shape[1] for o in owns])
    starts = np.concatenate([[0], np.cumsum(widths)])
    blocks, ys = [], []
    for k, rows in enumerate(runs):
        own = np.zeros((3 * len(rows.t_s), int(starts[-1])))
        own[:, starts[k]:starts[k + 1]] = owns[k]
        blocks.append(np.hstack([design(rows), friction_columns(rows), design(rows, servo_s), own]))
        ys.append(rows.deflection_m.T.reshape(-1))
    X, y = np.vstack(blocks), np.concatenate(ys)
    # the held joints' prior deflection is taken out of the data; the held columns out of the fit
    drop = np.concatenate([held, held, held, np.zeros(int(starts[-1]), dtype=bool)])
    if drop.any():
        y = y - X[:, :dof][:, held] @ c0[held]
        X[:, drop] = 0.0
    prior_precision = np.concatenate([1.0 / (PRIOR_SPREAD * c0) ** 2, 1.0 / (FRICTION_SPREAD_NM * c0) ** 2,
                                      1.0 / (PRIOR_SPREAD * c0) ** 2, *(own_precision(rows) for rows in runs)])
    coef, cov = gaussian_posterior(X, y, prior_precision, np.concatenate([c0, np.zeros(2 * dof + int(starts[-1]))]))
    rss = float(np.sum((y - X @ coef) ** 2))
    if drop.any():
        coef[drop] = 0.0
        coef[:dof][held] = c0[held]
        cov = cov * np.outer(~drop, ~drop)
    return coef, cov, rss


def joint_rows(rows: RobotRows, linear: np.ndarray) -> JointRows:
    """The rows as the play model takes them (`twin.analysis.learn.stick_slip`), with the linear part's columns."""
    torque = np.einsum("nij,ni->nj", rows.jacobian, interp_rows(rows.t_s, rows.force_t_s, rows.force_n))
    return JointRows(rows.t_s, rows.q, rows.jacobian, torque, rows.deflection_m, linear, rows.nuisance)


def predicted_deflection(rows: RobotRows, fit: RobotFit, offset_m: np.ndarray) -> np.ndarray:
    """The learned robot's tool-tip deflection under the measured forces at the tracker's times [m], (m, 3): its
    springs and sticking friction (`stick_slip.play_deflection`, as the twin's equilibrium holds them), servo, plus
    `offset_m` (the tracker's own: (3,) or (m, 3))."""
    m = len(rows.t_s)
    spring = play_deflection(joint_rows(rows, np.zeros((3 * m, 0))), 1.0 / fit.k_q_nm_per_rad, fit.friction_nm)
    servo = 0.0 if fit.servo is None else (design(rows, fit.servo.time_constant_s)
                                           @ np.asarray(fit.servo.compliance_rad_per_nm)).reshape(3, m).T
    return spring + servo + offset_m


def fit_robot(runs: list[Run], twin: Twin, tracker: TrackerErrors = TrackerErrors.OFFSET) -> RobotFit:
    """Learn the effective joint compliances, the servo lag and the tracker offset from runs (module docstring).

    Args:
        runs: Runs with tracker and force streams, made by the twin's robot at the twin's placement.
        twin: The twin (its robot's K_q is the prior).
        tracker: Which of each run's tracker errors are fitted beside its offset (`tracker_columns`). TURNED keeps a
            joint the runs cannot observe in the fit with its prior's spread (`fit_rows`' `keep_unobserved`); LATE
            holds it (free, a wrist joint trades with joint 1 as a late tracker's reading does on a cone).
    """
    return fit_rows([robot_rows(run, twin, tracker) for run in runs], twin.joint_stiffness,
                    twin.joint_friction, twin.spec.servo, keep_unobserved=tracker is TrackerErrors.TURNED)


def fit_rows(rows: list[RobotRows], k0: np.ndarray, prior_friction_nm: np.ndarray,
             prior_servo: ServoTransient | None, keep_unobserved: bool = False) -> RobotFit:
    """`fit_robot` on the runs' regression rows (module docstring).

    Args:
        rows: Per run, its rows (`robot_rows`).
        k0: The prior joint stiffness (dof,) [N·m/rad].
        prior_friction_nm: The twin's joint friction before learning (dof,) [N·m].
        prior_servo: The twin's servo transient before learning (None: none).
        keep_unobserved: A joint the runs cannot observe keeps its prior's spread in the fit (held at its prior
            in the twin all the same); False: it is held at its prior in the fit too.
    """
    k0 = np.asarray(k0, dtype=float)
    c0 = 1.0 / k0
    solves = {tau: _solve(rows, tau, c0) for tau in SERVO_TIME_CONSTANTS_S}
    best = min(solves, key=lambda tau: solves[tau][2])
    coef, cov, _ = solves[best]
    dof = len(c0)
    observable = np.sqrt(np.diag(cov)[:dof]) < OBSERVABLE_RATIO * PRIOR_SPREAD * c0
    # a joint the runs cannot observe is held at its prior in the fit (or, `keep_unobserved`, keeps its prior's
    # spread there: holding it would put its prior's error on the joints whose columns are nearly collinear with its
    # own, with a spread that does not say so) and in the twin; one the fit pulls outside its range is held in both
    held = np.zeros(dof, dtype=bool) if keep_unobserved else ~observable
    if held.any():
        coef, cov, _ = _solve(rows, best, c0, ~held)
    for _ in range(dof):
        outside = observable & ((coef[:dof] < COMPLIANCE_RANGE[0] * c0) | (coef[:dof] > COMPLIANCE_RANGE[1] * c0))
        if not outside.any():
            break
        observable &= ~outside
        held |= outside
        coef, cov, _ = _solve(rows, best, c0, ~held)
    c, c_std = np.where(observable, coef[:dof], c0), np.sqrt(np.diag(cov)[:dof])
    friction = np.where(observable, np.maximum(coef[dof:2 * dof], 0.0) / c, 0.0)
    servo_c = np.where(observable, coef[2 * dof:3 * dof], 0.0)
    own = np.split(coef[3 * dof:], np.cumsum([own_columns(r).shape[1] for r in rows])[:-1])
    # the springs and friction as the twin's equilibrium holds them (friction that sticks), for the joints the
    # linear fit pins down; a joint it leaves loose keeps the linear fit's values (its spring and friction could
    # trade against each other without end)
    pinned = observable & (c_std < REFINE_SPREAD * c)
    if pinned.any():
        # a joint whose deflection leads its motion (its sign column came out negative) keeps that column beside
        # the servo's: the play holds a friction, never a lead, and without it the springs would take its share
        lead = observable & (coef[dof:2 * dof] < 0.0)
        ss = refine([joint_rows(r, np.hstack([design(r, best)[:, observable], friction_columns(r)[:, lead]]))
                     for r in rows], c, friction, pinned, c0)
        c = np.where(pinned, ss.c, c)
        c_std = np.where(pinned, ss.c_std, c_std)
        friction, own = np.where(observable, ss.friction_nm, 0.0), ss.own
        servo_c = np.zeros(dof)
        servo_c[observable] = ss.linear[:int(observable.sum())]
    k = 1.0 / c
    k_std = np.where(observable, c_std / c**2, PRIOR_SPREAD * k0)
    servo = ServoTransient(tuple(float(v) for v in servo_c), float(best)) if np.any(servo_c != 0) else None
    offset_mm, rotation_mrad, late_ms = _tracker_means(own)
    fit = RobotFit(k, k_std, k0, np.asarray(prior_friction_nm, dtype=float), observable, servo, friction, offset_mm,
                   (), (), rotation_mrad, late_ms)
    prior = fit._replace(k_q_nm_per_rad=k0, servo=prior_servo, friction_nm=fit.prior_friction_nm)
    prior_rms = tuple(rms_norm_mm(r.deflection_m - predicted_deflection(r, prior, np.zeros(3))) for r in rows)
    after_rms = tuple(rms_norm_mm(r.deflection_m - predicted_deflection(r, fit, (own_columns(r) @ o).reshape(3, -1).T))
                      for r, o in zip(rows, own, strict=True))
    return fit._replace(rms_prior_mm=prior_rms, rms_after_mm=after_rms)


def _tracker_means(own: list[np.ndarray]) -> tuple[np.ndarray, tuple[float, ...], float]:
    """The tracker's offset [mm], rotation [mrad] and lateness [ms] from each run's own coefficients (`own_columns`),
    mean over the runs (zero where the rows had no such columns)."""
    mean = np.mean(own, axis=0)
    full = np.zeros(3 + TRACKER_COLUMNS)
    full[:len(mean)] = mean
    return 1e3 * full[:3], tuple(float(v) for v in 1e3 * full[3:3 + 3]), 1e3 * float(full[3 + 3])


def rms_norm_mm(error_m: np.ndarray) -> float:
    """RMS over the samples of the norm of a tool-tip error (n, 3) [m], in [mm]."""
    return 1e3 * float(np.sqrt(np.mean(np.sum(error_m**2, axis=1))))
