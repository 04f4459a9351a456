"""The servo and its stop timing, learned from a run's own data for the dynamic twin (`twin.sim.dynamic`).

The dynamic twin's generic servo has five numbers (`ServoModel`: bandwidth over each joint's mode β, damping ζ,
reference delay d, inertial feed-forward share a, the share b of the twin's own sheet load fed forward). They are
fitted to the run's tracker: the residual tracker − the dynamic replay's predicted tracker
(`twin.sim.measure.predict_tracker`, the twin's instruments) at every tracker sample, by a coarse grid (`GRID`) and
then `scipy.optimize.least_squares` (trust region, bounded, from the grid's best; deterministic). One quasi-static
replay serves every evaluation (`DynamicTwin`).

What drives the fit's arm: the twin's own sheet (the quasi-static replay's force, linearised), or, where the run's
F/T stream is fast enough (`MEASURED_FORCES_MIN_HZ`), the forces it measured (`DynamicTwin`'s `forces`): the robot
alone, as `learn` fits the springs, with none of the twin's load fed forward (b = 0). A stream of tens of hertz folds
the force's fast content into the band the arm follows; driven by it, the arm misses more (docs/dynamic-twin.md,
"The arm under the measured forces").

The stop timing is read from the stamps themselves as well: at each sharp corner or reversal of the command (a turn
over `CORNER_TURN_DEG`, where the controller brings the tool to rest), the time of the tracker's slowest sample
minus that of the command's, the median over the corners (`stop_lag`); it seeds d.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from itertools import product

import numpy as np
from scipy.optimize import least_squares

from twin.analysis.replay import ReplayResult, replay_metrics
from twin.analysis.resolve import spec_for_run
from twin.errors import IdentificationError, InputError, RunFormatError
from twin.runs.format import Run
from twin.sim.dynamic import DynamicTwin, ServoModel, without_servo
from twin.sim.measure import predict_forces, predict_tracker
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

#: A turn of the commanded path over this is a corner the controller stops at [deg].
CORNER_TURN_DEG = 30.0
#: The grid the fit starts from: β, ζ, a, b (d starts at the stamps' stop lag).
GRID = {"bandwidth_over_mode": (0.25, 0.5, 1.0, 2.0), "damping_ratio": (0.7, 1.4), "feedforward": (0.0, 1.0),
        "load_feedforward": (0.0, 1.0)}
#: Bounds of the fit: β, ζ, d [s], a, b.
BOUNDS = ((0.05, 0.3, 0.0, 0.0, 0.0), (3.0, 5.0, 0.1, 1.0, 1.0))
#: The fit's unit of each: it steps in these (finite differences of 2 % of a unit).
SCALE = np.array([1.0, 1.0, 0.01, 1.0, 1.0])
#: An F/T stream at this rate or faster drives the fit's arm by its measured forces [Hz]: its Nyquist frequency lies
#: above the arm's first modes (10-75 Hz on the shipped robots, `DynamicTwin.mode_rad_s`).
MEASURED_FORCES_MIN_HZ = 250.0
#: Window around a commanded stop in which the tracker's slowest sample is looked for [s].
STOP_WINDOW_S = 0.3


@dataclass(frozen=True)
class ServoFit:
    """A servo learned from a run.

    Attributes:
        servo: The fitted servo.
        bandwidth_rad_s: Its bandwidth on each arm joint, β times the joint's mode [rad/s].
        stop_lag_s: The tracker's stops behind the command's, median over the corners [s] (NaN: no corner).
        rms_rigid_mm: Tracker residual rms with a rigid servo (β = inf, d = 0) [mm].
        rms_mm: Tracker residual rms with the fitted servo [mm].
        evaluations: Dynamic replays the fit ran.
        wall_s: Its wall time [s].
        measured_forces: Whether the run's measured forces drove the arm (else the twin's sheet).
    """

    servo: ServoModel
    bandwidth_rad_s: tuple[float, ...]
    stop_lag_s: float
    rms_rigid_mm: float
    rms_mm: float
    evaluations: int
    wall_s: float
    measured_forces: bool = False


def corner_indices(p_cmd_sheet_m: np.ndarray, turn_deg: float = CORNER_TURN_DEG) -> np.ndarray:
    """Samples of a commanded path where it turns by more than `turn_deg` (corners, reversals), shape (k,).

    Args:
        p_cmd_sheet_m: Commanded tool tip [m], shape (n, 3).
        turn_deg: Smallest turn [deg].
    """
    p = np.asarray(p_cmd_sheet_m, dtype=float)
    keep = np.r_[True, np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-7]
    idx = np.flatnonzero(keep)  # samples that moved (a stop repeats a point)
    seg = np.diff(p[idx], axis=0)
    u = seg / np.linalg.norm(seg, axis=1)[:, None]
    turn = np.sum(u[1:] * u[:-1], axis=1) < math.cos(math.radians(turn_deg))
    return idx[1:-1][turn]


def near_corners(run: Run, radius_m: float, t_s: np.ndarray | None = None) -> np.ndarray:
    """Which samples lie within `radius_m` of a commanded corner or reversal, shape (m,) bool.

    Args:
        run: The run (its commanded path; its tracker times unless `t_s` is given).
        radius_m: Distance of the commanded tip at the sample from the nearest corner [m].
        t_s: Sample times [s], shape (m,); None: the tracker's.
    """
    t = run.tracker.t_s if t_s is None else np.asarray(t_s, dtype=float)
    corners = run.commanded.values[corner_indices(run.commanded.values)]
    if not len(corners):
        return np.zeros(len(t), dtype=bool)
    cmd = np.column_stack([np.interp(t, run.commanded.t_s, run.commanded.values[:, j]) for j in range(3)])
    dist = np.min(np.linalg.norm(cmd[:, None, :] - corners[None, :, :], axis=2), axis=1)
    return dist < radius_m


def stop_lag(run: Run) -> float:
    """The tracker's stops behind the command's: median over the corners of the time of the tracker's slowest
    sample minus the command's within `STOP_WINDOW_S` [s]; NaN where the command has no corner."""
    t_c, p_c, t_k, p_k = run.commanded.t_s, run.commanded.values, run.tracker.t_s, run.tracker.values
    v_c = np.r_[np.inf, np.linalg.norm(np.diff(p_c, axis=0), axis=1) / np.diff(t_c)]
    v_k = np.linalg.norm(np.gradient(p_k, t_k, axis=0), axis=1)
    lags = []
    for i in corner_indices(p_c):  # bounded: one per corner
        t0 = t_c[i]
        win_c = np.flatnonzero(np.abs(t_c - t0) <= STOP_WINDOW_S)
        win_k = np.flatnonzero(np.abs(t_k - t0) <= STOP_WINDOW_S)
        if len(win_k) > 2:
            lags.append(t_k[win_k[np.argmin(v_k[win_k])]] - t_c[win_c[np.argmin(v_c[win_c])]])
    return float(np.median(lags)) if lags else math.nan


def _twin_for(run: Run, twin: Twin | TwinSpec | None) -> Twin:
    """The quasi-static twin of the run, without a servo transient (the dynamic servo replaces it)."""
    return without_servo(twin) if isinstance(twin, Twin) else spec_for_run(run, twin).replace(servo=None).build()


def force_rate_hz(run: Run) -> float:
    """The run's F/T stream's rate [Hz] (its median sample interval's inverse); 0 without one."""
    if run.forces is None or len(run.forces.t_s) < 2:
        return 0.0
    return 1.0 / float(np.median(np.diff(run.forces.t_s)))


def prepare(run: Run, twin: Twin | TwinSpec | None = None, measured_forces: bool = False) -> DynamicTwin:
    """The dynamic twin of a run's commanded path, its quasi-static replay made once.

    Args:
        run: A measured run (at least 2 commanded samples).
        twin: A spec (placed at the run's placement) or a twin at the run's placement; None: the run's robot.
        measured_forces: Drive the arm by the run's measured forces (module docstring), not the twin's sheet.

    Raises:
        InputError: `measured_forces` on a run without forces.csv.
    """
    if len(run.commanded.t_s) < 2:
        raise RunFormatError("commanded.csv", "needs at least 2 samples to replay")
    if measured_forces and run.forces is None:
        raise InputError(f"run {run.directory}: no forces.csv to drive the dynamic twin's arm by")
    qs = _twin_for(run, twin)
    forces = (run.forces.t_s, run.forces.values) if measured_forces and run.forces is not None else None
    return DynamicTwin(qs, qs.simulate(run.commanded.t_s, run.commanded.values), forces=forces)


def tracker_residual(run: Run, dynamic: DynamicTwin, servo: ServoModel) -> np.ndarray:
    """Tracker minus the dynamic replay's predicted tracker [m], shape (m, 3)."""
    sim = dynamic.simulate(servo)
    return run.tracker.values - predict_tracker(sim, run.tracker.t_s, dynamic.twin.effects)


def _rms_mm(residual: np.ndarray) -> float:
    return 1e3 * float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))


def fit_servo(run: Run, twin: Twin | TwinSpec | DynamicTwin | None = None, *, max_evaluations: int = 40,
              measured_forces: bool | None = None) -> ServoFit:
    """Learn the dynamic twin's servo from a run's tracker (module docstring).

    Args:
        run: A measured run with corners or reversals (their transients carry the servo).
        twin: The cell's twin (a learned spec, say), a `DynamicTwin` of this run (which says what drives it), or
            None (the run's robot).
        max_evaluations: Dynamic replays the least-squares stage may run after the grid.
        measured_forces: Drive the arm by the run's measured forces (b held at 0); None: where its F/T stream runs
            at `MEASURED_FORCES_MIN_HZ` or faster.

    Returns:
        The fitted servo and the residual before and after.

    Raises:
        InputError: `max_evaluations` below 1.
        IdentificationError: The run's tracker does not overlap its command.
    """
    if max_evaluations < 1:
        raise InputError(f"max_evaluations = {max_evaluations!r}: expected >= 1")
    start = time.perf_counter()
    if isinstance(twin, DynamicTwin):
        dynamic, measured = twin, twin.forces is not None
    else:
        measured = force_rate_hz(run) >= MEASURED_FORCES_MIN_HZ if measured_forces is None else measured_forces
        dynamic = prepare(run, twin, measured)
    width = 4 if measured else 5  # measured forces: none of the twin's load is fed forward (b = 0)
    low, high, scale = BOUNDS[0][:width], BOUNDS[1][:width], SCALE[:width]
    inside = (run.tracker.t_s >= run.commanded.t_s[0]) & (run.tracker.t_s <= run.commanded.t_s[-1])
    if inside.sum() < 8:
        raise IdentificationError(f"the run's tracker has {int(inside.sum())} samples within its command; "
                                  "the servo fit needs 8 or more")
    lag = stop_lag(run)
    d0 = float(np.clip(0.0 if math.isnan(lag) else lag, BOUNDS[0][2], BOUNDS[1][2]))
    count = [0]

    def residual(scaled: np.ndarray) -> np.ndarray:
        count[0] += 1
        x = np.clip(scaled * scale, low, high)
        servo = ServoModel(*(float(v) for v in x))
        try:
            return 1e3 * tracker_residual(run, dynamic, servo)[inside].ravel()
        except InputError:  # a diverged replay: the worst the fit can see
            return np.full(3 * int(inside.sum()), 1e3)

    rigid = _rms_mm(tracker_residual(run, dynamic, ServoModel(math.inf, 1.0, 0.0))[inside])
    axes = [GRID["bandwidth_over_mode"], GRID["damping_ratio"], GRID["feedforward"]]
    axes += [] if measured else [GRID["load_feedforward"]]
    grid = [np.array([beta, z, d0, *shares]) for beta, z, *shares in product(*axes)]
    costs = [float(np.sum(residual(x / scale) ** 2)) for x in grid]  # bounded: the grid's 16 or 32 points
    x0 = grid[int(np.argmin(costs))]
    fit = least_squares(residual, x0 / scale, bounds=(low / scale, high / scale), diff_step=0.02,
                        max_nfev=max_evaluations)
    best = np.clip(fit.x * scale, low, high) if 2 * fit.cost <= min(costs) else x0
    servo = ServoModel(*(float(v) for v in best))
    return ServoFit(servo, tuple(float(w) for w in servo.bandwidth_over_mode * dynamic.mode_rad_s), lag, rigid,
                    _rms_mm(tracker_residual(run, dynamic, servo)[inside]), count[0] + 2,
                    time.perf_counter() - start, measured)


def dynamic_replay(
    run: Run, twin: Twin | TwinSpec | DynamicTwin | None = None, servo: ServoModel | None = None
) -> ReplayResult:
    """`twin.analysis.replay.replay` on the dynamic twin: the run's command replayed with the arm stepped in time
    under `servo`, compared with the run's measurements (the same metrics).

    Args:
        run: A measured run (its measurements only).
        twin: A spec (placed at the run's placement), a twin at the run's placement, a `DynamicTwin` of this run
            (`prepare`), or None (the run's robot in its cell). A spec's servo transient is left out.
        servo: The servo (`fit_servo(...).servo`); None: `ServoModel()`.

    Returns:
        The dynamic replay (`sim.p_sheet_m`: the moving arm's tip) and its gap to the run.
    """
    dynamic = twin if isinstance(twin, DynamicTwin) else prepare(run, twin)
    sim = dynamic.simulate(servo or ServoModel())
    effects = dynamic.twin.effects
    tracker = predict_tracker(sim, run.tracker.t_s, effects)
    forces = predict_forces(dynamic.twin, sim, run.forces.t_s, effects) if run.forces is not None else None
    return ReplayResult(sim, tracker, forces, replay_metrics(run, tracker, forces))


__all__ = ["MEASURED_FORCES_MIN_HZ", "ServoFit", "corner_indices", "dynamic_replay", "fit_servo", "force_rate_hz",
           "near_corners", "prepare", "stop_lag", "tracker_residual"]
