"""The effect vocabulary: every effect the twin can carry, declared once.

An effect is a named physical or measurement effect with one scalar parameter in a stated unit, a neutral value
that switches it off, the range it may take and where it acts:

| name | unit | acts on | what it does |
|---|---|---|---|
| lost_motion | mrad | robot | lost motion (half dead band) of the robot's lost-motion joints, flipping with the travel direction |
| force_scale | - | sheet | the sheet's real forces are k x the FE history (the field is fitted to the scaled history) |
| force_scale_in_plane | - | sheet | their in-plane part r x that (k r on x and y, k on z: a per-axis scale) |
| stream_time_offset | s | sensor | the force sensor's clock runs tau ahead: a sample stamped t was measured at t - tau |
| tracker_drift | mm/s | tracker | the tracker's reading drifts linearly with time along `TRACKER_DRIFT_DIRECTION` |
| tool_length_offset | mm | robot | the real tool tip lies this much further along the tool axis than nominal |
| sheet_springback | - | sheet | fraction of the formed depth the sheet recovers after unclamping |
| frame_compliance | mm/kN | sheet | the clamping frame gives along the sheet's normal by c x the axial force (`twin.sim.giving_frame`) |

The F/T sensor's and the tracker's calibration (vectors: a bias, a registration, a clock) ride along as
`Effects.instruments` (`twin.sim.instruments`), and a gear's play under the forming load (one half dead band per arm
joint, the flank set by the joint's torque) as `Effects.gear_play_rad` (`twin.sim.gear_play`). The same vocabulary
serves the quasi-static lab (its hidden truth), the twin (the effects it knows, e.g. found by the discrepancy
search), the model file (`twin.sim.model_file`) and the discrepancy families, which map onto these names
(`twin.analysis.discrepancy.families`). `step` is the finite-difference step the search refines an effect with;
`compose` says how a fitted increment adds to a known value. Names used before are still read (`RENAMED`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from twin.base.registry import Registry
from twin.errors import InputError
from twin.sim.instruments import Instruments

#: Direction of the lab's tracker drift in the sheet frame (thermal drift of the camera bar, mostly vertical).
TRACKER_DRIFT_DIRECTION = np.array([0.6, 0.0, 0.8])
#: Prefix of an increment of the instruments' calibration in `Effects.composed` (`instruments.force_bias_n`).
INSTRUMENTS = "instruments."
#: Travel after a reversal over which lost motion is taken up [m].
LOST_MOTION_TAKEUP_M = 0.002
#: Key of an increment of `Effects.gear_play_rad` in `Effects.composed` (one value per arm joint [rad]).
GEAR_PLAY = "gear_play_rad"
#: The largest half dead band of a gear's play the twin takes [rad] (a worn industrial gear shows a few mrad).
GEAR_PLAY_MAX_RAD = 0.02


#: (time since the run's start [s], simulated tip [m], value [unit]) -> reading added [m] (`EffectSpec.tracker`).
TrackerAction = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


def _tracker_drift(t_s: np.ndarray, p_sheet_m: np.ndarray, value_mm_per_s: float) -> np.ndarray:
    """The drift of `tracker_drift`: (t - t0) x rate along `TRACKER_DRIFT_DIRECTION` [m] (`p_sheet_m` unused)."""
    return np.outer(t_s, 1e-3 * value_mm_per_s * TRACKER_DRIFT_DIRECTION)


@dataclass(frozen=True)
class EffectSpec:
    """One named effect.

    Attributes:
        name: The effect's name (`--effect NAME=VALUE`, model files, verdicts).
        unit: Unit of its parameter, as written after the value.
        neutral: Value that switches it off.
        bounds: Smallest and largest valid value [unit].
        acts_on: `robot`, `sheet`, `sensor` (the F/T sensor) or `tracker`.
        description: One line in words.
        step: Finite-difference step of a refinement over replays [unit].
        compose: How an increment joins a known value: `add`, `scale` (multiplies) or `fraction` (1 - (1-a)(1-b)).
        key_suffix: Suffix of its parameter key in reports (`lost_motion_mrad`).
        simulated: It changes the twin's simulation (a new replay), not only what its sensors report.
        tracker: For an effect on the tracker's reading: (time since the run's start [s], shape (m,); simulated
            tip, sheet frame [m], shape (m, 3); value [unit]) -> what it adds to the reading [m], shape (m, 3).
            `twin.sim.measure.predict_tracker` applies it; None: the effect does not touch the tracker.
    """

    name: str
    unit: str
    neutral: float
    bounds: tuple[float, float]
    acts_on: Literal["robot", "sheet", "sensor", "tracker"]
    description: str
    step: float
    compose: Literal["add", "scale", "fraction"] = "add"
    key_suffix: str = ""
    simulated: bool = False
    tracker: TrackerAction | None = None

    @property
    def key(self) -> str:
        """The parameter key with its unit (`force_scale_ratio`)."""
        return f"{self.name}_{self.key_suffix}"


#: The effect vocabulary (`twin.base.registry.Registry`): `register_effect` adds one.
EFFECTS: Registry[EffectSpec] = Registry("effect")
for _spec in (
    EffectSpec("lost_motion", "mrad", 0.0, (-20.0, 20.0), "robot",
               "lost motion of the lost-motion joints that flips with the travel direction", 0.02,
               key_suffix="mrad", simulated=True),
    EffectSpec("force_scale", "-", 1.0, (0.0, 100.0), "sheet", "real sheet forces = k x the FE force history",
               0.02, "scale", "ratio", simulated=True),
    EffectSpec("force_scale_in_plane", "-", 1.0, (0.0, 100.0), "sheet", "real in-plane sheet forces = r x the "
               "axial force's scale (a per-axis force scale)", 0.02, "scale", "ratio", simulated=True),
    EffectSpec("stream_time_offset", "s", 0.0, (-math.inf, math.inf), "sensor",
               "force-sensor clock ahead of the tracker clock by tau", 0.005, key_suffix="s"),
    EffectSpec("tracker_drift", "mm/s", 0.0, (-math.inf, math.inf), "tracker",
               "linear drift of the tracker reading with time", 0.002, key_suffix="mm_per_s", tracker=_tracker_drift),
    EffectSpec("tool_length_offset", "mm", 0.0, (-math.inf, math.inf), "robot",
               "real tool tip further along the tool axis than nominal", 0.05, key_suffix="mm", simulated=True),
    EffectSpec("sheet_springback", "-", 0.0, (0.0, 0.99), "sheet",
               "fraction of the formed depth recovered after unclamping", 0.01, "fraction", "ratio"),
    EffectSpec("frame_compliance", "mm/kN", 0.0, (0.0, 5.0), "sheet", "the clamping frame gives along the sheet's "
               "normal by c x the axial force", 0.02, key_suffix="mm_per_kn", simulated=True),
):
    EFFECTS.register(_spec)


def register_effect(spec: EffectSpec) -> EffectSpec:
    """Add an effect to the vocabulary (a measurement effect acts through its hook, e.g. `tracker`; a family
    with `effect = spec.name` lets the discrepancy search find it)."""
    return EFFECTS.register(spec)


#: Names read before, and the effect each is now.
RENAMED: dict[str, str] = {"direction_dependent_compliance": "lost_motion", "tcp_offset": "tool_length_offset"}


def effect_name(name: str, where: str = "effect") -> str:
    """The vocabulary's name for `name`: itself, or the new name of a renamed effect (with a warning).

    Raises:
        InputError: Unknown name (the message lists the valid names and units).
    """
    if name in RENAMED:
        warnings.warn(f"{where} {name!r} is now called {RENAMED[name]!r}; read as {RENAMED[name]!r}", FutureWarning,
                      stacklevel=3)
        return RENAMED[name]
    if name not in EFFECTS:
        listing = ", ".join(f"{n} [{s.unit}]" for n, s in EFFECTS.items())
        raise InputError(f"unknown {where} {name!r}; valid: {listing}")
    return name


@dataclass(frozen=True)
class Effects:
    """A set of named effects with their parameters, in the units of `EFFECTS`.

    Attributes:
        values: Effect name -> parameter value (only effects that are switched on).
        lost_motion_takeup_m: Travel after a reversal over which lost motion is taken up [m].
        instruments: The F/T sensor's and the tracker's calibration (`twin.sim.instruments`), applied to its sensors.
        gear_play_rad: Half dead band of each arm joint's gear, the link resting on the flank its torque pushes it
            to (`twin.sim.gear_play`) [rad], one per arm joint; empty: none.
    """

    values: Mapping[str, float] = field(default_factory=dict)
    lost_motion_takeup_m: float = LOST_MOTION_TAKEUP_M
    instruments: Instruments = field(default_factory=Instruments)
    gear_play_rad: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        clean: dict[str, float] = {}
        for given, value in dict(self.values).items():
            name = effect_name(given)
            spec = EFFECTS[name]
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise InputError(f"effect {name} = {value!r}, expected a number [{spec.unit}]") from None
            if not np.isfinite(number):
                raise InputError(f"effect {name} = {value!r}, expected a finite number [{spec.unit}]")
            lo, hi = spec.bounds
            if not lo <= number <= hi:
                raise InputError(f"effect {name} = {number!r}, expected within [{lo:g}, {hi:g}] [{spec.unit}] (the "
                                 "plausible range of a real cell's effect)")
            if number != spec.neutral:
                clean[name] = number
        if not (np.isfinite(self.lost_motion_takeup_m) and self.lost_motion_takeup_m > 0):
            raise InputError(f"lost_motion_takeup_m = {self.lost_motion_takeup_m!r} m, expected > 0")
        if not isinstance(self.instruments, Instruments):
            raise InputError(f"Effects.instruments = {self.instruments!r}: expected an Instruments")
        object.__setattr__(self, "values", clean)
        object.__setattr__(self, "gear_play_rad", _gear_play(self.gear_play_rad))

    def __hash__(self) -> int:
        return hash((tuple(sorted(self.values.items())), self.lost_motion_takeup_m, self.instruments,
                     self.gear_play_rad))

    def get(self, name: str) -> float:
        """Parameter of `name`, or its neutral value when the effect is off."""
        return float(self.values.get(name, EFFECTS[name].neutral))

    def with_value(self, name: str, value: float) -> Effects:
        """A copy with one effect set (neutral value switches it off)."""
        return Effects({**self.values, name: value}, self.lost_motion_takeup_m, self.instruments, self.gear_play_rad)

    def with_values(self, values: Mapping[str, float]) -> Effects:
        """A copy with these values in place of its own (its take-up, instruments and gear play kept)."""
        return Effects(values, self.lost_motion_takeup_m, self.instruments, self.gear_play_rad)

    def with_instruments(self, instruments: Instruments) -> Effects:
        """A copy with these instruments."""
        return Effects(self.values, self.lost_motion_takeup_m, instruments, self.gear_play_rad)

    def composed(self, increments: Mapping[str, Any]) -> Effects:
        """These effects with fitted increments joined by each effect's `compose` rule; keys `instruments.FIELD` add
        to the instruments' calibration (`Instruments.plus`), `GEAR_PLAY` (per arm joint [rad]) to the gear play."""
        values = dict(self.values)
        inst = {k.removeprefix(INSTRUMENTS): v for k, v in increments.items() if k.startswith(INSTRUMENTS)}
        play = self.gear_play_rad
        if GEAR_PLAY in increments:
            inc = np.asarray(increments[GEAR_PLAY], dtype=float)
            if play and len(play) != len(inc):
                raise InputError(f"gear play increment {inc.tolist()} rad: {len(inc)} joints, the twin's {len(play)}")
            play = tuple(float(v) for v in (np.asarray(play or np.zeros(len(inc))) + inc))
        for name, inc in increments.items():
            if name.startswith(INSTRUMENTS) or name == GEAR_PLAY:
                continue
            rule = EFFECTS[name].compose
            if rule == "scale":
                values[name] = self.get(name) * inc
            elif rule == "fraction":
                values[name] = 1.0 - (1.0 - self.get(name)) * (1.0 - inc)
            else:
                values[name] = self.get(name) + inc
        return Effects(values, self.lost_motion_takeup_m, self.instruments.plus(inst) if inst else self.instruments,
                       play)

    def simulated(self) -> Effects:
        """The effects that change the twin's simulation (`EffectSpec.simulated`), the others off; gear play kept."""
        return Effects({n: v for n, v in self.values.items() if EFFECTS[n].simulated}, self.lost_motion_takeup_m,
                       gear_play_rad=self.gear_play_rad)

    @property
    def lost_motion_rad(self) -> float:
        """Half of the lost-motion joints' dead band [rad]."""
        return 1e-3 * self.get("lost_motion")

    @property
    def tool_offset_m(self) -> float:
        """Real tool tip minus nominal, along the tool axis [m]."""
        return 1e-3 * self.get("tool_length_offset")

    @property
    def force_scale(self) -> float:
        """Real sheet forces over the FE history's [-]."""
        return self.get("force_scale")

    @property
    def changes_model(self) -> bool:
        """Whether the compiled robot differs from the nominal one (lost-motion hinges, another tool length)."""
        return self.lost_motion_rad != 0.0 or self.tool_offset_m != 0.0

    @property
    def stream_time_offset_s(self) -> float:
        """Force-sensor clock offset [s]."""
        return self.get("stream_time_offset")

    @property
    def tracker_drift_m_per_s(self) -> np.ndarray:
        """Tracker drift velocity in the sheet frame [m/s], shape (3,)."""
        return 1e-3 * self.get("tracker_drift") * TRACKER_DRIFT_DIRECTION

    @property
    def springback_ratio(self) -> float:
        """Fraction of the formed depth recovered after unclamping [-]."""
        return self.get("sheet_springback")

    def named_parameters(self) -> dict[str, dict[str, float | list[float]]]:
        """Effect name -> {parameter key with unit: value}, for JSON reports (the gear play as `gear_play`:
        {`gear_play_mrad`: one per arm joint})."""
        named: dict[str, dict[str, float | list[float]]] = {
            name: {EFFECTS[name].key: value} for name, value in self.values.items()}
        if self.gear_play_rad:
            named["gear_play"] = {"gear_play_mrad": [1e3 * b for b in self.gear_play_rad]}
        return named


def _gear_play(values: Any) -> tuple[float, ...]:
    """`Effects.gear_play_rad` checked (finite, |b| <= GEAR_PLAY_MAX_RAD) [rad]; () where no joint has play.

    Raises:
        InputError: Not numbers, or a value out of range (naming the joint and the value in mrad).
    """
    try:
        play = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise InputError(f"gear play = {values!r}: expected one number per arm joint [rad]") from None
    for i, b in enumerate(play):
        if not (math.isfinite(b) and abs(b) <= GEAR_PLAY_MAX_RAD):
            raise InputError(f"gear play of arm joint {i + 1} = {1e3 * b:g} mrad, expected a finite half dead band "
                             f"within +/-{1e3 * GEAR_PLAY_MAX_RAD:g} mrad")
    return play if any(play) else ()


def parse_effect_args(items: list[str] | None) -> Effects:
    """Parse CLI `--effect NAME=VALUE` items.

    Raises:
        InputError: Malformed item, unknown name or bad value (the message lists the valid names and units).
    """
    values: dict[str, float] = {}
    listing = ", ".join(f"{n} [{s.unit}]" for n, s in EFFECTS.items())
    for item in items or []:
        given, sep, text = item.partition("=")
        if not sep:
            raise InputError(f"--effect {item!r}: expected NAME=VALUE, e.g. force_scale=0.5; valid: {listing}")
        try:
            name = effect_name(given, "--effect")
        except InputError:
            raise InputError(f"--effect {item!r}: unknown effect {given!r}; valid: {listing}") from None
        if name in values:
            raise InputError(f"--effect {name} given twice ({item!r} after {name}={values[name]:g}): give each "
                             "effect once")
        try:
            values[name] = float(text)
        except ValueError:
            raise InputError(
                f"--effect {item!r}: {text!r} is not a number [{EFFECTS[name].unit}]; valid: {listing}"
            ) from None
        try:
            Effects({name: values[name]})
        except InputError as exc:
            raise InputError(f"--effect {item}: {exc}") from None
    return Effects(values)
