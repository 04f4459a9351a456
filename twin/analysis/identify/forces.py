"""The sheet's forces learned from the cell: the force model's level and shape fitted to a measured F/T stream.

A first part formed by the cell tells how hard its sheet really pushes: its tracker says where the tool was and
its sensor what the sheet did. The declared process's force model is driven along the measured tool tip (the
commanded path moved by the tracker's deflection, at the command's sample spacing: the model's height map wants
samples closer than its 0.5 mm grid) and its forces are compared with the measured ones. Least squares then
fits, for the `isf` model, the level (`scale`, a factor on the published level of the declared material), the
build-up depth D0 and the in-plane ratios μ_t, μ_r; the `table` model takes the level only. The result goes
into `Process.force_fit`, so the next part is compensated with the cell's forces, not the formula's.

The twin's models are quasi-static; a cell's tool may chatter on the sheet (the contact force jumps by its full
size within a few milliseconds, and the tracker sees the tool bounce by millimetres), and the sensor and tracker
sample that vibration at tens of hertz, aliased. Sample by sample, the model driven along a bouncing tip loses
and regains contact at the wrong times, and least squares drives a constant to its bound. So both sides are
compared as means over windows of `WINDOW_S` (the measured forces over the sensor's samples in a window, the
model's over the command's), and the model is driven along the deflection's mean over the same window: what a
quasi-static twin predicts and compensates. A constant that ends on its bound is reported (`ForceFit.at_bound`):
the model could not take the run's force history there.

The fit uses the run's commanded path, tracker and forces only; `truth.json` is never read.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.registry import build_force_field
from twin.process.toolpath.groove import ToolPath, label_passes
from twin.runs.format import Run
from twin.sim.compiled.rigid import rigid_forces

#: Window over which measured and model forces are averaged, and the tracker's deflection too [s] (0: compare
#: sample by sample, at the sensor's times, along the raw deflection).
WINDOW_S = 0.5
#: Fitted constants of each model: (name, lower bound, upper bound), in the model's units.
FITTED = {
    "isf": (("scale", 0.05, 20.0), ("build_up_m", 0.2e-3, 20e-3), ("mu_eff", 0.0, 1.0), ("mu_radial", 0.0, 1.0)),
    "table": (("scale", 0.05, 20.0),),
}


class ForceFit(NamedTuple):
    """`fit_forces`'s result.

    Attributes:
        force_fit: The fitted constants, as `Process.force_fit`.
        rms_before_n: RMS of measured - model force over the samples (all three axes), declared process [N].
        rms_after_n: The same with the fitted constants [N].
        samples: Force samples used.
        evaluations: Model drives the fit took.
        at_bound: The fitted constants that ended on a bound of `FITTED` (the model could not take the run's force
            history there; their values are the bound's, not the cell's).
        windows: Windows compared (`samples` where `window_s` was 0).
    """

    force_fit: tuple[tuple[str, float], ...]
    rms_before_n: float
    rms_after_n: float
    samples: int
    evaluations: int
    at_bound: tuple[str, ...] = ()
    windows: int = 0


def measured_tip_path(run: Run, window_s: float = 0.0) -> ToolPath:
    """The tool tip as the tracker saw it, at the command's samples: the commanded path plus the tracker's
    deflection (its mean over `window_s` around each sample [s], 0: as read) interpolated to the command's
    times [m]."""
    cmd, tracker = run.commanded, run.tracker
    deflection = tracker.values - interp_rows(tracker.t_s, cmd.t_s, cmd.values)
    p = cmd.values + interp_rows(cmd.t_s, tracker.t_s, moving_mean(tracker.t_s, deflection, window_s))
    # the passes are the command's: a tip that jitters at a reversal would otherwise start a pass of its own
    passes, direction = label_passes(cmd.values[:, 0])
    return ToolPath(t_s=cmd.t_s, p_sheet_m=p, pass_index=passes, direction=direction)


def moving_mean(t_s: np.ndarray, values: np.ndarray, window_s: float) -> np.ndarray:
    """Each row's mean over the rows within ±window_s / 2 of its time (sorted times, any spacing) [units of
    `values`]; `values` itself where `window_s` is 0."""
    if window_s <= 0.0:
        return values
    total = np.vstack([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
    lo = np.searchsorted(t_s, t_s - 0.5 * window_s, side="left")
    hi = np.searchsorted(t_s, t_s + 0.5 * window_s, side="right")
    return (total[hi] - total[lo]) / (hi - lo)[:, None]


def window_means(t_s: np.ndarray, values: np.ndarray, edges_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Means of `values` over the windows between consecutive `edges_s` [s], and how many rows each holds."""
    index = np.clip(np.searchsorted(edges_s, t_s, side="right") - 1, 0, len(edges_s) - 2)
    count = np.bincount(index, minlength=len(edges_s) - 1)
    sums = np.stack([np.bincount(index, values[:, j], minlength=len(edges_s) - 1) for j in range(values.shape[1])], 1)
    return sums / np.maximum(count, 1)[:, None], count


def fit_forces(run: Run, process: Process, window_s: float = WINDOW_S) -> ForceFit:
    """Fit the declared process's force model to the run's measured forces (module docstring).

    Args:
        run: A run with a force stream.
        process: The declared process (its force model names what is fitted).
        window_s: Window of the means compared [s] (`WINDOW_S`; 0: sample by sample).

    Raises:
        InputError: The run has no forces, the model has no fitted constants here, or the window is negative or
            leaves fewer than 10 windows.
    """
    if run.forces is None or len(run.forces.t_s) < 10:
        raise InputError(f"run {run.directory}: identify --forces needs forces.csv with at least 10 samples")
    if process.force_model not in FITTED:
        raise InputError(f"force model {process.force_model!r}: identify --forces fits {sorted(FITTED)}")
    if not (math.isfinite(window_s) and window_s >= 0.0):
        raise InputError(f"force-fit window {window_s!r} s: expected a finite number >= 0")
    fitted = FITTED[process.force_model]
    path = measured_tip_path(run, window_s)
    t_f = np.clip(run.forces.t_s, path.t_s[0], path.t_s[-1])
    if window_s > 0.0:
        edges = np.arange(path.t_s[0], path.t_s[-1] + window_s, window_s)
        measured, counts = window_means(t_f, run.forces.values, edges)
        keep = (counts > 0) & (window_means(path.t_s, path.p_sheet_m, edges)[1] > 0)
        measured = measured[keep]
        if len(measured) < 10:
            raise InputError(f"force-fit window {window_s:g} s leaves {len(measured)} windows of run "
                             f"{run.directory}; expected at least 10 (a shorter window)")
    else:
        measured = run.forces.values
    norm = 1.0 / np.sqrt(measured.size)
    start = dict(process.force_fit)

    def forces(values: dict[str, float]) -> np.ndarray:
        model = rigid_forces(build_force_field(replace(process, force_fit=tuple(values.items()))), path)
        if window_s > 0.0:
            return window_means(path.t_s, model, edges)[0][keep]
        return interp_rows(t_f, path.t_s, model)

    def residual(v: np.ndarray) -> np.ndarray:
        return norm * (forces(dict(zip([f[0] for f in fitted], v, strict=True))) - measured).ravel()

    base = forces(start)
    defaults = build_force_field(process)
    params = getattr(defaults, "params", None)
    v0 = [start.get(name, getattr(params, name, 1.0) if params is not None else 1.0) for name, _, _ in fitted]
    lo, hi = np.array([f[1] for f in fitted]), np.array([f[2] for f in fitted])
    result = least_squares(residual, np.clip(v0, lo + 1e-12, hi - 1e-12), bounds=(lo, hi), x_scale=np.maximum(v0, 1e-3),
                           diff_step=1e-3)
    fit = tuple((name, float(x)) for (name, _, _), x in zip(fitted, result.x, strict=True))
    after = forces(dict(fit))
    at_bound = tuple(name for (name, low, high), x in zip(fitted, result.x, strict=True)
                     if min(x - low, high - x) <= 1e-6 * (high - low))
    return ForceFit(fit, _rms(base - measured), _rms(after - measured), len(t_f), int(result.nfev), at_bound,
                    len(measured))


def _rms(error_n: np.ndarray) -> float:
    """RMS of the error's norm over the samples [N]."""
    return float(np.sqrt(np.mean(np.sum(error_n**2, axis=1))))
