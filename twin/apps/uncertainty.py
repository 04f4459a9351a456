"""The uncertainty of the Monte Carlo sweep (`twin.apps.sweep`): which parameters are drawn, their means and σ.

Means and σ come from a calibration file (`tx200-twin calibrate` writes `parameters` and `sigma`, e.g.
docs/calibration.json; only the σ of each parameter is stored, so the draws are independent), else from the
model with the relative σ of `DEFAULT_RELATIVE_SIGMA`. Parameters a file does not name keep those defaults.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from twin.base.jsonio import read_json
from twin.errors import InputError
from twin.process.force.table import SheetForceField
from twin.robot.description import load_robot
from twin.sim.quasi_static import Twin

#: Relative σ of each parameter group when no calibration file gives one [-].
DEFAULT_RELATIVE_SIGMA: dict[str, float] = {
    "k_q": 0.10,  # K_q from a load test: the thesis's Method 1 spread is ~10 % per joint
    "friction": 0.30,
    "k_unload_n_per_m": 0.20,  # calibration: 1.43 ± 0.29 kN/mm
    "k_load_n_per_m": 0.40,  # calibration: 0.160 ± 0.065 kN/mm
    "force_scale": 0.05,
}
MIN_FRACTION = 0.1  # stiffnesses and the force scale are clipped to >= this fraction of their mean
_DOF = load_robot().dof
#: The drawn parameters, in the order of a draw's values: K_q and friction per joint (numbered from 1), the
#: sheet's two sensitivities and the force scale.
PARAMETERS: tuple[str, ...] = (
    *(f"k_q{i}_nm_per_rad" for i in range(1, _DOF + 1)),
    *(f"friction{i}_nm" for i in range(1, _DOF + 1)),
    "k_unload_n_per_m",
    "k_load_n_per_m",
    "force_scale",
)


class Draw(NamedTuple):
    """One parameter set of `PARAMETERS`, by name.

    Attributes:
        k_q_nm_per_rad: Joint stiffness per joint [N·m/rad], shape (dof,).
        friction_nm: Joint friction per joint [N·m], shape (dof,).
        k_unload_n_per_m: The sheet's unloading stiffness [N/m].
        k_load_n_per_m: The sheet's forming sensitivity [N/m].
        force_scale: Factor on the FE history's forces [-].
    """

    k_q_nm_per_rad: np.ndarray
    friction_nm: np.ndarray
    k_unload_n_per_m: float
    k_load_n_per_m: float
    force_scale: float

    @classmethod
    def of(cls, values: np.ndarray) -> Draw:
        """Split a row of values (`PARAMETERS` order)."""
        return cls(values[:_DOF], values[_DOF : 2 * _DOF], float(values[2 * _DOF]), float(values[2 * _DOF + 1]),
                   float(values[2 * _DOF + 2]))

    def values(self) -> np.ndarray:
        """The row of values (`PARAMETERS` order)."""
        return np.array([*self.k_q_nm_per_rad, *self.friction_nm, self.k_unload_n_per_m, self.k_load_n_per_m,
                         self.force_scale])


@dataclass(frozen=True)
class Uncertainty:
    """Independent normal uncertainty of the sweep's parameters (`PARAMETERS` order).

    Attributes:
        mean: Mean of each parameter [its unit], shape (len(PARAMETERS),).
        sigma: Standard deviation [its unit], shape (len(PARAMETERS),).
        source: Where the values come from (a file, or "model defaults").
    """

    mean: np.ndarray
    sigma: np.ndarray
    source: str

    def draw(self, n: int, seed: int) -> np.ndarray:
        """`n` parameter sets [units of `PARAMETERS`], shape (n, len(PARAMETERS)), clipped to physical values."""
        if n < 1:
            raise InputError(f"draws = {n!r}: expected >= 1")
        rng = np.random.default_rng(seed)
        values = self.mean + self.sigma * rng.standard_normal((n, len(PARAMETERS)))
        floor = np.array([0.0 if name.startswith("friction") else MIN_FRACTION for name in PARAMETERS])
        return np.maximum(values, floor * self.mean)


def model_uncertainty(twin: Twin, calibration: Mapping[str, Any] | None = None, source: str = "") -> Uncertainty:
    """Means and σ of the sweep: the model's values with `DEFAULT_RELATIVE_SIGMA`, overridden by a calibration.

    Args:
        twin: The nominal twin (K_q, friction and the field's k_unload/k_load are read from it).
        calibration: A `tx200-twin calibrate` payload with `parameters` and `sigma` (same keys), or None.
        source: Name of the calibration (a path) for the record.

    Raises:
        InputError: A twin whose robot has another number of joints than `PARAMETERS` names, or whose force
            model is not the table field; a calibration without `parameters`/`sigma`, or with a non-finite,
            negative or zero-mean value.
    """
    sheet = twin.sheet_field
    if not isinstance(sheet, SheetForceField):
        raise InputError(f"the sweep draws the table field's sensitivities; the twin's force model is {type(sheet).__name__}")
    if len(twin.joint_stiffness) != _DOF:
        raise InputError(f"the sweep draws K_q and friction of {_DOF} joints; the twin's robot {twin.robot.name!r} "
                         f"has {len(twin.joint_stiffness)}")
    mean = Draw(twin.joint_stiffness, twin.joint_friction, sheet.k_unload, sheet.k_load, 1.0).values()
    sigma = Draw(
        np.full(_DOF, DEFAULT_RELATIVE_SIGMA["k_q"]), np.full(_DOF, DEFAULT_RELATIVE_SIGMA["friction"]),
        DEFAULT_RELATIVE_SIGMA["k_unload_n_per_m"], DEFAULT_RELATIVE_SIGMA["k_load_n_per_m"],
        DEFAULT_RELATIVE_SIGMA["force_scale"],
    ).values() * mean
    if calibration is None:
        return Uncertainty(mean, sigma, "model defaults")
    params, sig = calibration.get("parameters"), calibration.get("sigma")
    if not isinstance(params, Mapping) or not isinstance(sig, Mapping):
        raise InputError(f"{source}: expected a calibration with 'parameters' and 'sigma' objects")
    for j, name in enumerate(PARAMETERS):
        if name not in params and name not in sig:
            continue
        if name not in params or name not in sig:
            raise InputError(f"{source}: '{name}' needs both a value in 'parameters' and one in 'sigma'")
        value, spread = params[name], sig[name]
        if not (isinstance(value, int | float) and isinstance(spread, int | float)):
            raise InputError(f"{source}: '{name}' = {value!r} ± {spread!r}: expected numbers")
        if not (math.isfinite(value) and math.isfinite(spread) and value >= 0 and spread >= 0):
            raise InputError(f"{source}: '{name}' = {value!r} ± {spread!r}: expected finite values >= 0")
        if value == 0 and not name.startswith("friction"):
            raise InputError(f"{source}: '{name}' = 0: a stiffness or scale must be > 0")
        mean[j], sigma[j] = float(value), float(spread)
    return Uncertainty(mean, sigma, str(source))


def load_uncertainty(path: str | Path | None, twin: Twin) -> Uncertainty:
    """`model_uncertainty` from a calibration JSON file, or the model defaults when `path` is None."""
    if path is None:
        return model_uncertainty(twin)
    return model_uncertainty(twin, read_json(path), str(path))
