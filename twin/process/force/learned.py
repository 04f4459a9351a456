"""The sheet's force learned from a cell: the height-map ISF model and a library of terms of the formed state.

A real cell's sheet need not push as Aerens's formula says (`twin.process.force.isf`): its level, how it builds
up with depth, the step-down and the wall are the cell's own. This model keeps the ISF model's height map, wall
angle, sliding direction and in-plane law, and writes its unsoftened axial force as a weighted sum of terms of
the formed state at the tip (a library; `twin.analysis.learn.sheet` chooses which a cell's data support):

    Fz_lin = w · Fz_isf,lin                                  the published formula (the prior mean: w = 1)
           + a_side · Σ_{left, right} m(u_s) + b_side · Σ_{left, right} u_s³ + a_ahead · m(u_a)   membrane wrap
           + Σ_k c_k · Π_{q in term k} q,   q in {Fz_isf,lin, E(Δz), σ(Δz), α / 45°, D, S_d(D)}   formed state

Membrane wrap: u = sin β = r / sqrt(r² + R²), r = max(S(p + R·d) − z, 0) the rise of the met surface one tool
radius R from the tip, to the left and the right of the held travel direction and ahead of it, and
m(u) = u²·sqrt(1 − u²): the vertical part of a membrane force per side σ·t·cos β over a contact length R·sin β
(Silva, Skjødt, Atkins, Bay, Martins, J Strain Anal 43 (2008) 15-35); u³ lets the membrane stress harden.
Formed state, the quantities the ISF literature's force correlations are written in (step-down, wall angle, depth;
e.g. Aerens et al., IJAMT 46 (2010); Duflou et al., CIRP Annals 56 (2007)): the engagement Δz = S(p) − z (the
step-down where a wall is formed), its smooth part E(Δz) = W·ln(1 + exp(Δz/W)) [mm] and the contact
σ(Δz) = 1/(1 + exp(−Δz/W)) (W = `CONTACT_WIDTH_M`: off the sheet every formed-state term fades), the held wall
angle α and the depth D = max(−z, 0) [mm] below the original sheet; the terms are those quantities and their
products up to second order in E and D (`STATE_TERMS`: E, σ, σα, σD, E², σD², σDE, Fz_isf,lin·D/10 mm, σαD), and
the depth's saturating rise σ·S_d(D), S_d = 1 − exp(−D/d), d = 1, 2, 4 mm (`SATURATION_MM`: the force of a wall
formed pass by pass builds up over its first millimetres of depth and then levels off, the course the ISF force
measurements show, e.g. Duflou et al. 2007; a polynomial in D fitted to that rise keeps rising where the part goes
deeper). They read no part shape around the tool. The rise terms read it as plainly as it can be read, the sines
u_s, u_a of the walls' rise to the sides and ahead and their squares (the wall angle on each side and ahead), with
no law of how a membrane or a bend turns them into force. With w = 1 and the rest 0 it is the ISF model itself;
what `twin.analysis.learn` fits is marked fitted wherever it is reported.

The in-plane law is the ISF model's, F_xy = -Fz·(μ_t·v + μ_r'·σ·L·v), with the radial ratio
μ_r' = μ_r + μ_ρ·Σ_{left, right} u_s: where the walls around the tool rise, the contact's normal tilts off the
vertical and the sheet pushes the tool across its travel by the axial force times that tilt (a normal at an angle
β to the vertical has a horizontal part tan β ≈ sin β of its vertical one). μ_ρ (`mu_radial_rise`) is the
learner's to choose like any term; 0 is the ISF model's law, and the rises are read as state (∂f/∂p does not
differentiate them, as it does not α or σ).

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
        engagement_n_per_mm: on the smooth engagement E [N/mm].
        contact_n: on the contact σ [N].
        wall_angle_n: on σ α / 45° [N].
        depth_n_per_mm: on σ D [N/mm].
        engagement_sq_n_per_mm2: on E² [N/mm²].
        depth_sq_n_per_mm2: on σ D² [N/mm²].
        depth_engagement_n_per_mm2: on σ D E [N/mm²].
        prior_per_cm: on Fz_isf,lin · D / 10 mm [-].
        wall_depth_n_per_mm: on σ α / 45° · D [N/mm].
        depth_sat_1mm_n: on σ (1 − exp(−D / 1 mm)), the depth's saturating rise [N].
        depth_sat_2mm_n: on σ (1 − exp(−D / 2 mm)) [N].
        depth_sat_4mm_n: on σ (1 − exp(−D / 4 mm)) [N].
        side_rise_n: on Σ_{left, right} u_s, the sines of the side walls' rise [N].
        side_rise_sq_n: on Σ_{left, right} u_s² [N].
        ahead_rise_n: on u_a, ahead [N].
    """

    prior_weight: float = 1.0
    side_membrane_n: float = 0.0
    side_cubic_n: float = 0.0
    ahead_membrane_n: float = 0.0
    engagement_n_per_mm: float = 0.0
    contact_n: float = 0.0
    wall_angle_n: float = 0.0
    depth_n_per_mm: float = 0.0
    engagement_sq_n_per_mm2: float = 0.0
    depth_sq_n_per_mm2: float = 0.0
    depth_engagement_n_per_mm2: float = 0.0
    prior_per_cm: float = 0.0
    wall_depth_n_per_mm: float = 0.0
    depth_sat_1mm_n: float = 0.0
    depth_sat_2mm_n: float = 0.0
    depth_sat_4mm_n: float = 0.0
    side_rise_n: float = 0.0
    side_rise_sq_n: float = 0.0
    ahead_rise_n: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value)):
                raise InputError(f"LearnedWeights.{f.name} = {value!r}: expected a finite number")

    def as_array(self) -> np.ndarray:
        """The weights in the order of `WEIGHT_KEYS`."""
        return np.array([getattr(self, f.name) for f in fields(self)])


#: Where the rises are read, in tool radii from the tip [-].
REACH = 1.0
#: Largest rise read, in tool radii [-].
CAP = 1.0
#: The keys of `LearnedWeights`, as `Process.force_fit` carries them beside the ISF constants.
WEIGHT_KEYS = tuple(f.name for f in fields(LearnedWeights))
#: The keys every learned model file has carried (the later ones are read as 0 where a file lacks them).
REQUIRED_WEIGHT_KEYS = WEIGHT_KEYS[:4]
#: The formed-state terms (read no part shape around the tool: `twin.analysis.learn.sheet`'s library).
STATE_KEYS = WEIGHT_KEYS[4:16]
#: The rise terms: the sines of the walls' rise one tool radius to the sides and ahead, as a polynomial.
RISE_KEYS = WEIGHT_KEYS[16:]
#: The depths [mm] over which the saturating depth terms rise to 1 - 1/e of their plateau.
SATURATION_MM = (1.0, 2.0, 4.0)
#: Each formed-state term (in the order of `STATE_KEYS`) as a product of up to three base quantities, indices
#: into (Fz_isf,lin [N], E [mm], σ [-], α / 45° [-], D [mm], 1 − exp(−D / d) for each d of `SATURATION_MM`)
#: (-1: none), and its factor.
STATE_TERMS = np.array([[1, -1, -1], [2, -1, -1], [2, 3, -1], [2, 4, -1], [1, 1, -1], [2, 4, 4], [2, 4, 1],
                        [0, 4, -1], [2, 3, 4], [2, 5, -1], [2, 6, -1], [2, 7, -1]], dtype=np.int64)
STATE_FACTORS = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.1, 1.0, 1.0, 1.0, 1.0])
#: `STATE_TERMS` as `features` walks them: each term's scale and factors, and each factor with the others beside it
#: (the product rule), worked out once.
_STATE_WALK = tuple(
    (float(scale), used, tuple((f, tuple(g for j, g in enumerate(used) if j != i)) for i, f in enumerate(used)))
    for factors, scale in zip(STATE_TERMS, STATE_FACTORS, strict=True)
    for used in (tuple(int(f) for f in factors if f >= 0),)
)
#: The column of the side walls' rise Σ u_s among the terms (`features`; the radial ratio's μ_ρ reads it).
SIDE_RISE_INDEX = WEIGHT_KEYS.index("side_rise_n")
_SIDE_RISE_SQ_INDEX, _AHEAD_RISE_INDEX = WEIGHT_KEYS.index("side_rise_sq_n"), WEIGHT_KEYS.index("ahead_rise_n")
#: The learned model's in-plane constant beyond the ISF model's: μ_ρ, the radial ratio per unit of the side walls'
#: rise Σ u_s [-] (module docstring).
RADIAL_RISE_KEY = "mu_radial_rise"
#: The weights on the published formula's force itself (dimensionless: a force-level ratio does not scale them).
ON_PRIOR_KEYS = ("prior_weight", "prior_per_cm")
#: Width of the contact's smooth step in the engagement [m].
CONTACT_WIDTH_M = 1e-4
#: The wall angle the wall term is read against [deg].
ALPHA_REF_DEG = 45.0


def contact_terms(dh_m: float) -> tuple[float, float, float]:
    """(E(Δz) [mm], σ(Δz) [-], dσ/dΔz [1/m]) of the engagement Δz [m] (module docstring)."""
    a = dh_m / CONTACT_WIDTH_M
    if a < -40.0:
        return 0.0, 0.0, 0.0
    ex = math.exp(-abs(a))
    soft = (max(a, 0.0) + math.log1p(ex)) * CONTACT_WIDTH_M
    sig = 1.0 / (1.0 + ex) if a >= 0.0 else ex / (1.0 + ex)
    return 1e3 * soft, sig, sig * (1.0 - sig) / CONTACT_WIDTH_M


def _add(row: list[float], factor: float, vec: tuple[float, float, float]) -> None:
    """row += factor * vec, element by element, in place (a factor of 1 leaves vec's bits as they are)."""
    for c in range(3):
        row[c] += factor * vec[c]


def _rise(s: float, radius: float) -> tuple[float, float]:
    """(u, du/ds [1/m]) for a rise s [m] one tool radius away, capped as `_membrane`."""
    if s <= 0.0:
        return 0.0, 0.0
    if s >= CAP * radius:
        return _rise(0.999999 * CAP * radius, radius)[0], 0.0
    q = s * s + radius * radius
    return s / math.sqrt(q), radius * radius / q**1.5


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
        radial_rise: μ_ρ, the radial ratio per unit of the side walls' rise [-] (module docstring; >= 0).

    Raises:
        InputError: `radial_rise` negative or not finite.
    """

    compiled_kernel: ClassVar[str | None] = "isf"

    def __init__(self, params: IsfForceParams | None = None, weights: LearnedWeights | None = None,
                 half_size_m: tuple[float, float] = (0.12, 0.12), radial_rise: float = 0.0) -> None:
        if not (math.isfinite(radial_rise) and radial_rise >= 0.0):
            raise InputError(f"{RADIAL_RISE_KEY} = {radial_rise!r}: expected a finite number >= 0 (a wall that rises "
                             "tilts the contact away from it)")
        self.weights = weights or LearnedWeights()
        self._w = self.weights.as_array()
        self.radial_rise = float(radial_rise)
        self._rise_sum = 0.0  # Σ u_s at the last evaluated tip (`features`), read by `_in_plane`
        super().__init__(params, half_size_m)

    def features(self, p_sheet_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The terms the axial force is a weighted sum of, at a tip position, and their gradients; pure.

        Returns:
            (values (k,) [N for the prior; -, mm for the rest], gradients (k, 3) [per m]) in the order of
            `LearnedWeights`.
        """
        x, y, z = float(p_sheet_m[0]), float(p_sheet_m[1]), float(p_sheet_m[2])
        lin, gx, gy, gz = super()._fz_linear(x, y, z)
        vx, vy = self._dir
        speed = math.hypot(vx, vy)
        vx, vy = (vx / speed, vy / speed) if speed > 1e-9 else (1.0, 0.0)
        radius = self.radius
        reach = REACH * radius
        values = [0.0] * len(WEIGHT_KEYS)  # Python floats, not numpy's: each operation the same, a third the time
        values[0] = lin
        grads = [[0.0, 0.0, 0.0] for _ in WEIGHT_KEYS]
        grads[0] = [gx, gy, gz]
        for dx, dy, ahead in ((-vy, vx, False), (vy, -vx, False), (vx, vy, True)):
            s, sx, sy = self.map.met_height(x + reach * dx, y + reach * dy)
            m, dm, cube, dcube = _membrane(s - z, radius)
            u, du = _rise(s - z, radius)
            rise = (du * sx, du * sy, -du)
            if ahead:
                values[_AHEAD_RISE_INDEX] = u
                grads[_AHEAD_RISE_INDEX] = list(rise)
            else:
                values[SIDE_RISE_INDEX] += u
                values[_SIDE_RISE_SQ_INDEX] += u * u
                _add(grads[SIDE_RISE_INDEX], 1.0, rise)
                _add(grads[_SIDE_RISE_SQ_INDEX], 2.0 * u, rise)
            k = 3 if ahead else 1
            values[k] += m
            _add(grads[k], 1.0, (dm * sx, dm * sy, -dm))
            if not ahead:
                values[2] += cube
                _add(grads[2], 1.0, (dcube * sx, dcube * sy, -dcube))
        s, sx, sy = self.map.met_height(x, y)
        soft, sig, dsig = contact_terms(s - z)
        depth_mm, d_depth = 1e3 * max(-z, 0.0), -1e3 if z < 0.0 else 0.0
        fade = [math.exp(-depth_mm / d) for d in SATURATION_MM]
        b = [float(v) for v in (lin, soft, sig, self._alpha / ALPHA_REF_DEG, depth_mm, *[1.0 - e for e in fade])]
        base_grad = [(gx, gy, gz), (1e3 * sig * sx, 1e3 * sig * sy, -1e3 * sig), (dsig * sx, dsig * sy, -dsig),
                     (0.0, 0.0, 0.0), (0.0, 0.0, d_depth),
                     *[(0.0, 0.0, e / d * d_depth) for e, d in zip(fade, SATURATION_MM, strict=True)]]
        for k, (scale, used, rule) in enumerate(_STATE_WALK):  # product rule
            values[4 + k] = scale * math.prod([b[f] for f in used])
            for f, others in rule:
                _add(grads[4 + k], scale * math.prod([b[g] for g in others]), base_grad[f])
        return np.array(values), np.array(grads)

    def _in_plane(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The ISF model's A with the radial ratio μ_r + μ_ρ·Σ u_s at the tip last evaluated (module docstring)."""
        mu, mr = self.params.mu_eff, (self.params.mu_radial + self.radial_rise * self._rise_sum) * self._side
        return (-mu, mr), (-mr, -mu)

    def _fz_linear(self, x: float, y: float, z: float) -> tuple[float, float, float, float]:
        values, grads = self.features(np.array([x, y, z]))
        self._rise_sum = float(values[SIDE_RISE_INDEX])
        w = self._w
        g = w @ grads
        return float(w @ values), float(g[0]), float(g[1]), float(g[2])
