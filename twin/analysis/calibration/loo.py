"""Leave-one-out predictions of the calibration targets: refit without a target, then predict it.

A fitted number says how well the model can be made to agree; the leave-one-out prediction says what the
other twelve targets alone predict for it. Each refit starts from the full fit (the shipped model, warm start)
and drops one target's residual.

A parameter that only the left-out target constrains (its Jacobian column outside that row is under
`SOLE_RATIO` of the row's entry; at the shipped fit: k_unload for the CNC depth, K_q,1 for C_yy) has nothing
left to fit it: the refit holds it at its prior (`PRIORS`), so that row's prediction is essentially the prior's,
and both priors are read from the same thesis numbers the targets are. Rows flagged `sole` are not
out-of-sample predictions.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from twin.analysis.calibration.fit import LOWER, PARAMETERS, UPPER, TwinEvaluator, to_values, to_vector
from twin.analysis.calibration.targets import TARGETS
from twin.robot.description import load_robot

#: A parameter is set by one target alone when its sensitivity to every other target, together (2-norm), is
#: under this fraction of its sensitivity to that one (residuals in units of σ).
SOLE_RATIO = 0.1
#: Finite-difference step of the Jacobian and of the refits, in the fitted vector (`twin.analysis.calibration.fit`).
_STEP = 1e-3


def _priors() -> dict[str, tuple[float, str]]:
    robot = load_robot()
    out = {f"k_q{robot.joints.index(p.joint) + 1}_nm_per_rad": (p.k_nm_per_rad, p.source)
           for p in robot.stiffness_priors}
    out["k_unload_n_per_m"] = (1.3e6, "docs/forces.md: 1.3 mm springback under about 1.7 kN, read from the "
                               "thesis's 8.7 mm of 10 mm (§2.3.1)")
    return out


#: Parameter name -> (value before the calibration [SI], where it comes from), for the parameters a single
#: target may set alone.
PRIORS: dict[str, tuple[float, str]] = _priors()


class Prediction(NamedTuple):
    """One target: the thesis, the full fit and the leave-one-out prediction.

    Attributes:
        target: Target name (`twin.analysis.calibration.targets.TARGETS`).
        unit: Unit of the three values.
        thesis: The thesis's value.
        fitted: The twin's value at the full fit (all 13 targets).
        predicted: The twin's value refitted without this target.
        sole: Parameters only this target constrains, held at their prior in the refit (empty: a prediction).
        chi2_reduced: Reduced χ² of the refit (its targets − its free parameters degrees of freedom).
        dof: Degrees of freedom of the refit.
    """

    target: str
    unit: str
    thesis: float
    fitted: float
    predicted: float
    sole: tuple[str, ...]
    chi2_reduced: float
    dof: int


class LeaveOneOut(NamedTuple):
    """The full fit and one prediction per target.

    Attributes:
        predictions: One per target, in the order of `TARGETS`.
        chi2_reduced: Reduced χ² of the full fit.
        dof: Its degrees of freedom (targets − parameters).
        evaluations: Twin evaluations spent.
    """

    predictions: list[Prediction]
    chi2_reduced: float
    dof: int
    evaluations: int


def sole_parameters(jacobian: np.ndarray, ratio: float = SOLE_RATIO) -> dict[int, tuple[int, ...]]:
    """Target row -> the parameter columns that only it constrains.

    Args:
        jacobian: d residual / d parameter, shape (targets, parameters).
        ratio: Threshold: the column's norm over the other rows below `ratio` times the row's entry.
    """
    out: dict[int, tuple[int, ...]] = {}
    for i in range(jacobian.shape[0]):
        others = np.delete(jacobian, i, axis=0)
        out[i] = tuple(int(j) for j in range(jacobian.shape[1])
                       if abs(jacobian[i, j]) > 0 and np.linalg.norm(others[:, j]) < ratio * abs(jacobian[i, j]))
    return out


def leave_one_out(
    evaluator: TwinEvaluator | None = None, progress: Callable[[str], None] | None = None
) -> LeaveOneOut:
    """Refit once per target without it, from the shipped model's parameters (the full fit), and predict it.

    Args:
        evaluator: The twin evaluator (default: a new one on the shipped model).
        progress: Called with each target's name before its refit.
    """
    ev = evaluator or TwinEvaluator()
    x_fit = ev.start_vector()
    r_fit = ev.residual(x_fit)
    jac = np.empty((len(r_fit), len(x_fit)))
    for j in range(len(x_fit)):
        step = np.zeros_like(x_fit)
        step[j] = _STEP * max(1.0, abs(x_fit[j]))
        jac[:, j] = (ev.residual(x_fit + step) - r_fit) / step[j]
    fitted = ev.measure(x_fit).values
    sole = sole_parameters(jac)
    predictions = []
    for i, target in enumerate(TARGETS):
        if progress is not None:
            progress(target.name)
        held = sole[i]
        free = [j for j in range(len(x_fit)) if j not in held]
        x_start = x_fit.copy()
        if held:
            values = to_values(x_start)
            for j in held:
                values[j] = PRIORS[PARAMETERS[j]][0]
            x_start = to_vector(values)
        keep = [k for k in range(len(TARGETS)) if k != i]

        def fun(x_free: np.ndarray, x_start: np.ndarray = x_start, free: list[int] = free,
                keep: list[int] = keep) -> np.ndarray:
            x = x_start.copy()
            x[free] = x_free
            return ev.residual(x)[keep]

        fit = least_squares(fun, x_start[free], bounds=(LOWER[free], UPPER[free]), diff_step=_STEP,
                            x_scale=0.1, xtol=1e-6)
        x = x_start.copy()
        x[free] = fit.x
        dof = max(len(keep) - len(free), 1)
        predictions.append(Prediction(
            target.name, target.unit, target.thesis, fitted[target.name], ev.measure(x).values[target.name],
            tuple(PARAMETERS[j] for j in held), float(fit.fun @ fit.fun) / dof, dof,
        ))
    dof = len(TARGETS) - len(PARAMETERS)
    return LeaveOneOut(predictions, float(r_fit @ r_fit) / dof, dof, ev.evaluations)
