"""Reading a robot's description file (`tx200-twin-robot/1`, TOML) and the facts derived from its MJCF.

`read_description` parses the file (`twin.robot.facts` says what it holds) and compiles the robot MJCF it
names once to read the actuators of the arm joints (each joint's one position actuator is its spring K_q), the
home pose from the keyframe, the joint ranges and the tool tip in the flange frame (to the nanometre), and
checks that every part the file names exists: an error names the file and what is missing.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from twin.base.jsonio import NonFiniteNumberError, finite_float, non_finite_problem
from twin.errors import ModelError
from twin.robot.facts import (
    ROBOT_FORMAT,
    TOOL_ROUNDING_DIGITS,
    Datasheet,
    DhTable,
    RobotDescription,
    StiffnessPrior,
)


def read_description(path: Path) -> RobotDescription:
    """Parse a description file and read the derived facts from its MJCF.

    Raises:
        ModelError: A malformed file (naming it and the key) or an MJCF that lacks a part the file names.
    """
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark (Windows editors) dropped
        data = tomllib.loads(text, parse_float=finite_float)
    except NonFiniteNumberError as exc:
        raise ModelError(str(non_finite_problem(path, tomllib.loads(text), exc.text))) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path}: not valid TOML: {exc}") from None
    if data.get("format") != ROBOT_FORMAT:
        raise ModelError(f"{path}: format is {data.get('format')!r}, expected {ROBOT_FORMAT!r}")
    frames, joint_table = _table(path, data, "frames"), _table(path, data, "joints")
    joints = tuple(_strings(path, joint_table, "names"))
    lost = tuple(_strings(path, joint_table, "lost_motion", default=[]))
    if not joints or len(set(joints)) != len(joints) or not set(lost) <= set(joints):
        raise ModelError(f"{path}: [joints] names {joints} must be unique, and lost_motion {lost} among them")
    mjcf = path.parent / _string(path, data, "mjcf")
    scene = path.parent / data["scene"] if "scene" in data else None
    names = {key: _string(path, frames, key) for key in
             ("flange_site", "tool_site", "ft_site", "ft_force_sensor", "home_keyframe")}
    try:
        derived = _from_mjcf(mjcf, joints, names)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from None
    calibration = data.get("calibration", {})
    stiffness_joints = tuple(_strings(path, calibration, "stiffness_joints", default=[]))
    friction_joints = tuple(_strings(path, calibration, "friction_joints", default=[]))
    if not set(stiffness_joints + friction_joints) <= set(joints):
        raise ModelError(f"{path}: [calibration] names joints that are not among {list(joints)}")
    return RobotDescription(
        name=_string(path, data, "name"), vendor=_string(path, data, "vendor"), model=_string(path, data, "model"),
        controller=_string(path, data, "controller"), language=_string(path, data, "language"), source=path,
        mjcf=mjcf, scene=scene, joints=joints, actuators=derived["actuators"], lost_motion_joints=lost,
        sheet_site=frames.get("sheet_site"), q_home_rad=derived["q_home"], q_min_rad=derived["q_min"],
        q_max_rad=derived["q_max"], tool_in_flange_m=derived["tool"],
        det_j_min_m3=float(data.get("det_j_min_m3", 0.0)), dh=_dh(path, data.get("dh"), len(joints)),
        stiffness_priors=_priors(path, data.get("stiffness_prior", []), joints),
        calibrated_stiffness=stiffness_joints, calibrated_friction=friction_joints,
        datasheet=_datasheet(path, data.get("datasheet"), len(joints)),
        controller_sign=_per_joint(path, joint_table, "controller_sign", len(joints), 1.0),
        controller_offset_rad=tuple(np.deg2rad(_per_joint(path, joint_table, "controller_offset_deg", len(joints),
                                                          0.0)).tolist()), **names,
    )


def _per_joint(path: Path, table: Mapping[str, Any], key: str, dof: int, default: float) -> tuple[float, ...]:
    """A list of one number per joint (`default` for each where the key is absent)."""
    value = table.get(key, [default] * dof)
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        out = ()
    if len(out) != dof or (key == "controller_sign" and any(v not in (-1.0, 1.0) for v in out)):
        raise ModelError(f"{path}: [joints] {key} = {value!r}: expected {dof} numbers"
                         + (" of +1 or -1" if key == "controller_sign" else ""))
    return out


def _datasheet(path: Path, table: Any, dof: int) -> Datasheet | None:
    """The `[datasheet]` table: reach_mm, payload_kg, joint_speed_deg_s (optional), source."""
    if table is None:
        return None
    try:
        reach, payload, source = float(table["reach_mm"]) / 1e3, float(table["payload_kg"]), str(table["source"])
        speeds = table.get("joint_speed_deg_s")
        speed = None if speeds is None else tuple(float(np.deg2rad(float(v))) for v in speeds)
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"{path}: [datasheet] needs reach_mm, payload_kg and source (and optional "
                         f"joint_speed_deg_s, one per joint): {exc}") from None
    if not (reach > 0 and payload > 0 and source) or (speed is not None and (len(speed) != dof or min(speed) <= 0)):
        raise ModelError(f"{path}: [datasheet] {dict(table)!r}: positive reach and payload, a source, and one "
                         f"positive speed per joint ({dof})")
    return Datasheet(reach, payload, speed, source)


def _table(path: Path, data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data.get(key)
    if not isinstance(value, Mapping):
        raise ModelError(f"{path}: missing table [{key}]")
    return value


def _string(path: Path, data: Mapping[str, Any], key: str) -> str:
    value = data.get(key)
    if not isinstance(value, str) or not value:
        raise ModelError(f"{path}: key {key!r} is {value!r}, expected a non-empty string")
    return value


def _strings(path: Path, data: Mapping[str, Any], key: str, default: Sequence[str] | None = None) -> list[str]:
    value = data.get(key, default)
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ModelError(f"{path}: key {key!r} is {value!r}, expected a list of names")
    return list(value)


def _from_mjcf(mjcf: Path, joints: tuple[str, ...], names: Mapping[str, str]) -> dict[str, Any]:
    """Actuators, home pose, ranges and tool offset, read from the compiled robot MJCF."""
    if not mjcf.is_file():
        raise ModelError(f"robot MJCF not found: {mjcf}")
    try:
        model = mujoco.MjModel.from_xml_path(str(mjcf))
    except ValueError as exc:
        raise ModelError(f"model {mjcf} does not compile: {exc}") from None
    try:
        ids = [model.joint(name).id for name in joints]
        key = model.key(names["home_keyframe"])
        flange, tool = model.site(names["flange_site"]).id, model.site(names["tool_site"]).id
        model.site(names["ft_site"])
        model.sensor(names["ft_force_sensor"])
    except KeyError as exc:
        raise ModelError(f"{mjcf} lacks {exc}, which its robot description names") from None
    actuators = []
    for j, name in zip(ids, joints, strict=True):
        driving = [a for a in range(model.nu) if model.actuator_trnid[a, 0] == j
                   and model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT]
        if len(driving) != 1:
            raise ModelError(f"{mjcf}: joint {name!r} needs exactly one position actuator (its spring K_q)")
        actuators.append(model.actuator(driving[0]).name)
    if not all(model.jnt_limited[ids]):
        bad = [n for j, n in zip(ids, joints, strict=True) if not model.jnt_limited[j]]
        raise ModelError(f"{mjcf}: joint(s) {bad} have no range; the twin needs every arm joint's limits")
    data = mujoco.MjData(model)
    qpos = model.jnt_qposadr[ids]
    data.qpos[:] = key.qpos
    mujoco.mj_kinematics(model, data)
    R_flange = data.site_xmat[flange].reshape(3, 3)
    offset = R_flange.T @ (data.site_xpos[tool] - data.site_xpos[flange])
    return {
        "actuators": tuple(actuators),
        "q_home": tuple(float(v) for v in key.qpos[qpos]),
        "q_min": tuple(float(v) for v in model.jnt_range[ids, 0]),
        "q_max": tuple(float(v) for v in model.jnt_range[ids, 1]),
        "tool": tuple(round(float(v), TOOL_ROUNDING_DIGITS) + 0.0 for v in offset),
    }


def _dh(path: Path, table: Any, dof: int) -> DhTable | None:
    if table is None:
        return None
    try:
        rows = {k: [float(v) for v in table[k]] for k in ("d_m", "a_m", "alpha_deg", "offset_deg")}
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"{path}: [dh] needs d_m, a_m, alpha_deg and offset_deg lists of numbers ({exc})") from None
    if any(len(v) != dof for v in rows.values()):
        raise ModelError(f"{path}: [dh] rows must have one entry per joint ({dof})")
    geometry = table.get("geometry", False)
    if not isinstance(geometry, bool):
        raise ModelError(f"{path}: [dh] geometry = {geometry!r}: expected true (the table sets the MJCF's link "
                         "offsets) or false (it only cross-checks them)")
    return DhTable(
        tuple(rows["d_m"]), tuple(rows["a_m"]), tuple(float(np.deg2rad(v)) for v in rows["alpha_deg"]),
        tuple(float(np.deg2rad(v)) for v in rows["offset_deg"]), str(table.get("source", "")), geometry,
    )


def _priors(path: Path, entries: Any, joints: tuple[str, ...]) -> tuple[StiffnessPrior, ...]:
    out = []
    for entry in entries:
        try:
            prior = StiffnessPrior(str(entry["joint"]), float(entry["k_nm_per_rad"]), str(entry["source"]))
        except (KeyError, TypeError, ValueError):
            raise ModelError(f"{path}: [[stiffness_prior]] {entry!r} needs joint, k_nm_per_rad and source") from None
        if prior.joint not in joints or not prior.k_nm_per_rad > 0:
            raise ModelError(f"{path}: stiffness prior {entry!r}: unknown joint or non-positive stiffness")
        out.append(prior)
    return tuple(out)
