"""Replay a measured run on the twin and compare prediction with measurement."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.analysis.resolve import resolve_robot, spec_for_run
from twin.base.signals import interp_rows
from twin.errors import InputError, RunFormatError
from twin.runs.format import Run, run_placement
from twin.sim.measure import predict_forces, predict_tracker
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec


@dataclass(frozen=True)
class ReplayResult:
    """A run replayed on the twin.

    Attributes:
        sim: The twin's simulation at the commanded samples.
        tracker_pred_m: Predicted tracker reading at the run's tracker times, sheet frame [m].
        forces_pred_n: Predicted sensor force at the run's sensor times [N] (None when the run has none).
        metrics: Summary numbers (see `replay_metrics`).
    """

    sim: SimResult
    tracker_pred_m: np.ndarray
    forces_pred_n: np.ndarray | None
    metrics: dict[str, float]


def replay_metrics(
    run: Run, tracker_pred_m: np.ndarray, forces_pred_n: np.ndarray | None
) -> dict[str, float]:
    """Gap between measurement and prediction.

    Keys: `position_rms_mm` and `position_max_mm` (norm of measured minus predicted tool tip),
    `force_rms_n` and `force_max_n` (norm of measured minus predicted force), `deflection_max_mm` (max norm
    of the measured tool tip minus the commanded one), `samples` (tracker samples), `force_samples`.
    """
    err = np.linalg.norm(run.tracker.values - tracker_pred_m, axis=1)
    cmd = interp_rows(run.tracker.t_s, run.commanded.t_s, run.commanded.values)
    deflection = np.linalg.norm(run.tracker.values - cmd, axis=1)
    metrics = {
        "position_rms_mm": 1e3 * float(np.sqrt(np.mean(err**2))),
        "position_max_mm": 1e3 * float(np.max(err)),
        "deflection_max_mm": 1e3 * float(np.max(deflection)),
        "samples": len(err),
    }
    if run.forces is not None and forces_pred_n is not None:
        ferr = np.linalg.norm(run.forces.values - forces_pred_n, axis=1)
        metrics |= {
            "force_rms_n": float(np.sqrt(np.mean(ferr**2))),
            "force_max_n": float(np.max(ferr)),
            "force_peak_measured_n": float(np.max(np.linalg.norm(run.forces.values, axis=1))),
            "force_samples": len(ferr),
        }
    return metrics


def replay(run: Run, twin: Twin | TwinSpec | None = None) -> ReplayResult:
    """Simulate the run's commanded path on the twin and compare with its measurements.

    Args:
        run: A measured run (never its truth).
        twin: The twin: a spec (built at the run's placement, `meta.json`'s `placement`, which replaces the
            spec's), a ready twin to reuse (it must be at the run's placement), or None (the run's robot in its
            cell at the run's placement). Its robot must be the run's (`meta.json`'s `robot`).

    Returns:
        Prediction at the run's stream times and the gap metrics.

    Raises:
        InputError: A twin at another placement than the run's, or of another robot.
    """
    if len(run.commanded.t_s) < 2:
        raise RunFormatError("commanded.csv", "needs at least 2 samples to replay")
    if isinstance(twin, Twin):
        resolve_robot(twin.robot, None, run, label="the twin")
        if twin.placement != run_placement(run.meta):
            raise InputError(f"the twin passed has the sheet placement {twin.placement}, but the run was made at "
                             f"{run_placement(run.meta)}")
    else:
        twin = spec_for_run(run, twin).build()
    effects = twin.effects
    sim = twin.simulate(run.commanded.t_s, run.commanded.values)
    tracker = predict_tracker(sim, run.tracker.t_s, effects)
    forces = predict_forces(twin, sim, run.forces.t_s, effects) if run.forces is not None else None
    return ReplayResult(sim, tracker, forces, replay_metrics(run, tracker, forces))
