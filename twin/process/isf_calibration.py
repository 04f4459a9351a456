"""Calibration of the ISF force model (`twin.process.isf_force`) on an FE force history along the groove.

The history becomes calibration data: the model is driven rigidly along the history's own samples
(`IsfForceField.rigid_forces`) and five constants are fitted by least squares to Fz and Fx, each normalised by
its peak: the wall-angle cap α_max, the build-up depth D0, the in-plane ratio μ_eff, the travel-direction
filter length L_f and the plateau engagement Δh_min. Aerens's coefficient and exponents, R_m, t and R stay as
published, so the model's steady-state forces on cone walls below α_max are Aerens's formula, not a fit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from twin.process.forces import ForceHistory
from twin.process.isf_force import IsfForceField, IsfForceParams

# fitted constants: (name, scale to the optimiser's unit, lower bound, upper bound) in the optimiser's units
_FITTED = (
    ("wall_angle_max_deg", 1.0, 49.3, 89.0),  # above the peak of α·cos α (49.3°): the steep branch
    ("build_up_m", 1e-3, 0.2, 10.0),
    ("mu_eff", 1.0, 0.01, 1.0),
    ("direction_length_m", 1e-3, 0.1, 20.0),
    ("step_min_m", 1e-3, 0.05, 0.2),  # >= 0.05 mm caps the stiffness 0.09·Fz/Δh; <= 0.2 keeps Aerens over 0.2-1 mm
)


@dataclass(frozen=True)
class IsfFit:
    """Result of `calibrate_isf`.

    Attributes:
        params: The fitted constants.
        rms_fz: RMS of Fz_model - Fz_history over the history, divided by the peak Fz [-].
        rms_fx: The same for Fx, divided by the peak |Fx| [-].
        evaluations: Model drives the fit took.
    """

    params: IsfForceParams
    rms_fz: float
    rms_fx: float
    evaluations: int


def groove_errors(params: IsfForceParams, history: ForceHistory) -> tuple[float, float, np.ndarray]:
    """RMS errors of the model against the history, each over its peak, and the model's forces.

    Returns:
        (rms_fz, rms_fx, forces (n, 3) [N]) along the history's samples.
    """
    forces = IsfForceField(params).rigid_forces(history.to_path())
    ref = history.f_sheet_n
    rms_fz = float(np.sqrt(np.mean((forces[:, 2] - ref[:, 2]) ** 2)) / np.max(np.abs(ref[:, 2])))
    rms_fx = float(np.sqrt(np.mean((forces[:, 0] - ref[:, 0]) ** 2)) / np.max(np.abs(ref[:, 0])))
    return rms_fz, rms_fx, forces


def calibrate_isf(history: ForceHistory, start: IsfForceParams | None = None) -> IsfFit:
    """Fit α_max, D0, μ_eff, L_f and Δh_min to a groove force history (module docstring).

    Args:
        history: Physical force history along the groove (`load_force_history`).
        start: Initial constants (also the fixed ones: material, tool, k_unload); None for the defaults.
    """
    base = start or IsfForceParams()
    path = history.to_path()
    ref = history.f_sheet_n
    peak_z, peak_x = np.max(np.abs(ref[:, 2])), np.max(np.abs(ref[:, 0]))
    norm = 1.0 / np.sqrt(len(path))

    def params_of(v: np.ndarray) -> IsfForceParams:
        return replace(base, **{name: float(x) * unit for (name, unit, _, _), x in zip(_FITTED, v, strict=True)})

    def residual(v: np.ndarray) -> np.ndarray:
        f = IsfForceField(params_of(v)).rigid_forces(path)
        return norm * np.concatenate([(f[:, 2] - ref[:, 2]) / peak_z, (f[:, 0] - ref[:, 0]) / peak_x])

    lo = np.array([b[2] for b in _FITTED])
    hi = np.array([b[3] for b in _FITTED])
    v0 = np.clip([getattr(base, name) / unit for name, unit, _, _ in _FITTED], lo, hi)
    result = least_squares(residual, v0, bounds=(lo, hi), diff_step=1e-3)
    params = params_of(result.x)
    rms_fz, rms_fx, _ = groove_errors(params, history)
    return IsfFit(params=params, rms_fz=rms_fz, rms_fx=rms_fx, evaluations=int(result.nfev))


def fitted_scale(params: IsfForceParams, history: ForceHistory) -> float:
    """The factor on the model's forces that best matches the history's Fz along its samples (least squares) [-].

    A history scaled by k (a stiffer sheet, `force_scale`) gives k times the params' own scale.
    """
    fz = IsfForceField(replace(params, scale=1.0)).rigid_forces(history.to_path())[:, 2]
    ref = history.f_sheet_n[:, 2]
    return float(fz @ ref / (fz @ fz))


def isf_field_factory(params: IsfForceParams | None = None) -> Callable[[ForceHistory], IsfForceField]:
    """A `Twin(field_factory=...)` argument: the ISF height-map model with its force level fitted to the history.

    Args:
        params: Model constants (all but `scale`, which is fitted); None for the calibrated defaults.
    """
    base = params or IsfForceParams()

    def build(history: ForceHistory) -> IsfForceField:
        return IsfForceField(replace(base, scale=fitted_scale(base, history)))

    return build
