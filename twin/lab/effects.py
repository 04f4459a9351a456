"""Named effects: what the virtual lab hides in its runs and what the discrepancy workflow adds to the twin.

Every effect has one scalar parameter in a documented unit (the unit of `--effect NAME=VALUE`) and a
neutral value that switches it off:

| name | parameter [unit] | what it does |
|---|---|---|
| direction_dependent_compliance | lost motion of joints 2-3 [mrad] | link-side hinge offset that flips with travel direction (`twin.robot.model`) |
| force_scale | k [-] | the sheet's real forces are k x the FE history (the field is fitted to the scaled history) |
| stream_time_offset | tau [s] | the force sensor's clock runs tau ahead: a sample stamped t was measured at t - tau |
| tracker_drift | rate [mm/s] | the tracker's reading drifts linearly with time along TRACKER_DRIFT_DIRECTION |
| tcp_offset | tool-length error [mm] | the real tool tip lies this much further along the tool axis than nominal |
| sheet_springback | ratio [-] | fraction of the formed depth the sheet recovers after unclamping |

A twin "model file" (JSON, `tx200-twin-model/1`) stores a set of named effects (and optionally the joint
stiffness); `replay --model` and `compensate --model` read it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import read_json, write_json
from twin.errors import DataFileError, InputError
from twin.robot.model import RobotEffects

MODEL_FORMAT = "tx200-twin-model/1"
# Direction of the lab's tracker drift in the sheet frame (thermal drift of the camera bar, mostly vertical).
TRACKER_DRIFT_DIRECTION = np.array([0.6, 0.0, 0.8])


@dataclass(frozen=True)
class EffectSpec:
    """One named effect: its parameter unit, neutral value and meaning."""

    name: str
    unit: str
    neutral: float
    description: str


EFFECTS: dict[str, EffectSpec] = {
    spec.name: spec
    for spec in (
        EffectSpec(
            "direction_dependent_compliance",
            "mrad",
            0.0,
            "lost motion of joints 2-3 that flips with travel direction",
        ),
        EffectSpec("force_scale", "-", 1.0, "real sheet forces = k x the FE force history"),
        EffectSpec("stream_time_offset", "s", 0.0, "force-sensor clock ahead of the tracker clock by tau"),
        EffectSpec("tracker_drift", "mm/s", 0.0, "linear drift of the tracker reading with time"),
        EffectSpec("tcp_offset", "mm", 0.0, "real tool tip further along the tool axis than nominal"),
        EffectSpec("sheet_springback", "-", 0.0, "fraction of the formed depth recovered after unclamping"),
    )
}


def _unit_key(name: str) -> str:
    unit = EFFECTS[name].unit
    suffix = {"mrad": "mrad", "-": "ratio", "s": "s", "mm/s": "mm_per_s", "mm": "mm"}[unit]
    return f"{name}_{suffix}"


@dataclass(frozen=True)
class Effects:
    """A set of named effects with their parameters, in the units of `EFFECTS`.

    Attributes:
        values: Effect name -> parameter value (only effects that are switched on).
        lost_motion_takeup_m: Travel after a reversal over which lost motion is taken up [m].
    """

    values: Mapping[str, float] = field(default_factory=dict)
    lost_motion_takeup_m: float = 0.002

    def __post_init__(self) -> None:
        clean: dict[str, float] = {}
        for name, value in dict(self.values).items():
            if name not in EFFECTS:
                raise InputError(f"unknown effect {name!r}; valid effects: {sorted(EFFECTS)}")
            number = float(value)
            if not np.isfinite(number):
                raise InputError(
                    f"effect {name} = {value!r}, expected a finite number [{EFFECTS[name].unit}]"
                )
            if name in ("force_scale", "sheet_springback") and number < 0:
                raise InputError(f"effect {name} = {number!r}, expected >= 0")
            if name == "sheet_springback" and number >= 1:
                raise InputError(f"effect sheet_springback = {number!r}, expected a fraction in [0, 1)")
            if number != EFFECTS[name].neutral:
                clean[name] = number
        object.__setattr__(self, "values", clean)

    def get(self, name: str) -> float:
        """Parameter of `name`, or its neutral value when the effect is off."""
        return float(self.values.get(name, EFFECTS[name].neutral))

    def with_value(self, name: str, value: float) -> Effects:
        """A copy with one effect set (neutral value switches it off)."""
        return Effects({**self.values, name: value}, self.lost_motion_takeup_m)

    @property
    def robot(self) -> RobotEffects:
        """The robot-side part, in SI units, for `twin.robot.model.build_model` and the simulator."""
        return RobotEffects(
            lost_motion_rad=1e-3 * self.get("direction_dependent_compliance"),
            lost_motion_takeup_m=self.lost_motion_takeup_m,
            tcp_offset_m=1e-3 * self.get("tcp_offset"),
            force_scale=self.get("force_scale"),
        )

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

    def named_parameters(self) -> dict[str, dict[str, float]]:
        """Effect name -> {parameter key with unit: value}, for JSON reports."""
        return {name: {_unit_key(name): value} for name, value in self.values.items()}


def parse_effect_args(items: list[str] | None) -> Effects:
    """Parse CLI `--effect NAME=VALUE` items.

    Raises:
        InputError: Malformed item, unknown name or bad value (the message lists the valid names and units).
    """
    values: dict[str, float] = {}
    listing = ", ".join(f"{n} [{s.unit}]" for n, s in EFFECTS.items())
    for item in items or []:
        name, sep, text = item.partition("=")
        if not sep:
            raise InputError(
                f"--effect {item!r}: expected NAME=VALUE, e.g. force_scale=0.5; valid: {listing}"
            )
        if name not in EFFECTS:
            raise InputError(f"--effect {item!r}: unknown effect {name!r}; valid: {listing}")
        try:
            values[name] = float(text)
        except ValueError:
            raise InputError(
                f"--effect {item!r}: {text!r} is not a number [{EFFECTS[name].unit}]; valid: {listing}"
            ) from None
    return Effects(values)


def write_model_file(
    path: str | Path,
    effects: Effects,
    *,
    joint_stiffness_nm_per_rad: np.ndarray | None = None,
    note: str = "",
    protect: Sequence[str | Path] = (),
) -> Path:
    """Write a twin model file (JSON) holding named effects and optionally K_q."""
    payload: dict[str, Any] = {
        "format": MODEL_FORMAT,
        "effects": dict(effects.values),
        "units": {name: EFFECTS[name].unit for name in effects.values},
        "note": note,
    }
    if joint_stiffness_nm_per_rad is not None:
        payload["joint_stiffness_nm_per_rad"] = np.asarray(joint_stiffness_nm_per_rad, dtype=float)
    for other in protect:  # never write into a run (or over an input) the model was made from
        if Path(path).resolve() == Path(other).resolve() or Path(path).resolve().is_relative_to(
            Path(other).resolve()
        ):
            raise InputError(f"refusing to write the model file {path} into/over the input {other}")
    return write_json(path, payload)


def read_model_file(path: str | Path) -> tuple[Effects, np.ndarray | None]:
    """Read a twin model file written by `write_model_file` (or by hand).

    Returns:
        The effects and K_q [N·m/rad] (None when the file does not set it).

    Raises:
        DataFileError: Wrong format tag, unknown effects or bad values (naming the file).
    """
    payload = read_json(path)
    if payload.get("format") != MODEL_FORMAT:
        raise DataFileError(path, f"format is {payload.get('format')!r}, expected {MODEL_FORMAT!r}")
    try:
        effects = Effects(dict(payload.get("effects", {})))
    except (InputError, TypeError, ValueError) as exc:
        raise DataFileError(path, f"bad effects: {exc}") from None
    stiffness = payload.get("joint_stiffness_nm_per_rad")
    if stiffness is None:
        return effects, None
    k = np.asarray(stiffness, dtype=float)
    if k.shape != (6,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise DataFileError(path, f"joint_stiffness_nm_per_rad = {stiffness!r}, expected 6 positive numbers")
    return effects, k
