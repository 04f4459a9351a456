"""The dynamic plant's knobs: documented defaults, neutral values, `--set NAME=VALUE` parsing.

Every physical or sensor parameter the dynamic lab can change is a knob with a unit, a default (what a
CS8C-class cell with a laser tracker and an ATI Omega160 plausibly has) and a neutral value (the knob switched
off: no backlash, no friction, perfect clocks, no registration error, no bias). Noise levels are the same in
both (noise is not an effect; a test compares gaps with it). `Knobs.as_dict()` is what `truth.json` records.

The gear stiffness is the plant's own (`plant_robots.py`); `gear_stiffness_j<i>_scale` multiply it (1: the
plant's table, not the twin's prior).

Controller and integrator ranges admit only stable runs. Measured on every shipped robot with the plant's own
K_q (full tx200 groove, kr210 pyramid, irb6640 40 mm cone, 6 mm deep; stable = no blow-up and the tip's fast
oscillation, tip minus its 50 ms moving average, below 0.2 mm rms), at every corner of the box
`servo_damping_ratio` {0.7, 2} x `servo_bandwidth_over_mode` {0.35, 1} x all six gear scales {0.2, 5, and
alternating 0.2/5 both ways}, at the 1 ms step (and, at some of those corners, `gear_armature_frac` {0.001, 1},
`timestep_s` 1e-4 and `sheet_law` 2): the tip stays within 0.4-12 mm of the command (the larger numbers the quasi-static deflection of
gears 5x softer under the forming force), fast oscillation 0.01-0.16 mm rms. Limits, with the margin found:

* `servo_damping_ratio` >= 0.7: the cascade diverges at 0.5 (irb6640 1.5 m off; the kr210 too, 2.5 m, with the
  plant's sheet as it was at the start of this measurement), rings at 0.52-0.55 (up to 7 mm, 0.25 mm rms), and
  is still stable at 0.55 at every corner above.
* `servo_bandwidth_over_mode` in [0.35, 1]: above the first mode the design rule no longer holds, and with the
  stiffest gears (scale 5) it diverges at 2 with zeta 0.7 (kr210, irb6640) and at 1 with a 2 ms step (irb6640);
  at 1 ms it is stable up to 1.4 at every corner. Below 0.35 the loop is too slow to follow the path (0.25:
  5-10 mm lag; 0.05: 30-60 mm), not unstable.
* `timestep_s` <= 1 ms: the servo's kp term and the gear springs are explicit; at 2 ms the stiffest gears with
  a fast loop diverge (scale 5, bandwidth 1: irb6640; scale 3, bandwidth 1.2), at 1.5 ms they do not.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from twin.errors import InputError
from twin.robot.description import load_robot


@dataclass(frozen=True)
class KnobSpec:
    """One knob.

    Attributes:
        default: Value of a default lab run [unit].
        neutral: Value that switches the effect off [unit].
        unit: Unit, as written after the value.
        doc: One line: what it is and why the default.
        minimum: Smallest valid value [unit].
        maximum: Largest valid value [unit].
    """

    default: float
    neutral: float
    unit: str
    doc: str
    minimum: float = 0.0
    maximum: float = math.inf


_BACKLASH_DOC = "dead band (full free play) of the gear of joint {j}: no gear torque inside it"
_STIFFNESS_DOC = (
    "scale on the plant's own gear stiffness K_q of joint {j} (plant_robots.py's table, not the twin's prior)"
)
#: Range of the gear-stiffness scales [-]: every shipped robot stays stable over it (module docstring).
GEAR_STIFFNESS_SCALE_RANGE = (0.2, 5.0)

KNOBS: dict[str, KnobSpec] = {
    # ---- plant
    **{
        f"backlash_j{j}_mrad": KnobSpec(0.0, 0.0, "mrad", _BACKLASH_DOC.format(j=j), 0.0, 10.0)
        for j in range(1, load_robot().dof + 1)
    },
    **{
        f"gear_stiffness_j{j}_scale": KnobSpec(1.0, 1.0, "-", _STIFFNESS_DOC.format(j=j), *GEAR_STIFFNESS_SCALE_RANGE)
        for j in range(1, load_robot().dof + 1)
    },
    "link_friction_scale": KnobSpec(
        1.0,
        1.0,
        "-",
        "scale on the model's joint frictionloss (link-side Coulomb friction, as the twin's)",
        0.0,
        10.0,
    ),
    "coulomb_friction_nm": KnobSpec(
        30.0, 0.0, "N·m", "Coulomb friction of each motor-side hinge (MuJoCo frictionloss)", 0.0, 1e4
    ),
    "viscous_friction_nms": KnobSpec(
        200.0, 0.0, "N·m·s/rad", "viscous friction of each motor-side hinge (joint damping)", 0.0, 1e6
    ),
    "gear_armature_frac": KnobSpec(
        0.1, 0.1, "-", "armature of the gear/link-side hinges, fraction of the motor armature", 1e-3, 1.0
    ),
    "friction_reversal_mm": KnobSpec(
        0.05,
        0.05,
        "mm",
        "tool travel over which the sheet's tangential force reverses (-1 to +1)",
        0.01,
        10.0,
    ),
    "sheet_law": KnobSpec(
        1.0,
        1.0,
        "-",
        "the plant's sheet law: 1 membrane across the tool (sheet.py), 2 contact patch (sheet_patch.py)",
        1.0,
        2.0,
    ),
    "timestep_s": KnobSpec(
        1e-3,
        1e-3,
        "s",
        "MuJoCo timestep (implicitfast); the servo runs once per step (2 ms: stiff gears diverge, knobs.py)",
        1e-4,
        1e-3,
    ),
    "sheet_grid_mm": KnobSpec(
        0.5, 0.5, "mm", "the sheet's formed-surface grid spacing, a whole number of them across its 240 mm (finer: "
        "slower; at 0.5 law 1's answer to a weave and law 2's force are not converged, docs/dynamic-plant.md)", 0.1,
        1.0
    ),
    "sheet_side_read_radii": KnobSpec(
        1.0, 1.0, "-", "law 1: how far from the tip a side's chord is read, in tool radii (at 1 a groove's read is "
        "the tool's own imprint at its equator: its answer to a weave is the grid's; at 1.1 it is not, but a tool "
        "within 0.5 mm of a groove's middle feels no wall, docs/dynamic-plant.md)", 1.0, 1.5
    ),
    "sheet_side_read_band": KnobSpec(
        0.0, 0.0, "-", "law 1: half-width of the band about that read over which a side's chord angle is averaged "
        "(9 reads), in tool radii (0: one read; at 0.1 on a 0.25 mm grid a groove's answer to a weave converges and "
        "a tool off its middle is pushed back, docs/dynamic-plant.md)", 0.0, 0.3
    ),
    # ---- controller
    "servo_bandwidth_over_mode": KnobSpec(
        0.5,
        0.5,
        "-",
        "position-loop bandwidth over the joint's first structural mode sqrt(K_q/J)/2pi (design rule; stable range, knobs.py)",
        0.35,
        1.0,
    ),
    "servo_damping_ratio": KnobSpec(
        0.8,
        0.8,
        "-",
        "damping factor of the cascade (Rockwell's default 0.8; sets the loop ratios; 0.5 diverges, knobs.py)",
        0.7,
        2.0,
    ),
    "trajectory_period_s": KnobSpec(
        0.004, 0.004, "s", "trajectory-generator cycle (CS8C: 4 ms), linear in between", 1e-3, 0.05
    ),
    "trajectory_accel_mps2": KnobSpec(
        0.5,
        0.5,
        "m/s^2",
        "acceleration/deceleration along the path into and out of a stop at each sharp corner (0: no stops)",
        0.0,
        100.0,
    ),
    "trajectory_smoothing_s": KnobSpec(
        0.02, 0.02, "s", "centred moving average of the joint set-points (jerk filter; 0: none)", 0.0, 0.5
    ),
    "correction_period_ms": KnobSpec(
        4.0, 4.0, "ms", "online: how often the controller takes a sensor correction (RSI, EGM position guidance: "
        "4; EGM path correction: 48, ABB EGM manual 3HAC073318)", 1.0, 240.0
    ),
    "correction_along_path": KnobSpec(
        1.0, 1.0, "-", "online: 1 the correction applied whole; 0 its part along the path dropped (EGM path "
        "correction applies y and z of the path frame only)", 0.0, 1.0
    ),
    # ---- tracker
    "tracker_rate_hz": KnobSpec(50.0, 50.0, "Hz", "tracker rate (thesis 3.2.1: 50 Hz)", 1.0, 1000.0),
    "tracker_noise_mm": KnobSpec(0.02, 0.02, "mm", "tracker white noise per axis (K-610 class)", 0.0, 1.0),
    "tracker_quantum_mm": KnobSpec(0.001, 0.0, "mm", "tracker resolution (0: none)", 0.0, 0.1),
    "tracker_latency_s": KnobSpec(0.002, 0.0, "s", "tracker latency (sample shows the past)", 0.0, 0.5),
    "tracker_clock_offset_s": KnobSpec(0.001, 0.0, "s", "tracker clock minus controller clock", -0.5, 0.5),
    "tracker_clock_skew_ppm": KnobSpec(20.0, 0.0, "ppm", "tracker clock-rate error", -1e4, 1e4),
    "tracker_reg_mm": KnobSpec(
        0.2, 0.0, "mm", "tracker-frame registration error: translation along (1,-1,1)/sqrt 3", -5.0, 5.0
    ),
    "tracker_reg_mrad": KnobSpec(
        1.0, 0.0, "mrad", "registration error: rotation about (1,1,1)/sqrt 3 at the sheet origin", -10.0, 10.0
    ),
    "profile_noise_mm": KnobSpec(
        0.02, 0.02, "mm", "part-profile scan white noise (after unclamping)", 0.0, 1.0
    ),
    # ---- force/torque sensor
    "ft_rate_hz": KnobSpec(30.0, 30.0, "Hz", "F/T sensor rate (thesis 3.3: 30 Hz)", 1.0, 7000.0),
    "ft_noise_n": KnobSpec(
        5.0, 5.0, "N", "F/T white noise per axis (ATI Omega160 at this range)", 0.0, 100.0
    ),
    "ft_quantum_n": KnobSpec(0.25, 0.0, "N", "F/T resolution (Omega160 SI-2500: 1/4 N)", 0.0, 10.0),
    "ft_latency_s": KnobSpec(0.005, 0.0, "s", "F/T latency", 0.0, 0.5),
    "ft_clock_offset_s": KnobSpec(-0.002, 0.0, "s", "F/T clock minus controller clock", -0.5, 0.5),
    "ft_clock_skew_ppm": KnobSpec(-30.0, 0.0, "ppm", "F/T clock-rate error", -1e4, 1e4),
    "ft_bias_n": KnobSpec(3.0, 0.0, "N", "F/T bias on each sensor axis after taring", -500.0, 500.0),
    "ft_crosstalk": KnobSpec(0.01, 0.0, "-", "F/T cross-talk: off-diagonal coupling fraction", -0.2, 0.2),
}


#: Knobs that choose among alternatives: whole numbers only.
INTEGER_KNOBS = frozenset({"sheet_law", "correction_along_path"})


class Knobs:
    """A full set of knob values [the units of `KNOBS`].

    Args:
        values: Overrides by name; unset knobs take their default (or neutral) value.
        neutral: Start from the neutral values instead of the defaults.

    Raises:
        InputError: Unknown name, non-finite or out-of-range value.
    """

    def __init__(self, values: Mapping[str, float] | None = None, *, neutral: bool = False) -> None:
        base = {name: (spec.neutral if neutral else spec.default) for name, spec in KNOBS.items()}
        for name, value in (values or {}).items():
            base[name] = _checked(name, value)
        self._values = base
        self.neutral_base = neutral

    def __getitem__(self, name: str) -> float:
        if name not in self._values:
            raise InputError(f"unknown knob {name!r}; valid: {', '.join(KNOBS)}")
        return self._values[name]

    def backlash_rad(self, dof: int) -> list[float]:
        """Dead band of the first `dof` joints [rad] (knobs `backlash_j<i>_mrad`, numbered from 1)."""
        return [1e-3 * self._values.get(f"backlash_j{j}_mrad", 0.0) for j in range(1, dof + 1)]

    def gear_stiffness_scales(self, dof: int) -> list[float]:
        """Scales on the plant's gear stiffness of the first `dof` joints [-] (knobs `gear_stiffness_j<i>_scale`)."""
        return [self._values.get(f"gear_stiffness_j{j}_scale", 1.0) for j in range(1, dof + 1)]

    def as_dict(self) -> dict[str, float]:
        """All values by name (what `truth.json` records)."""
        return dict(self._values)

    def changed(self) -> dict[str, float]:
        """Knobs that differ from their neutral value."""
        return {k: v for k, v in self._values.items() if v != KNOBS[k].neutral}


def _checked(name: str, value: float | str) -> float:
    if name not in KNOBS:
        raise InputError(f"unknown knob {name!r}; valid knobs: {', '.join(KNOBS)}")
    spec = KNOBS[name]
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise InputError(f"knob {name} = {value!r}: expected a number [{spec.unit}]") from exc
    if not math.isfinite(number) or not spec.minimum <= number <= spec.maximum:
        raise InputError(
            f"knob {name} = {value!r} [{spec.unit}]: expected a finite value in [{spec.minimum:g}, {spec.maximum:g}]"
        )
    if name in INTEGER_KNOBS and number != round(number):
        raise InputError(f"knob {name} = {value!r}: expected a whole number in [{spec.minimum:g}, {spec.maximum:g}]")
    return number


def parse_set_args(items: Iterable[str] | None, *, neutral: bool = False) -> Knobs:
    """Parse repeated `--set NAME=VALUE` options into knobs.

    Args:
        items: Strings `NAME=VALUE` (None or empty: all defaults).
        neutral: Start from the neutral values.

    Raises:
        InputError: Missing `=`, unknown name, bad or out-of-range value, a name given twice.
    """
    values: dict[str, float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(f"--set {item!r}: expected NAME=VALUE, e.g. backlash_j2_mrad=0.2")
        if name in values:
            raise InputError(f"--set {name} given twice")
        values[name] = _checked(name, text.strip())
    return Knobs(values, neutral=neutral)
