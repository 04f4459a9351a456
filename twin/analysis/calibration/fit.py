"""Calibrate the twin's free physical parameters to the thesis's measurements (scipy least squares).

Free parameters: the stiffnesses in log10 (positive, and relative steps make sense), the frictions in
units of 100 N·m (they may be 0):

| parameter | what | why it is free |
|---|---|---|
| K_q,1, K_q,2, K_q,3, K_q,5 | joint stiffnesses [N·m/rad] | the joints that move the tool tip at `home` |
| k_unload | sheet's elastic unloading stiffness [N/m] | sets the springback (CNC depth) and the force fall of a lifted tool |
| k_load | sheet's forming sensitivity [N/m] | how the force follows a tool that forms deeper or shallower than planned |
| τ_f,2, τ_f,3, τ_f,5 | joint friction [N·m] | the only non-reciprocal term: a load test from rest loses τ_f/K_q per joint |

Why friction: a robot without it has a symmetric compliance (Maxwell–Betti, thesis §4.1.3), and the
antisymmetric part of the thesis's C_R(1) alone is 21 % of its norm, so no symmetric model comes within 20 %
of it. Gear friction makes the load test's deflection an affine function of the load (a constant deficit
while all loads lie in one octant, as Table 4.2's do), and the OLS fit through the origin of Method 1 turns
that into the asymmetric K_R(1) the thesis found.

K_q,4 and K_q,6 stay fixed: they do not move the tool tip at `home` (joint 6's axis goes through the tip, joint
4's column of the design matrix has a singular value 9e-4 of the largest). Residuals are (twin − thesis)/σ of
every target in `twin.analysis.calibration.targets.TARGETS`; uncertainties of the parameters come from the
Jacobian at the optimum, cov = (JᵀJ)⁻¹ scaled by the reduced χ² when it exceeds 1 (the model cannot match every
target, and the spread that remains is part of what we do not know).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from twin.analysis.calibration.targets import TARGETS, TwinMeasurements, measure_twin
from twin.process.description import Process
from twin.process.fe.load import ForceHistory, default_force_history
from twin.process.force.table import K_LOAD_N_PER_M, K_UNLOAD_N_PER_M, SheetForceField
from twin.process.toolpath.groove import groove_path
from twin.robot.description import load_robot
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

_ROBOT = load_robot()
#: Joints (0-based) whose K_q and friction are fitted: the robot description's `[calibration]`.
_JOINTS = tuple(_ROBOT.joints.index(j) for j in _ROBOT.calibrated_stiffness)
_FRICTION_JOINTS = tuple(_ROBOT.joints.index(j) for j in _ROBOT.calibrated_friction)
#: Parameter names, in the order of the fitted vector.
PARAMETERS = (
    *(f"k_q{j + 1}_nm_per_rad" for j in _JOINTS),
    "k_unload_n_per_m", "k_load_n_per_m",
    *(f"friction{j + 1}_nm" for j in _FRICTION_JOINTS),
)
_N_LOG = len(_JOINTS) + 2  # stiffnesses are fitted in log10, the frictions in units of _FRICTION_UNIT_NM
_FRICTION_UNIT_NM = 100.0
#: Bounds of the fitted vector: K_q in 1e5..1e8 N·m/rad, sheet sensitivities in 1e4..1e8 N/m, frictions 0..500 N·m.
LOWER = np.array([5.0] * len(_JOINTS) + [4.0, 4.0] + [0.0] * len(_FRICTION_JOINTS))
UPPER = np.array([8.0] * len(_JOINTS) + [8.0, 8.0] + [5.0] * len(_FRICTION_JOINTS))


def to_values(x: np.ndarray) -> np.ndarray:
    """Fitted vector -> parameter values in SI (order `PARAMETERS`)."""
    x = np.asarray(x, dtype=float)
    return np.concatenate([10.0 ** x[:_N_LOG], _FRICTION_UNIT_NM * x[_N_LOG:]])


def to_vector(values: np.ndarray) -> np.ndarray:
    """Parameter values in SI -> fitted vector."""
    v = np.asarray(values, dtype=float)
    return np.concatenate([np.log10(v[:_N_LOG]), v[_N_LOG:] / _FRICTION_UNIT_NM])


@dataclass(frozen=True)
class Calibration:
    """Result of a calibration.

    Attributes:
        values: Parameter name -> fitted value (SI).
        sigma: Parameter name -> 1σ uncertainty (SI, from the Jacobian).
        start: Parameter name -> starting value.
        measurements: The targets measured on the calibrated twin.
        chi2_reduced: Σ r² / (targets − parameters) at the optimum.
        evaluations: Twin evaluations spent.
    """

    values: dict[str, float]
    sigma: dict[str, float]
    start: dict[str, float]
    measurements: TwinMeasurements
    chi2_reduced: float
    evaluations: int

    @property
    def joint_stiffness(self) -> np.ndarray:
        """Calibrated K_q of the arm joints [N·m/rad] (those not calibrated as in the model)."""
        k = Twin(TwinSpec()).joint_stiffness
        for j, name in zip(_JOINTS, PARAMETERS[: len(_JOINTS)], strict=True):
            k[j] = self.values[name]
        return k

    @property
    def joint_friction(self) -> np.ndarray:
        """Calibrated friction of the arm joints [N·m] (0 for those not calibrated)."""
        tau = np.zeros(_ROBOT.dof)
        for j, name in zip(_FRICTION_JOINTS, PARAMETERS[_N_LOG:], strict=True):
            tau[j] = self.values[name]
        return tau

    def residuals(self) -> list[dict[str, object]]:
        """Per target: thesis value, twin value, difference and difference/σ."""
        out: list[dict[str, object]] = []
        for t in TARGETS:
            twin_value = self.measurements.values[t.name]
            out.append({
                "target": t.name, "unit": t.unit, "thesis": t.thesis, "sigma": t.sigma, "twin": twin_value,
                "difference": twin_value - t.thesis, "normalised": (twin_value - t.thesis) / t.sigma,
                "source": t.source,
            })
        return out


class TwinEvaluator:
    """Measures the targets on the twin for a parameter vector, reusing one twin (K_q set in place)."""

    def __init__(self, history: ForceHistory | None = None) -> None:
        self.history = history or default_force_history()
        self.twin = TwinSpec(process=Process(history=self.history)).build()
        self.path = groove_path()
        self.f_ideal_n = SheetForceField(self.history).rigid_forces(self.path)
        self.evaluations = 0

    def start_vector(self) -> np.ndarray:
        """The twin's current parameters as a fitted vector."""
        k = self.twin.joint_stiffness
        tau = self.twin.joint_friction
        return to_vector(
            np.array([*k[list(_JOINTS)], K_UNLOAD_N_PER_M, K_LOAD_N_PER_M, *tau[list(_FRICTION_JOINTS)]])
        )

    def measure(self, x: np.ndarray) -> TwinMeasurements:
        """Set the parameters (a fitted vector) on the twin and measure every target."""
        p = to_values(x)
        k = self.twin.joint_stiffness
        k[list(_JOINTS)] = p[: len(_JOINTS)]
        self.twin.set_joint_stiffness(k)
        tau = np.zeros(_ROBOT.dof)
        tau[list(_FRICTION_JOINTS)] = p[_N_LOG:]
        self.twin.joint_friction = tau

        def field() -> SheetForceField:
            return SheetForceField(self.history, k_unload_n_per_m=p[_N_LOG - 2], k_load_n_per_m=p[_N_LOG - 1])

        self.twin.set_sheet_field(field())
        self.evaluations += 1
        return measure_twin(self.twin, self.path, field_factory=field, f_ideal_n=self.f_ideal_n)

    def residual(self, x: np.ndarray) -> np.ndarray:
        """(twin − thesis)/σ of every target."""
        values = self.measure(x).values
        return np.array([(values[t.name] - t.thesis) / t.sigma for t in TARGETS])


def calibrate(
    history: ForceHistory | None = None,
    *,
    start: np.ndarray | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> Calibration:
    """Fit the free parameters to the thesis's targets.

    Args:
        history: FE force history (physical); default the shipped one.
        start: Starting parameter values in SI (order `PARAMETERS`); default the shipped model's.
        progress: Called with (evaluation count, cost) after each evaluation.

    Returns:
        The calibration, with uncertainties and the residual of every target.
    """
    ev = TwinEvaluator(history)
    x0 = ev.start_vector() if start is None else to_vector(start)
    # a friction of exactly 0 is a kink of the stick/slip model (no slope there): start frictions at 100 N·m
    x0[_N_LOG:] = np.where(x0[_N_LOG:] > 0.0, x0[_N_LOG:], 1.0)
    x0 = np.clip(x0, LOWER, UPPER)

    def fun(x: np.ndarray) -> np.ndarray:
        r = ev.residual(x)
        if progress is not None:
            progress(ev.evaluations, 0.5 * float(r @ r))
        return r

    fit = least_squares(fun, x0, bounds=(LOWER, UPPER), diff_step=1e-3, x_scale=0.1, xtol=1e-6)
    dof = max(len(TARGETS) - len(PARAMETERS), 1)
    chi2_red = float(fit.fun @ fit.fun) / dof
    cov = np.linalg.pinv(fit.jac.T @ fit.jac) * max(chi2_red, 1.0)
    sigma_x = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    values = to_values(fit.x)
    # d value / d x: value·ln 10 for the log10 parameters, the unit for the frictions
    scale = np.concatenate([values[:_N_LOG] * math.log(10.0), np.full(len(values) - _N_LOG, _FRICTION_UNIT_NM)])
    return Calibration(
        values={n: float(v) for n, v in zip(PARAMETERS, values, strict=True)},
        sigma={n: float(s) for n, s in zip(PARAMETERS, scale * sigma_x, strict=True)},
        start={n: float(v) for n, v in zip(PARAMETERS, to_values(x0), strict=True)},
        measurements=ev.measure(fit.x),
        chi2_reduced=chi2_red,
        evaluations=ev.evaluations,
    )
