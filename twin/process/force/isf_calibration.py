"""Calibration of the ISF force model (`twin.process.force.isf`) on an FE force history along the groove.

The history becomes calibration data: the model is driven rigidly along the history's tool path
(`IsfForceField.rigid_forces`) and four constants are fitted by least squares to Fz and Fx, each normalised by
its peak: the groove factor (the history's force level over the general formula's on this groove, `scale`), the
in-plane ratio μ_t, the travel-direction filter length L_f and the plateau engagement Δz_min. These are a fit
to our own stand-in data, not a validation; only L_f and Δz_min are kept as the model's constants
(`twin.process.force.isf_params`). Aerens's coefficient and exponents, R_m, t and R stay as published, the wall-angle
cap is the groove's geometry and the build-up depth a fit to published depth curves: the model's steady forces
on any part are the process's, and the groove factor says where the groove's zig-zag sits against them
(docs/forces.md).

The tool path between two samples is not always their chord: an export sampled at equal arc length puts the
reversals of a zig-zag between samples (the groove's 1311 samples miss all nine corners), and a sample a few
hundredths of a millimetre past a corner then seems to move the old way. `history_drive` puts the turns back
where the arc length between two samples exceeds their chord (`ForceHistory.turns`): the corner where the
incoming and outgoing lines meet with legs that add up to that arc length, accepted when they join the two
samples to within 5 % of it. The model is driven through the corners and compared at the history's samples.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from twin.process.fe.load import ForceHistory
from twin.process.force.isf import IsfForceField
from twin.process.force.isf_params import IsfForceParams
from twin.process.toolpath.groove import ToolPath, label_passes

#: Miss [-] of a reconstructed corner's legs at the next sample, over the arc length between the samples.
_TURN_TOLERANCE = 0.05

# fitted constants: (name, scale to the optimiser's unit, lower bound, upper bound) in the optimiser's units
_FITTED = (
    ("scale", 1.0, 0.2, 5.0),
    ("mu_eff", 1.0, 0.01, 1.0),
    ("direction_length_m", 1e-3, 0.1, 20.0),
    ("step_min_m", 1e-3, 0.05, 0.2),  # >= 0.05 mm caps the stiffness 0.09·Fz/Δh; <= 0.2 keeps Aerens over 0.2-1 mm
)


@dataclass(frozen=True)
class IsfFit:
    """Result of `calibrate_isf`.

    Attributes:
        params: The fitted constants (`scale` is the groove factor).
        rms_fz: RMS of Fz_model - Fz_history over the history, divided by the peak Fz [-].
        rms_fx: The same for Fx, divided by the peak |Fx| [-].
        evaluations: Model drives the fit took.
    """

    params: IsfForceParams
    rms_fz: float
    rms_fx: float
    evaluations: int


def history_drive(history: ForceHistory) -> tuple[ToolPath, np.ndarray]:
    """The history's tool path with the turns between samples put back (module docstring).

    Returns:
        (path through the samples and the reconstructed corners, row of each history sample in that path).
    """
    p, s = history.p_sheet_m, history.s_m
    turned = history.turns()
    points, rows = [p[0]], [0]
    for i in range(len(p) - 1):
        gap = s[i + 1] - s[i]
        d = p[i + 1] - p[i]
        if turned[i] and 0 < i < len(p) - 2:
            u_in, u_out = p[i] - p[i - 1], p[i + 2] - p[i + 1]
            n_in, n_out = np.linalg.norm(u_in), np.linalg.norm(u_out)
            if n_in > 0.0 and n_out > 0.0:
                u_in, u_out = u_in / n_in, u_out / n_out
                # legs a + b = gap with a·u_in + b·u_out = d (least squares in a)
                a = float((u_in - u_out) @ (d - gap * u_out) / max((u_in - u_out) @ (u_in - u_out), 1e-12))
                miss = np.linalg.norm(a * u_in + (gap - a) * u_out - d)
                if 0.0 < a < gap and miss <= _TURN_TOLERANCE * gap:
                    points.append(p[i] + a * u_in)
        points.append(p[i + 1])
        rows.append(len(points) - 1)
    drive = np.array(points)
    steps = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(drive, axis=0), axis=1))]
    pass_index, direction = label_passes(drive[:, 0])
    feed = 2.0 / 60.0  # [m/s], as `ForceHistory.to_path` (the model is rate-independent)
    return ToolPath(t_s=steps / feed, p_sheet_m=drive, pass_index=pass_index, direction=direction), np.array(rows)


def groove_errors(params: IsfForceParams, history: ForceHistory) -> tuple[float, float, np.ndarray]:
    """RMS errors of the model against the history, each over its peak, and the model's forces.

    Returns:
        (rms_fz, rms_fx, forces (n, 3) [N]) at the history's samples, the model driven along `history_drive`.
    """
    drive, rows = history_drive(history)
    forces = IsfForceField(params).rigid_forces(drive)[rows]
    ref = history.f_sheet_n
    rms_fz = float(np.sqrt(np.mean((forces[:, 2] - ref[:, 2]) ** 2)) / np.max(np.abs(ref[:, 2])))
    rms_fx = float(np.sqrt(np.mean((forces[:, 0] - ref[:, 0]) ** 2)) / np.max(np.abs(ref[:, 0])))
    return rms_fz, rms_fx, forces


def calibrate_isf(history: ForceHistory, start: IsfForceParams | None = None) -> IsfFit:
    """Fit the groove factor, μ_t, L_f and Δz_min to a groove force history (module docstring).

    Args:
        history: Physical force history along the groove (`load_force_history`).
        start: Initial constants (also the fixed ones: material, tool, k_unload); None for the defaults.
    """
    base = start or IsfForceParams()
    path, rows = history_drive(history)
    ref = history.f_sheet_n
    peak_z, peak_x = np.max(np.abs(ref[:, 2])), np.max(np.abs(ref[:, 0]))
    norm = 1.0 / np.sqrt(len(rows))

    def params_of(v: np.ndarray) -> IsfForceParams:
        return replace(base, **{name: float(x) * unit for (name, unit, _, _), x in zip(_FITTED, v, strict=True)})

    def residual(v: np.ndarray) -> np.ndarray:
        f = IsfForceField(params_of(v)).rigid_forces(path)[rows]
        return norm * np.concatenate([(f[:, 2] - ref[:, 2]) / peak_z, (f[:, 0] - ref[:, 0]) / peak_x])

    lo = np.array([b[2] for b in _FITTED])
    hi = np.array([b[3] for b in _FITTED])
    v0 = np.clip([getattr(base, name) / unit for name, unit, _, _ in _FITTED], lo, hi)
    result = least_squares(residual, v0, bounds=(lo, hi), diff_step=1e-3)
    params = params_of(result.x)
    rms_fz, rms_fx, _ = groove_errors(params, history)
    return IsfFit(params=params, rms_fz=rms_fz, rms_fx=rms_fx, evaluations=int(result.nfev))
