"""The sheet's force learned from a cell: the height-map ISF model with a membrane correction fitted to a run.

A real cell's sheet need not push as Aerens's formula says (`twin.process.force.isf`): its level, how it builds
up with depth and how it depends on the surface around the tool are the cell's own. This model keeps the ISF
model's height map, wall angle, sliding direction and in-plane law, and writes its unsoftened axial force as

    Fz_lin = w · Fz_isf,lin + a_side · Σ_{left, right} m(u_s) + b_side · Σ_{left, right} u_s³ + a_ahead · m(u_a)

with u = sin β = r / sqrt(r² + R²), r = max(S(p + R·d) − z, 0) the rise of the met surface one tool radius R
from the tip, to the left and the right of the held travel direction and ahead of it (the sheet wrapped
around the tool leaves it at the angle β), and m(u) = u²·sqrt(1 − u²): the vertical part (sin β) of a membrane
force per side σ·t·cos β over a contact length R·sin β (the membrane analysis of SPIF: Silva, Skjødt, Atkins,
Bay, Martins, J Strain Anal 43 (2008) 15-35). The u³ term lets the membrane stress grow with the wrap (strain
hardening). With w = 1 and the rest 0 it is the ISF model itself (its prior); what `twin.analysis.learn`
fits from a run's F/T stream is marked fitted wherever it is reported. Every feature reads the formed surface,
so the learned force carries from one part shape to another (learned on a cone, used on a pyramid).

Its compiled kernel is the ISF model's (`twin.sim.compiled.isf`), which adds these terms where the model
carries them; `tests/test_compiled_replay.py` holds the two loops together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from twin.errors import InputError
from twin.process.force.isf import IsfForceField
from twin.process.force.isf_params import IsfForceParams


@dataclass(frozen=True)
class LearnedWeights:
    """The learned terms of `LearnedForceField` (module docstring).

    Attributes:
        prior_weight: w, the weight of the ISF model's own axial force [-] (1: the prior).
        side_membrane_n: a_side, on Σ m(u) over the two sides [N].
        side_cubic_n: b_side, on Σ u³ over the two sides [N].
        ahead_membrane_n: a_ahead, on m(u) ahead of the tool [N].
    """

    prior_weight: float = 1.0
    side_membrane_n: float = 0.0
    side_cubic_n: float = 0.0
    ahead_membrane_n: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise InputError(f"LearnedWeights.{f.name} = {value!r}: expected a finite number")

    def as_array(self) -> np.ndarray:
        """(w, a_side, b_side, a_ahead)."""
        return np.array([getattr(self, f.name) for f in fields(self)])


#: Where the rises are read, in tool radii from the tip [-].
REACH = 1.0
#: Largest rise read, in tool radii [-].
CAP = 1.0
#: The keys of `LearnedWeights`, as `Process.force_fit` carries them beside the ISF constants.
WEIGHT_KEYS = tuple(f.name for f in fields(LearnedWeights))


def _membrane(s: float, radius: float) -> tuple[float, float, float, float]:
    """(m(u), dm/ds, u³, d(u³)/ds) for a rise s [m] one tool radius away."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if s >= CAP * radius:
        return _membrane(0.999999 * CAP * radius, radius)[0], 0.0, _membrane(0.999999 * CAP * radius, radius)[2], 0.0
    q = s * s + radius * radius
    u = s / math.sqrt(q)
    du = radius * radius / q**1.5
    c = math.sqrt(max(1.0 - u * u, 1e-12))
    return u * u * c, (2.0 * u * c - u**3 / c) * du, u**3, 3.0 * u * u * du


class LearnedForceField(IsfForceField):
    """The ISF model with learned membrane terms (module docstring); compiled kernel `isf`.

    Args:
        params: ISF model constants (level, in-plane ratios, ...), possibly fitted too.
        weights: The learned terms; None for the prior (the ISF model itself).
        half_size_m: Half-extent (x, y) of the modelled sheet [m].
    """

    compiled_kernel: ClassVar[str | None] = "isf"

    def __init__(self, params: IsfForceParams | None = None, weights: LearnedWeights | None = None,
                 half_size_m: tuple[float, float] = (0.12, 0.12)) -> None:
        self.weights = weights or LearnedWeights()
        self._w = self.weights.as_array()
        super().__init__(params, half_size_m)

    def features(self, p_sheet_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The terms the axial force is a weighted sum of, at a tip position, and their gradients; pure.

        Returns:
            (values (4,) [N for the prior, - for the rest], gradients (4, 3) [per m]) in the order of
            `LearnedWeights`.
        """
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        lin, gx, gy, gz = super()._fz_linear(x, y, z)
        vx, vy = self._dir
        speed = math.hypot(vx, vy)
        vx, vy = (vx / speed, vy / speed) if speed > 1e-9 else (1.0, 0.0)
        radius = self.radius
        reach = REACH * radius
        values = np.array([lin, 0.0, 0.0, 0.0])
        grads = np.zeros((4, 3))
        grads[0] = gx, gy, gz
        for dx, dy, ahead in ((-vy, vx, False), (vy, -vx, False), (vx, vy, True)):
            s, sx, sy = self.map.met_height(x + reach * dx, y + reach * dy)
            m, dm, cube, dcube = _membrane(s - z, radius)
            k = 3 if ahead else 1
            values[k] += m
            grads[k] += (dm * sx, dm * sy, -dm)
            if not ahead:
                values[2] += cube
                grads[2] += (dcube * sx, dcube * sy, -dcube)
        return values, grads

    def _fz_linear(self, x: float, y: float, z: float) -> tuple[float, float, float, float]:
        values, grads = self.features(np.array([x, y, z]))
        w = self._w
        g = w @ grads
        return float(w @ values), float(g[0]), float(g[1]), float(g[2])
