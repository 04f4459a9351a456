"""The sheet's forces learned from the cell: the force model's level and shape fitted to a measured F/T stream.

A first part formed by the cell tells how hard its sheet really pushes: its tracker says where the tool was and
its sensor what the sheet did. The declared process's force model is driven along the measured tool tip (the
commanded path moved by the tracker's deflection, at the command's sample spacing: the model's height map wants
samples closer than its 0.5 mm grid) and its forces are compared at the sensor's times. Least squares then
fits, for the `isf` model, the level (`scale`, a factor on the published level of the declared material), the
build-up depth D0 and the in-plane ratios μ_t, μ_r; the `table` model takes the level only. The result goes
into `Process.force_fit`, so the next part is compensated with the cell's forces, not the formula's.

The fit uses the run's commanded path, tracker and forces only; `truth.json` is never read.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force_models import build_force_field
from twin.process.path import ToolPath, label_passes
from twin.runs.format import Run

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
    """

    force_fit: tuple[tuple[str, float], ...]
    rms_before_n: float
    rms_after_n: float
    samples: int
    evaluations: int


def measured_tip_path(run: Run) -> ToolPath:
    """The tool tip as the tracker saw it, at the command's samples: the commanded path plus the tracker's
    deflection interpolated to the command's times [m]."""
    cmd, tracker = run.commanded, run.tracker
    deflection = interp_rows(cmd.t_s, tracker.t_s, tracker.values - interp_rows(tracker.t_s, cmd.t_s, cmd.values))
    p = cmd.values + deflection
    passes, direction = label_passes(p[:, 0])
    return ToolPath(t_s=cmd.t_s, p_sheet_m=p, pass_index=passes, direction=direction)


def fit_forces(run: Run, process: Process) -> ForceFit:
    """Fit the declared process's force model to the run's measured forces (module docstring).

    Args:
        run: A run with a force stream.
        process: The declared process (its force model names what is fitted).

    Raises:
        InputError: The run has no forces, or the model has no fitted constants here.
    """
    if run.forces is None or len(run.forces.t_s) < 10:
        raise InputError(f"run {run.directory}: identify --forces needs forces.csv with at least 10 samples")
    if process.force_model not in FITTED:
        raise InputError(f"force model {process.force_model!r}: identify --forces fits {sorted(FITTED)}")
    fitted = FITTED[process.force_model]
    path = measured_tip_path(run)
    t_f = np.clip(run.forces.t_s, path.t_s[0], path.t_s[-1])
    measured = run.forces.values
    norm = 1.0 / np.sqrt(measured.size)
    start = dict(process.force_fit)

    def forces(values: dict[str, float]) -> np.ndarray:
        field = build_force_field(replace(process, force_fit=tuple(values.items())))
        return interp_rows(t_f, path.t_s, field.rigid_forces(path))

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
    return ForceFit(fit, _rms(base - measured), _rms(after - measured), len(t_f), int(result.nfev))


def _rms(error_n: np.ndarray) -> float:
    """RMS of the error's norm over the samples [N]."""
    return float(np.sqrt(np.mean(np.sum(error_n**2, axis=1))))
