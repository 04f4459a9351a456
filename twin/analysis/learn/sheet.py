"""The sheet learned from a cell's runs: the `learned` force model's weights fitted to the measured F/T stream.

Each run's measured tool tip (its commanded path moved by the tracker's deflection,
`twin.analysis.identify.forces.measured_tip_path`) drives a `LearnedForceField` from a flat sheet; at every
sample it gives the terms its axial force is a weighted sum of (the ISF model's own force and the membrane terms
of the formed surface around the tool, `twin.process.force.learned`). The model is linear in its weights, so
they come from one least-squares solve against the measured Fz (the terms interpolated to the sensor's times),
and the in-plane ratios μ_t, μ_r from a second one against the measured Fx, Fy with the fitted Fz. Their
standard errors are the least-squares ones (white residuals assumed: the residuals of a real run are
correlated in time, so they are a lower bound). The runs' commanded paths, trackers and forces are all it
reads; `truth.json` never.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from twin.analysis.identify.forces import measured_tip_path
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.learned import WEIGHT_KEYS, LearnedForceField
from twin.process.force.registry import build_force_field
from twin.runs.format import Run

#: Fewest force samples a run must give.
MIN_SAMPLES = 50
#: A run's measured force peaking below this fraction of what the declared sheet predicts is a silent sensor.
SILENT_SENSOR = 0.05


class SheetRows(NamedTuple):
    """One run's regression rows at its force samples."""

    terms: np.ndarray  # (m, 4) the axial-force terms (`LearnedForceField.features`)
    travel: np.ndarray  # (m, 2) the sliding direction at the tip [-]
    side: np.ndarray  # (m,) the held wall side [-]
    measured_n: np.ndarray  # (m, 3) the measured force [N]


class SheetFit(NamedTuple):
    """`fit_sheet`'s result.

    Attributes:
        force_fit: The fitted constants, as `Process.force_fit` (weights, `mu_eff`, `mu_radial`): fitted.
        std: Their standard errors, same keys [same units].
        rms_before_n: Per run, RMS of the measured minus the declared model's force along the measured tip [N].
        rms_after_n: Per run, the same with the learned model [N].
        samples: Force samples used, all runs.
    """

    force_fit: tuple[tuple[str, float], ...]
    std: tuple[tuple[str, float], ...]
    rms_before_n: tuple[float, ...]
    rms_after_n: tuple[float, ...]
    samples: int


def sheet_rows(run: Run, process: Process) -> SheetRows:
    """Drive the prior `learned` model along the run's measured tip and take its terms at the sensor's times."""
    if run.forces is None or len(run.forces.t_s) < MIN_SAMPLES:
        raise InputError(f"run {run.directory}: learning the sheet needs forces.csv with at least {MIN_SAMPLES} "
                         "samples (a run formed with the F/T sensor on)")
    path = measured_tip_path(run, 0.0)
    field = build_force_field(replace(process, force_model="learned", force_fit=()))
    assert isinstance(field, LearnedForceField)
    field.reset()
    n = len(path.t_s)
    terms, travel, side = np.empty((n, 4)), np.empty((n, 2)), np.empty(n)
    for i, p in enumerate(path.p_sheet_m):
        terms[i] = field.features(p)[0]
        travel[i] = field.sliding_direction(p)
        side[i] = field.state.wall_side
        field.advance(p)
    t_f = run.forces.t_s
    inside = (t_f >= path.t_s[0]) & (t_f <= path.t_s[-1])
    t_f = t_f[inside]
    return SheetRows(interp_rows(t_f, path.t_s, terms), interp_rows(t_f, path.t_s, travel),
                     interp_rows(t_f, path.t_s, side[:, None])[:, 0], run.forces.values[inside])


def _lstsq(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares and the standard errors of its coefficients."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    dof = max(len(y) - X.shape[1], 1)
    s2 = float(np.sum((y - X @ coef) ** 2)) / dof
    cov = s2 * np.linalg.pinv(X.T @ X)
    return coef, np.sqrt(np.maximum(np.diag(cov), 0.0))


def in_plane_columns(rows: SheetRows, fz_n: np.ndarray) -> np.ndarray:
    """(2m, 2) columns of (μ_t, μ_r) for the stacked (Fx, Fy) (`IsfForceField._in_plane`)."""
    vx, vy, s = rows.travel[:, 0], rows.travel[:, 1], rows.side
    mu_t = np.concatenate([-vx * fz_n, -vy * fz_n])
    mu_r = np.concatenate([s * vy * fz_n, -s * vx * fz_n])
    return np.stack([mu_t, mu_r], axis=1)


def fit_sheet(runs: list[Run], process: Process) -> SheetFit:
    """Learn the `learned` model's weights and in-plane ratios from the runs' F/T streams (module docstring).

    Args:
        runs: Runs with force streams (one part or several).
        process: The declared process (material, sheet, tool: the prior).

    Raises:
        InputError: A run without enough force samples, or the terms leave the weights undetermined.
    """
    rows = [sheet_rows(run, process) for run in runs]
    for run, r in zip(runs, rows, strict=True):
        measured_peak = float(np.max(np.linalg.norm(r.measured_n, axis=1)))
        prior_peak = float(np.max(np.abs(r.terms[:, 0])))
        if measured_peak < SILENT_SENSOR * prior_peak:
            raise InputError(f"run {run.directory}: its F/T stream peaks at {measured_peak:.1f} N where the declared "
                             f"sheet would push {prior_peak:.0f} N along its path: no forming contact in the "
                             "sensor's data (a sensor not connected, or not tared on?)")
    terms = np.vstack([r.terms for r in rows])
    measured = np.vstack([r.measured_n for r in rows])
    if np.linalg.matrix_rank(terms) < terms.shape[1]:
        raise InputError("the runs do not determine the sheet's terms (no forming contact in the path?): "
                         f"rank {np.linalg.matrix_rank(terms)} of {terms.shape[1]}")
    weights, w_std = _lstsq(terms, measured[:, 2])
    plane = np.vstack([in_plane_columns(r, np.maximum(r.terms @ weights, 0.0)) for r in rows])
    fxy = np.concatenate([np.concatenate([r.measured_n[:, 0], r.measured_n[:, 1]]) for r in rows])
    mu, mu_std = _lstsq(plane, fxy)
    mu = np.clip(mu, 1e-6, None)  # the ISF constants are positive; a ratio at its floor is reported so
    keys = (*WEIGHT_KEYS, "mu_eff", "mu_radial")
    values = (*weights, *mu)
    fit = tuple((k, float(v)) for k, v in zip(keys, values, strict=True))
    learned = replace(process, force_model="learned", force_fit=fit)
    before = [_rms_along(run, process) for run in runs]
    after = [_rms_along(run, learned) for run in runs]
    return SheetFit(fit, tuple((k, float(v)) for k, v in zip(keys, (*w_std, *mu_std), strict=True)),
                    tuple(before), tuple(after), len(measured))


def _rms_along(run: Run, process: Process) -> float:
    """RMS of the measured minus the model's force along the run's measured tip, at the sensor's times [N]."""
    assert run.forces is not None
    path = measured_tip_path(run, 0.0)
    model = build_force_field(process).rigid_forces(path)
    t_f = run.forces.t_s
    inside = (t_f >= path.t_s[0]) & (t_f <= path.t_s[-1])
    error = run.forces.values[inside] - interp_rows(t_f[inside], path.t_s, model)
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))
