"""The sheet learned from a cell's runs: which terms of the `learned` force model its F/T stream supports, and
their weights, chosen from the data under regularisation, with their uncertainty.

Each run's measured tool tip (its commanded path moved by the tracker's deflection,
`twin.analysis.identify.forces.measured_tip_path`) drives a `LearnedForceField` from a flat sheet; at every
sample it gives the library of terms its axial force is a weighted sum of (`twin.process.force.learned`). The
model is linear in its weights; the fit is a ridge regression towards the prior mean (the published formula: its
weight 1, every other 0; `RIDGE` of the samples' weight, on terms scaled to unit rms), and which terms enter is
chosen by best-subset selection on validation that looks ahead: each run's samples in `BLOCKS` blocks of time,
the blocks before b fitted, block b predicted, for b = 2 .. BLOCKS-1 (a part is formed deeper as it goes, so this
scores what a term predicts for the material the fit has not seen, as the next part asks); of 1, 2, ..
`MAX_TERMS` terms, the subset that predicts best is taken while it lowers that error by more than `ENTRY_GAIN`
below the last taken (not forward selection: the term best alone can be the wrong one beside others).

The candidates are the formed state at the tip (`STATE_KEYS`: engagement, contact, wall angle, depth and the
depth's saturating rise). The walls' rise around the tool (`RISE_KEYS`) enters beside them only where it takes off
more than 40 % (`SHAPE_GAIN`) of the look-ahead error the tip's terms leave: it reads the part's shape, and on one
cone the rise grows with the depth and stands in for it, which a look-ahead on that cone cannot tell apart, while
on a part of another shape it reads otherwise (at a pyramid's corner the rise to the side is the next side's
wall). On nominal cones it took off under a third and predicted a pyramid's force worse than the depth alone; on
grooves, whose force is their walls', over half. Never the membrane terms of Silva et al. (the form the plant's
sheet law 1 is written in). A model file's rise and membrane weights are still read and replayed. The radial
in-plane ratio μ_r and its part that follows the side walls' rise μ_ρ are chosen the same way on the look-ahead of
the measured Fx, Fy (each held at 0 where it does not show), μ_t always fitted; the ratios are non-negative.

The uncertainty is a moving-block bootstrap (`BOOT` resamples of blocks of `BOOT_BLOCK_S`, seeded): the spread of
each selected weight over resamples (a run's residuals are correlated in time; the least-squares standard error
would understate it); the validation error is what the next part's force should be expected to miss by. The
in-plane ratios come from a second least squares against the measured Fx, Fy with the fitted Fz. The runs'
commanded paths, trackers and forces are all it reads; `truth.json` never.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from scipy.optimize import lsq_linear

from twin.analysis.identify.forces import measured_tip_path
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force import learned as learned_force
from twin.process.force.learned import RADIAL_RISE_KEY, SIDE_RISE_INDEX, STATE_KEYS, WEIGHT_KEYS
from twin.process.force.registry import build_force_field
from twin.process.force.span import SPAN_KEYS, learned_span
from twin.runs.format import Run
from twin.sim.compiled.rigid import rigid_forces

#: Fewest force samples a run must give.
MIN_SAMPLES = 50
#: A run's measured force peaking below this fraction of what the declared sheet predicts is a silent sensor.
SILENT_SENSOR = 0.05
#: Ridge weight towards the prior mean, per sample, on terms scaled to unit rms [-].
RIDGE = 1e-3
#: Blocks of time per run for the look-ahead validation, and the least relative drop of its error to take a term.
BLOCKS = 6
ENTRY_GAIN = 0.03
#: The terms selection may add to the published formula's (module docstring), and the most it adds.
CANDIDATES: tuple[str, ...] = STATE_KEYS
MAX_TERMS = 5
#: The share of the tip terms' look-ahead error the walls' rise around the tool must take off to enter.
SHAPE_GAIN = 0.4
#: Every term selection may take: the tip's and, past `SHAPE_GAIN`, the walls' rise around the tool.
LIBRARY: tuple[str, ...] = (*CANDIDATES, *learned_force.RISE_KEYS)
#: The prior mean of the weights: the published formula (`prior_weight` 1), every other term 0.
PRIOR_MEAN = np.array([1.0 if key == "prior_weight" else 0.0 for key in WEIGHT_KEYS])
#: Weights that cannot be negative: the published formula's, and those on the engagement (the force does not fall as
#: the tool goes deeper into the same surface; a negative slope is the robot's give read as the sheet's).
NON_NEGATIVE = ("prior_weight", "engagement_n_per_mm", "engagement_sq_n_per_mm2", "depth_engagement_n_per_mm2")
#: Moving-block bootstrap: resamples, block length [s], seed.
BOOT, BOOT_BLOCK_S, BOOT_SEED = 64, 2.0, 0


class SheetRows(NamedTuple):
    """One run's regression rows at its force samples."""

    terms: np.ndarray  # (m, k) the axial-force terms (`LearnedForceField.features`)
    t_s: np.ndarray  # (m,) the sensor's times [s]
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
        terms: The terms selected (`WEIGHT_KEYS` names; the prior's always, first).
        validation_rms_n: The look-ahead validation's RMS axial-force error with those terms [N] (predicted).
        prior_validation_rms_n: The same with the published formula alone [N].
        shape_share: The share of the tip terms' look-ahead error the walls' rise takes off (`SHAPE_GAIN`) [-].
    """

    force_fit: tuple[tuple[str, float], ...]
    std: tuple[tuple[str, float], ...]
    rms_before_n: tuple[float, ...]
    rms_after_n: tuple[float, ...]
    samples: int
    terms: tuple[str, ...] = ("prior_weight",)
    validation_rms_n: float = float("nan")
    prior_validation_rms_n: float = float("nan")
    shape_share: float = float("nan")


def sheet_rows(run: Run, process: Process) -> SheetRows:
    """Drive the prior `learned` model along the run's measured tip and take its terms at the sensor's times."""
    if run.forces is None or len(run.forces.t_s) < MIN_SAMPLES:
        raise InputError(f"run {run.directory}: learning the sheet needs forces.csv with at least {MIN_SAMPLES} "
                         "samples (a run formed with the F/T sensor on)")
    path = measured_tip_path(run, 0.0)
    field = build_force_field(replace(process, force_model="learned", force_fit=()))
    assert isinstance(field, learned_force.LearnedForceField)
    field.reset()
    n = len(path.t_s)
    terms, travel, side = np.empty((n, len(WEIGHT_KEYS))), np.empty((n, 2)), np.empty(n)
    for i, p in enumerate(path.p_sheet_m):
        terms[i] = field.features(p)[0]
        travel[i] = field.sliding_direction(p)
        side[i] = field.state.wall_side
        field.advance(p)
    inside = (run.forces.t_s >= path.t_s[0]) & (run.forces.t_s <= path.t_s[-1])
    t_f = run.forces.t_s[inside]
    return SheetRows(interp_rows(t_f, path.t_s, terms), t_f, interp_rows(t_f, path.t_s, travel),
                     interp_rows(t_f, path.t_s, side[:, None])[:, 0], run.forces.values[inside])


def _lstsq(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares and the standard errors of its coefficients."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    dof = max(len(y) - X.shape[1], 1)
    s2 = float(np.sum((y - X @ coef) ** 2)) / dof
    cov = s2 * np.linalg.pinv(X.T @ X)
    return coef, np.sqrt(np.maximum(np.diag(cov), 0.0))


def _ridge(X: np.ndarray, y: np.ndarray, cols: list[int]) -> np.ndarray:
    """Ridge regression of `cols` towards the prior mean, `RIDGE` on unit-rms columns, `NON_NEGATIVE` held."""
    return _ridge_scaled(*_unit_rms(X.T @ X, X.T @ y, len(y), PRIOR_MEAN[cols]), cols)


def _unit_rms(G: np.ndarray, g: np.ndarray, n: int, prior: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ridge's system on unit-rms columns from the normal equations G = XᵀX, g = Xᵀy of n samples: (A, b, the
    columns' rms); a subset's is, element by element, the whole one's rows and columns (the look-ahead's spans)."""
    scale = np.where((rms := np.sqrt(np.diag(G) / max(n, 1))) > 0.0, rms, 1.0)
    return G / np.outer(scale, scale) + RIDGE * n * np.eye(len(g)), g / scale + RIDGE * n * prior * scale, scale


def _ridge_scaled(A: np.ndarray, b: np.ndarray, scale: np.ndarray, cols: list[int]) -> np.ndarray:
    """The ridge's weights of the terms `cols` from its unit-rms system (`_unit_rms`), `NON_NEGATIVE` held: exactly,
    as the optimum holds some bounded weights at 0 and the rest free, it is the free solution if that keeps the
    bounds, else the least objective over those choices whose free weights keep them (at most 2^4 small solves)."""
    bounded = [i for i, c in enumerate(cols) if WEIGHT_KEYS[c] in NON_NEGATIVE]
    coef = np.linalg.solve(A, b)
    if np.any(coef[bounded] < 0.0):
        best = math.inf
        for n_held in range(1, len(bounded) + 1):
            for held in itertools.combinations(bounded, n_held):
                free = [i for i in range(len(cols)) if i not in held]
                z = np.zeros(len(cols))
                z[free] = np.linalg.solve(A[free][:, free], b[free])
                value = float(z @ A @ z - 2.0 * b @ z)
                if np.all(z[bounded] >= 0.0) and value < best:
                    best, coef = value, z
    return np.asarray(coef / scale)


def _blocks(rows: list[SheetRows], count: int) -> np.ndarray:
    """Each sample's block of time within its own run, `count` equal blocks per run."""
    return np.concatenate([np.arange(len(r.t_s)) * count // max(len(r.t_s), 1) for r in rows])


class _LookAhead:
    """RMS axial-force error [N] predicting block b from blocks < b, b = 2 .. BLOCKS-1 (module docstring), each
    training span's normal equations formed once, so that a subset of terms is scored in a few small solves."""

    def __init__(self, terms: np.ndarray, fz_n: np.ndarray, block: np.ndarray) -> None:
        self.spans = [(*_unit_rms(terms[block < b].T @ terms[block < b], terms[block < b].T @ fz_n[block < b],
                                  int(np.sum(block < b)), PRIOR_MEAN), terms[block == b], fz_n[block == b])
                      for b in range(2, BLOCKS)]

    def __call__(self, cols: list[int], fitted: bool = True) -> float:
        """The error with the terms `cols` fitted; `fitted` False: the published formula as it is (weight 1)."""
        error, count = 0.0, 0
        for A, b, scale, X_test, y_test in self.spans:
            w = _ridge_scaled(A[cols][:, cols], b[cols], scale[cols], cols) if fitted else PRIOR_MEAN[cols]
            error += float(np.sum((y_test - np.maximum(X_test[:, cols] @ w, 0.0)) ** 2))
            count += len(y_test)
        return math.sqrt(error / max(count, 1))


def _plane_rms(plane: np.ndarray, fxy_n: np.ndarray, block: np.ndarray, cols: list[int]) -> float:
    """The look-ahead RMS [N] of the in-plane force with the ratios `cols` of (μ_t, μ_r, μ_ρ) fitted
    (`_LookAhead`)."""
    error, count = 0.0, 0
    for b in range(2, BLOCKS):
        train, test = block < b, block == b
        mu = np.linalg.lstsq(plane[train][:, cols], fxy_n[train], rcond=None)[0]
        error += float(np.sum((fxy_n[test] - plane[test][:, cols] @ mu) ** 2))
        count += int(np.sum(test))
    return math.sqrt(error / max(count, 1))


def _best_subset(score: Callable[[list[int]], float], candidates: Sequence[int],
                 most: int) -> tuple[list[int], float]:
    """Best-subset selection from column 0 (always in): for 1, 2, .. `most` added columns, the subset of that size
    that scores least, taken while it lowers the score of the last taken by more than `ENTRY_GAIN`; (columns, the
    last score). Not forward selection: a term that is best alone can be the wrong one beside others (on a cone
    the engagement alone follows the force's rise, which two terms of the wall and its depth follow better)."""
    chosen, best = [0], score([0])
    for size in range(1, min(most, len(candidates)) + 1):
        value, subset = min((score([0, *subset]), subset) for subset in itertools.combinations(candidates, size))
        if value > (1.0 - ENTRY_GAIN) * best:
            break
        chosen, best = [0, *subset], value
    return chosen, best


def select_terms(terms: np.ndarray, fz_n: np.ndarray, block: np.ndarray) -> tuple[list[int], float, float]:
    """Best-subset selection on the look-ahead validation, of the formed state at the tip and, where they take off
    more than `SHAPE_GAIN` of its error, of the walls' rise around the tool beside it: (columns, its RMS [N], the
    share of the tip terms' error the rise takes off [-])."""
    look, seen = _LookAhead(terms, fz_n, block), dict[tuple[int, ...], float]()
    def score(cols: list[int]) -> float:  # the tip terms' subsets, in both searches, are scored once
        return seen[key] if (key := tuple(cols)) in seen else seen.setdefault(key, look(cols))
    tip = _best_subset(score, [WEIGHT_KEYS.index(k) for k in CANDIDATES], MAX_TERMS)
    shape = _best_subset(score, [WEIGHT_KEYS.index(k) for k in LIBRARY], MAX_TERMS)
    share = 1.0 - shape[1] / tip[1] if tip[1] > 0.0 else 0.0
    return (*shape, share) if share > SHAPE_GAIN else (*tip, share)


def _bootstrap_std(rows: list[SheetRows], terms: np.ndarray, fz_n: np.ndarray, cols: list[int]) -> np.ndarray:
    """The spread of the selected weights over a seeded moving-block bootstrap (module docstring)."""
    ids = np.concatenate([np.floor((r.t_s - r.t_s[0]) / BOOT_BLOCK_S) + 1e6 * i for i, r in enumerate(rows)])
    groups = [np.flatnonzero(ids == u) for u in np.unique(ids)]
    rng = np.random.default_rng(BOOT_SEED)
    draws = np.empty((BOOT, len(cols)))
    for b in range(BOOT):
        pick = np.concatenate([groups[i] for i in rng.integers(0, len(groups), len(groups))])
        draws[b] = _ridge(terms[pick][:, cols], fz_n[pick], cols)
    return np.asarray(np.std(draws, axis=0, ddof=1))


def in_plane_columns(rows: SheetRows, fz_n: np.ndarray) -> np.ndarray:
    """(2m, 3) columns of (μ_t, μ_r, μ_ρ) for the stacked (Fx, Fy) (`LearnedForceField._in_plane`)."""
    vx, vy, s = rows.travel[:, 0], rows.travel[:, 1], rows.side
    mu_t = np.concatenate([-vx * fz_n, -vy * fz_n])
    mu_r = np.concatenate([s * vy * fz_n, -s * vx * fz_n])
    return np.stack([mu_t, mu_r, mu_r * np.tile(rows.terms[:, SIDE_RISE_INDEX], 2)], axis=1)


def select_ratios(plane: np.ndarray, fxy_n: np.ndarray, block: np.ndarray) -> list[int]:
    """Best-subset selection of μ_r and μ_ρ beside μ_t (always) on the look-ahead of the in-plane force: the columns
    of `in_plane_columns` taken."""
    return _best_subset(lambda cols: _plane_rms(plane, fxy_n, block, cols), range(1, plane.shape[1]), 2)[0]


def fit_sheet(runs: list[Run], process: Process, declared: Sequence[Process] | None = None) -> SheetFit:
    """Learn the `learned` model's weights and in-plane ratios from the runs' F/T streams (module docstring).

    Args:
        runs: Runs with force streams (one part or several).
        process: The declared process (material, sheet, tool: the prior).
        declared: Per run, the sheet its `rms_before_n` is of (default `process` for every run).

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
    if not np.any(terms[:, 0] > 0.0):
        raise InputError("the runs do not determine the sheet's terms: the published formula pushes nowhere along "
                         "their tips (no forming contact in the path?)")
    block = _blocks(rows, BLOCKS)
    cols, validation, shape_share = select_terms(terms, measured[:, 2], block)
    prior_validation = _LookAhead(terms, measured[:, 2], block)([0], fitted=False)
    weights, w_std = PRIOR_MEAN.copy(), np.zeros(len(WEIGHT_KEYS))
    weights[cols] = _ridge(terms[:, cols], measured[:, 2], cols)
    w_std[cols] = _bootstrap_std(rows, terms, measured[:, 2], cols)
    plane = np.vstack([in_plane_columns(r, np.maximum(r.terms @ weights, 0.0)) for r in rows])
    fxy = np.concatenate([np.concatenate([r.measured_n[:, 0], r.measured_n[:, 1]]) for r in rows])
    plane_block = np.concatenate([np.tile(b, 2) for b in np.split(block, np.cumsum([len(r.t_s) for r in rows])[:-1])])
    mu_cols = select_ratios(plane, fxy, plane_block)
    mu, mu_std = np.zeros(3), np.zeros(3)
    mu_std[mu_cols] = _lstsq(plane[:, mu_cols], fxy)[1]
    lower = np.array([1e-6, 1e-6, 0.0])[mu_cols]  # the ISF constants are positive; a ratio at its floor is so
    mu[mu_cols] = lsq_linear(plane[:, mu_cols], fxy, bounds=(lower, np.inf)).x
    keys = (*WEIGHT_KEYS, "mu_eff", "mu_radial", RADIAL_RISE_KEY)
    span = learned_span([measured_tip_path(r).p_sheet_m for r in runs], [r.commanded.values for r in runs],
                        process.tool_radius_m)
    fit = tuple((k, float(v)) for k, v in zip((*keys, *SPAN_KEYS), (*weights, *mu, *span), strict=True))
    learned = replace(process, force_model="learned", force_fit=fit)
    before = [_rms_along(run, own) for run, own in zip(runs, declared or [process] * len(runs), strict=True)]
    after = [_rms_along(run, learned) for run in runs]
    return SheetFit(fit, tuple((k, float(v)) for k, v in zip(keys, (*w_std, *mu_std), strict=True)),
                    tuple(before), tuple(after), len(measured), tuple(WEIGHT_KEYS[c] for c in cols), validation,
                    prior_validation, shape_share)


def _rms_along(run: Run, process: Process) -> float:
    """RMS of the measured minus the model's force along the run's measured tip, at the sensor's times [N]."""
    assert run.forces is not None
    path = measured_tip_path(run, 0.0)
    try:
        model = rigid_forces(build_force_field(process), path)
    except InputError as exc:  # a declared FE history shorter than the run's passes, say
        raise InputError(f"run {run.directory}: the declared sheet ({process.force_model}) cannot be driven along "
                         f"it: {exc}") from exc
    t_f = run.forces.t_s
    inside = (t_f >= path.t_s[0]) & (t_f <= path.t_s[-1])
    error = run.forces.values[inside] - interp_rows(t_f[inside], path.t_s, model)
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))
