"""The twin model file: a `TwinSpec` saved as JSON (`tx200-twin-model/2`), and read back.

What `discrepancy --model-out` and `identify --write-model` write and `replay`, `compensate` and `discrepancy`
read with `--model`:

    {"format": "tx200-twin-model/2", "robot": "tx200",
     "process": {"material": ..., "tensile_strength_mpa": ..., "thickness_mm": ..., "tool_radius_mm": ...,
                 "tool_friction": ..., "friction_reversal_mm": ..., "force_model": "table",
                 "force_fit": {"scale": 1.25, ...} (force-model constants learned by `identify --forces`),
                 "history": null | {"file": ..., "symmetry": "half", "unchecked_symmetry": false}},
     "placement": {"origin_base_mm": null, "yaw_deg": 0.0},
     "effects": {"lost_motion": 0.15}, "units": {"lost_motion": "mrad"}, "lost_motion_takeup_mm": 2.0,
     "joint_stiffness_nm_per_rad": [...], "joint_friction_nm": [...],
     "servo": {"compliance_rad_per_nm": [...], "time_constant_s": ...} (learned by `learn`),
     "dynamic_servo": {"bandwidth_over_mode": ..., "damping_ratio": ..., "delay_s": ..., "feedforward": ...,
                      "load_feedforward": ...}
             (the dynamic mode's joint servo, `learn --dynamic`; absent: none),
     "tool": {"length_mm": 300.0, "mass_kg": 8.0, "cog_mm": [0, 0, 150], "bending_stiffness_n_per_mm": 450.0}
             (the declared tool, `TwinSpec.tool`, its bending at the tip optional; absent: the robot model's own),
     "instruments": {"force_bias_n": [40, 0, -30], "tracker_shift_mm": [...], ...} (the F/T sensor's and the
             tracker's calibration found by `discrepancy`, `twin.sim.instruments`; fields left out are neutral),
     "gear_play_mrad": [0, 0, 0.4, 0, 0, 0] (a gear's play under the forming load, one half dead band per arm
             joint, `Effects.gear_play_rad`, found by `discrepancy`; absent: none),
     "note": "..."}

Every key but `format` may be left out (the default cell's value); a `material` of the library
(`tx200-twin materials`) without `tensile_strength_mpa` takes the library's R_m, any other material (a user's)
needs it. The first format, `tx200-twin-model/1`
(effects and K_q only), is still read; effects under a name used before are read under the new one, with a
warning naming it (`twin.sim.effects.RENAMED`). A history file is named relative to the model file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from twin.base.jsonio import read_json, write_json
from twin.errors import DataFileError, InputError, ModelError
from twin.process.description import Process, check_plausible
from twin.process.fe.load import load_force_history
from twin.process.process_file import RECORD_KEYS, process_from_record
from twin.process.toolpath.placement import Placement
from twin.robot.description import load_robot, shipped_robots
from twin.robot.tool import ToolSpec
from twin.sim.dynamic_servo import ServoModel
from twin.sim.effects import EFFECTS, LOST_MOTION_TAKEUP_M, Effects
from twin.sim.instruments import Instruments
from twin.sim.servo import ServoTransient
from twin.sim.spec import TwinSpec

MODEL_FORMAT = "tx200-twin-model/2"
READABLE_FORMATS = ("tx200-twin-model/1", MODEL_FORMAT)
#: The keys a model file takes (`model_payload` writes them; `units` and `note` are for the reader).
MODEL_KEYS = ("format", "robot", "process", "placement", "effects", "units", "lost_motion_takeup_mm",
              "joint_stiffness_nm_per_rad", "joint_friction_nm", "servo", "tool", "note", "floor", "instruments",
              "gear_play_mrad", "dynamic_servo")
#: The keys of its `dynamic_servo` object (`twin.sim.dynamic_servo.ServoModel`'s fields).
DYNAMIC_SERVO_KEYS = tuple(f.name for f in fields(ServoModel))
#: The keys a model file written before `load_feedforward` carries (read with it at 1).
LEGACY_SERVO_KEYS = tuple(key for key in DYNAMIC_SERVO_KEYS if key != "load_feedforward")
#: The keys of its `process` object and of `process.history`.
PROCESS_KEYS = (*RECORD_KEYS, "friction_reversal_mm", "force_model", "force_fit", "history")
HISTORY_KEYS = ("file", "symmetry", "unchecked_symmetry")
#: The keys of its `tool` object (the cell file's `[tool]`, its radius aside: that is the process's).
TOOL_KEYS = ("length_mm", "mass_kg", "cog_mm", "bending_stiffness_n_per_mm")


def model_payload(spec: TwinSpec, note: str = "") -> dict[str, Any]:
    """The JSON document of `spec` (module docstring)."""
    process, history = spec.process, spec.process.history
    robot = spec.robot.name if shipped_robots().get(spec.robot.name) == spec.robot.source else str(spec.robot.source)
    payload: dict[str, Any] = {
        "format": MODEL_FORMAT,
        "robot": robot,
        "process": {
            "material": process.material,
            "tensile_strength_mpa": process.tensile_strength_mpa,
            "thickness_mm": _mm(process.thickness_m),
            "tool_radius_mm": _mm(process.tool_radius_m),
            "tool_friction": process.tool_friction,
            "friction_reversal_mm": None if process.friction_reversal_m is None else _mm(process.friction_reversal_m),
            "force_model": process.force_model,
            "force_fit": dict(process.force_fit),
            "history": None if history is None else {
                "file": str(history.source), "symmetry": history.symmetry,
                "unchecked_symmetry": history.symmetry != history.column_symmetry,
            },
        },
        "placement": spec.placement.to_json(),
        "effects": dict(spec.effects.values),
        "units": {name: EFFECTS[name].unit for name in spec.effects.values},
        "lost_motion_takeup_mm": _mm(spec.effects.lost_motion_takeup_m),
        "note": note,
    }
    if spec.joint_stiffness is not None:
        payload["joint_stiffness_nm_per_rad"] = spec.joint_stiffness
    if spec.joint_friction is not None:
        payload["joint_friction_nm"] = spec.joint_friction
    if spec.servo is not None:
        payload["servo"] = {"compliance_rad_per_nm": list(spec.servo.compliance_rad_per_nm),
                            "time_constant_s": spec.servo.time_constant_s}
    if spec.tool is not None:
        payload["tool"] = spec.tool.to_json()
    if spec.dynamic_servo is not None:
        payload["dynamic_servo"] = spec.dynamic_servo.to_json()
    if not spec.effects.instruments.neutral:
        payload["instruments"] = spec.effects.instruments.changed()
    if spec.effects.gear_play_rad:
        payload["gear_play_mrad"] = [1e3 * b for b in spec.effects.gear_play_rad]
    return payload


def write_model_file(
    path: str | Path, spec: TwinSpec, *, note: str = "", protect: Sequence[str | Path] = (),
    floor: Mapping[str, Any] | None = None,
) -> Path:
    """Write `spec` as a twin model file (atomic); never into or over an input it was made from (`protect`).
    `floor`: what the learned cell leaves on its own clean runs (`twin.analysis.discrepancy.floor.Floor.to_json`),
    recorded beside the twin for `discrepancy` (`read_floor_entry`)."""
    for other in protect:
        if Path(path).resolve() == Path(other).resolve() or Path(path).resolve().is_relative_to(
            Path(other).resolve()
        ):
            raise InputError(f"refusing to write the model file {path} into/over the input {other}")
    payload = model_payload(spec, note)
    return write_json(path, payload if floor is None else {**payload, "floor": dict(floor)})


def read_floor_entry(path: str | Path) -> Any:
    """A model file's recorded floor (`write_model_file`'s `floor`), as written; None where it has none."""
    return read_json(Path(path)).get("floor")


def read_model_file(path: str | Path) -> TwinSpec:
    """Read a twin model file (`write_model_file`, the first format, or one written by hand).

    Raises:
        DataFileError: Wrong format tag, unknown effects, bad values or a missing history file (naming the file).
    """
    path = Path(path)
    payload = read_json(path)
    if payload.get("format") not in READABLE_FORMATS:
        raise DataFileError(path, f"format is {payload.get('format')!r}, expected one of {list(READABLE_FORMATS)}")
    _known_keys(path, payload, "", MODEL_KEYS)
    try:
        takeup_mm = payload.get("lost_motion_takeup_mm")
        takeup_m = LOST_MOTION_TAKEUP_M if takeup_mm is None else float(takeup_mm) / 1e3
        instruments = payload.get("instruments")
        effects = Effects(dict(payload.get("effects", {})), takeup_m,
                          Instruments() if instruments is None else Instruments.from_json(instruments, "the model"),
                          _gear_play(path, payload.get("gear_play_mrad")))
        return TwinSpec(
            robot=load_robot(payload.get("robot")),
            process=_process(path, payload.get("process")),
            placement=Placement.from_json(payload.get("placement"), path),
            effects=effects,
            joint_stiffness_nm_per_rad=payload.get("joint_stiffness_nm_per_rad"),
            joint_friction_nm=payload.get("joint_friction_nm"),
            servo=_servo(path, payload.get("servo")),
            tool=_tool(path, payload.get("tool")),
            dynamic_servo=_dynamic_servo(path, payload.get("dynamic_servo")),
        )
    except DataFileError:
        raise
    except (InputError, ModelError, TypeError, ValueError) as exc:
        raise DataFileError(path, f"bad model: {exc}") from None


def _process(path: Path, entry: Any) -> Process:
    """The `process` entry (None: the default process)."""
    if entry is None:
        return Process()
    if not isinstance(entry, Mapping):
        raise DataFileError(path, f"process = {entry!r}: expected an object")
    _known_keys(path, entry, "process.", PROCESS_KEYS)
    defaults = Process()

    def metres(key: str, default: float | None) -> float | None:
        if key not in entry:
            return default
        return None if entry[key] is None else float(entry[key]) / 1e3

    history = entry.get("history")
    loaded = None
    if history is not None:
        if not isinstance(history, Mapping):
            raise DataFileError(path, f"process.history = {history!r}: expected null or an object with {list(HISTORY_KEYS)}")
        _known_keys(path, history, "process.history.", HISTORY_KEYS)
        file = Path(str(history.get("file", "")))
        file = file if file.is_absolute() else path.parent / file
        loaded = load_force_history(
            file, symmetry=str(history.get("symmetry")), trust_columns=not history.get("unchecked_symmetry", False)
        )
    recorded = process_from_record({k: entry[k] for k in RECORD_KEYS if k in entry}, defaults)
    force_model = str(entry.get("force_model", defaults.force_model))
    force_fit = _force_fit(path, entry.get("force_fit"))
    _check_constants(path, force_model, dict(force_fit))
    return replace(
        recorded,
        friction_reversal_m=metres("friction_reversal_mm", defaults.friction_reversal_m),
        force_model=force_model,
        history=loaded,
        force_fit=force_fit,
    )


def _check_constants(path: Path, force_model: str, fit: Mapping[str, float]) -> None:
    """Refuse a force model's constants it does not take, and a learned model without its weights (it would be
    read as another model, or with its terms at zero, in silence)."""
    from twin.process.force.isf_params import IsfForceParams
    from twin.process.force.learned import RADIAL_RISE_KEY, REQUIRED_WEIGHT_KEYS, WEIGHT_KEYS

    isf = {f.name for f in fields(IsfForceParams)}
    from twin.process.force.span import SPAN_KEYS

    takes = {"isf": isf, "learned": isf | set(WEIGHT_KEYS) | {RADIAL_RISE_KEY, *SPAN_KEYS}}.get(force_model)
    if takes is not None and set(fit) - takes:
        raise DataFileError(path, f"process.force_fit has {sorted(set(fit) - takes)}, which the {force_model!r} force "
                            f"model does not take; it takes {sorted(takes)}")
    missing = [key for key in REQUIRED_WEIGHT_KEYS if key not in fit]
    if force_model == "learned" and missing:
        raise DataFileError(path, f"process.force_model = 'learned' without its learned weights: process.force_fit "
                            f"lacks {missing} (a model file `learn` writes has them)")


def _known_keys(path: Path, entry: Mapping[str, Any], prefix: str, keys: Sequence[str]) -> None:
    """Refuse a key `entry` does not take (a misspelling would otherwise be read as the default), naming it and
    the keys it takes."""
    unknown = [key for key in entry if key not in keys]
    if unknown:
        raise DataFileError(path, f"unknown key(s) {[prefix + str(k) for k in unknown]}; "
                            f"{'a model file' if not prefix else prefix.rstrip('.')} takes {list(keys)}")


def _gear_play(path: Path, entry: Any) -> tuple[float, ...]:
    """The `gear_play_mrad` list as `Effects.gear_play_rad` [rad] (None: no play; its range is the effects')."""
    if entry is None:
        return ()
    if not isinstance(entry, Sequence) or isinstance(entry, str) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in entry
    ):
        raise DataFileError(path, f"gear_play_mrad = {entry!r}: expected a list of numbers [mrad], one for each arm joint of the robot")
    return tuple(float(v) / 1e3 for v in entry)


def _servo(path: Path, entry: Any) -> ServoTransient | None:
    """The `servo` object (`twin.sim.servo`), or None."""
    if entry is None:
        return None
    if not isinstance(entry, Mapping) or set(entry) != {"compliance_rad_per_nm", "time_constant_s"}:
        raise DataFileError(path, f"servo = {entry!r}: expected an object with compliance_rad_per_nm (a list, one "
                            "per arm joint) and time_constant_s")
    return ServoTransient(tuple(entry["compliance_rad_per_nm"]), float(entry["time_constant_s"]))


def _dynamic_servo(path: Path, entry: Any) -> ServoModel | None:
    """The `dynamic_servo` object (`twin.sim.dynamic.ServoModel`), or None."""
    if entry is None:
        return None
    if not isinstance(entry, Mapping) or set(entry) not in (set(DYNAMIC_SERVO_KEYS), set(LEGACY_SERVO_KEYS)) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in entry.values()
    ):
        raise DataFileError(path, f"dynamic_servo = {entry!r}: expected an object with the numbers "
                            f"{', '.join(DYNAMIC_SERVO_KEYS)}")
    # fitted before `load_feedforward` existed: with the twin's load fed forward, as the loop then was
    return ServoModel(**{"load_feedforward": 1.0, **{key: float(value) for key, value in entry.items()}})


def _tool(path: Path, entry: Any) -> ToolSpec | None:
    """The `tool` object (`TwinSpec.tool`), or None."""
    if entry is None:
        return None
    if not isinstance(entry, Mapping) or "length_mm" not in entry:
        raise DataFileError(path, f"tool = {entry!r}: expected an object with length_mm (and mass_kg, cog_mm)")
    _known_keys(path, entry, "tool.", TOOL_KEYS)
    length = check_plausible("tool_length_m", float(entry["length_mm"]) / 1e3, f"{path}: tool.length_mm")
    mass = entry.get("mass_kg")
    if mass is not None:
        check_plausible("tool_mass_kg", float(mass), f"{path}: tool.mass_kg")
    cog = entry.get("cog_mm")
    if cog is not None and (not isinstance(cog, Sequence) or isinstance(cog, str)):
        raise DataFileError(path, f"tool.cog_mm = {cog!r}: expected three numbers [mm]")
    bending = entry.get("bending_stiffness_n_per_mm")
    if bending is not None and (isinstance(bending, bool) or not isinstance(bending, int | float)
                                or not 0.0 < bending < math.inf):
        raise DataFileError(path, f"tool.bending_stiffness_n_per_mm = {bending!r}: expected a positive stiffness "
                            "[N/mm]")
    return ToolSpec.make(length, mass, None if cog is None else [float(v) / 1e3 for v in cog],
                         None if bending is None else 1e3 * float(bending))


def _force_fit(path: Path, entry: Any) -> tuple[tuple[str, float], ...]:
    """The `process.force_fit` object (name -> value), as `Process.force_fit`."""
    if entry is None:
        return ()
    if not isinstance(entry, Mapping) or not all(
        isinstance(k, str) and isinstance(v, int | float) and not isinstance(v, bool) for k, v in entry.items()
    ):
        raise DataFileError(path, f"process.force_fit = {entry!r}: expected an object of name: number")
    return tuple((k, float(v)) for k, v in entry.items())


def _mm(length_m: float) -> float:
    """A length for the file [mm], rounded to 1e-12 mm so that reading it back (/ 1e3) gives the same metres."""
    return round(1e3 * length_m, 12)
