"""A robot as data: what the twin needs to know of a robot, read from its model folder.

A robot is an MJCF (robot only, in the menagerie manner: joints with ranges, position actuators as the joint
springs K_q, joint friction, a `home` keyframe, a flange site, a tool-tip site, an F/T site and force sensor)
and a description file beside it (`models/tx200.toml`, format `tx200-twin-robot/1`) that names those parts and
states what an MJCF cannot hold: vendor, controller and its language, the lost-motion joints, the DH table of
the independent kinematics check, joint-stiffness priors with their sources, the near-singularity threshold and
the scene site of the default sheet placement. Every fact is stated once: the home pose is the keyframe's, the
tool length the flange-to-tool-site distance, the joint ranges the MJCF's, all read from the compiled model.

Everything outside `twin.robot` asks a `RobotDescription` for joint names, counts, addresses and the tool; no
other module names a joint or a TX200 number.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np

from twin.base.resources import models_dir
from twin.errors import InputError, ModelError

ROBOT_FORMAT = "tx200-twin-robot/1"
DEFAULT_ROBOT = "tx200"
#: Rounding of the tool offset read from the MJCF [m]: the sites' float sum, to the nanometre.
TOOL_ROUNDING_DIGITS = 9


@dataclass(frozen=True)
class DhTable:
    """Denavit-Hartenberg parameters, A_i = Rot_z(θ_i) Trans_z(d_i) Trans_x(a_i) Rot_x(α_i), θ_i = q_i + offset_i.

    Attributes:
        d_m, a_m: Offsets [m], one per joint.
        alpha_rad, offset_rad: Twists and joint-angle offsets [rad], one per joint.
        source: Where the table comes from.
    """

    d_m: tuple[float, ...]
    a_m: tuple[float, ...]
    alpha_rad: tuple[float, ...]
    offset_rad: tuple[float, ...]
    source: str


@dataclass(frozen=True)
class StiffnessPrior:
    """A joint stiffness known before calibration, with its source.

    Attributes:
        joint: Joint name.
        k_nm_per_rad: Stiffness [N·m/rad].
        source: Paper, table or reasoning it comes from.
    """

    joint: str
    k_nm_per_rad: float
    source: str


class JointAddresses(NamedTuple):
    """Where a robot's arm joints live in one compiled model (arrays of shape (dof,))."""

    qpos: np.ndarray
    dof: np.ndarray
    joint: np.ndarray
    actuator: np.ndarray


@dataclass(frozen=True)
class RobotDescription:
    """One robot: its files, parts and the facts the twin needs (module docstring).

    Attributes:
        name: Registry name (`tx200`).
        vendor, model, controller: Maker, model and controller, in words.
        language: The controller's program language (`VAL3`, `KRL`, `RAPID`).
        source: The description file.
        mjcf: Robot-only MJCF.
        scene: Cell scene that includes the robot, or None.
        joints: Arm joint names, base to flange.
        actuators: Position actuator (joint spring) of each arm joint.
        lost_motion_joints: Joints whose gear play the lost-motion effect acts on.
        flange_site, tool_site, ft_site, ft_force_sensor, home_keyframe: MJCF names.
        sheet_site: Scene site at the default sheet origin (yaw 0), or None.
        q_home_rad: Home pose (the keyframe's) [rad].
        q_min_rad, q_max_rad: Joint ranges [rad].
        tool_in_flange_m: Tool tip in the flange frame [m] (from the MJCF's sites, to the nanometre).
        det_j_min_m3: |det J| below which an IK solution counts as near-singular [m^3].
        dh: DH table for the independent kinematics check, or None.
        stiffness_priors: Joint-stiffness priors with sources.
        calibrated_stiffness: Joints whose K_q a calibration to measurements fits.
        calibrated_friction: Joints whose friction a calibration fits.
    """

    name: str
    vendor: str
    model: str
    controller: str
    language: str
    source: Path
    mjcf: Path
    scene: Path | None
    joints: tuple[str, ...]
    actuators: tuple[str, ...]
    lost_motion_joints: tuple[str, ...]
    flange_site: str
    tool_site: str
    ft_site: str
    ft_force_sensor: str
    home_keyframe: str
    sheet_site: str | None
    q_home_rad: tuple[float, ...]
    q_min_rad: tuple[float, ...]
    q_max_rad: tuple[float, ...]
    tool_in_flange_m: tuple[float, float, float]
    det_j_min_m3: float
    dh: DhTable | None
    stiffness_priors: tuple[StiffnessPrior, ...]
    calibrated_stiffness: tuple[str, ...] = ()
    calibrated_friction: tuple[str, ...] = ()

    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return len(self.joints)

    @property
    def tool_length_m(self) -> float:
        """Flange to tool tip [m]."""
        return float(np.linalg.norm(self.tool_in_flange_m))

    @property
    def q_home(self) -> np.ndarray:
        """Home pose [rad], shape (dof,) (a new array)."""
        return np.array(self.q_home_rad)

    def model_path(self, scene: bool = True) -> Path:
        """The scene MJCF (default; the robot MJCF when the robot has no scene) or the robot-only MJCF."""
        return self.scene if scene and self.scene is not None else self.mjcf

    def addresses(self, model: mujoco.MjModel) -> JointAddresses:
        """qpos, dof, joint and actuator indices of the arm joints in `model`.

        Raises:
            ModelError: `model` lacks one of the joints or actuators (names it and what was expected).
        """
        try:
            joints = [model.joint(name).id for name in self.joints]
            actuators = [model.actuator(name).id for name in self.actuators]
        except KeyError as exc:
            raise ModelError(
                f"model lacks {exc} of robot {self.name!r}; expected joints {list(self.joints)} and actuators "
                f"{list(self.actuators)}"
            ) from None
        ids = np.array(joints, dtype=int)
        return JointAddresses(
            model.jnt_qposadr[ids].copy(), model.jnt_dofadr[ids].copy(), ids, np.array(actuators, dtype=int)
        )

    def joint_vector(self, values: Any, what: str, unit: str, *, positive: bool = False,
                     nonnegative: bool = False) -> np.ndarray:
        """`values` as one finite number per arm joint (a new array); InputError naming `what` otherwise.

        Args:
            values: The values.
            what: What they are, for the message (`joint stiffness`).
            unit: Their unit, for the message.
            positive: Every value must be > 0.
            nonnegative: Every value must be >= 0.
        """
        arr = np.array(values, dtype=float)
        ok = arr.shape == (self.dof,) and bool(np.all(np.isfinite(arr)))
        ok = ok and not (positive and np.any(arr <= 0.0)) and not (nonnegative and np.any(arr < 0.0))
        if not ok:
            bound = " > 0" if positive else " >= 0" if nonnegative else ""
            raise InputError(
                f"{what} must be {self.dof} finite values{bound} [{unit}], one per joint of {self.name} "
                f"({', '.join(self.joints)}); got {values!r}"
            )
        return arr


_CACHE: dict[tuple[str, int, int], RobotDescription] = {}


def shipped_robots() -> dict[str, Path]:
    """Name -> description file of every robot shipped in the models folder (`*.toml`, `*/robot.toml`)."""
    found: dict[str, Path] = {}
    folder = models_dir()
    for path in sorted([*folder.glob("*.toml"), *folder.glob("*/robot.toml")]):
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError):
            continue
        if data.get("format") == ROBOT_FORMAT and isinstance(data.get("name"), str):
            found[data["name"]] = path
    return found


def load_robot(robot: str | Path | RobotDescription | None = None) -> RobotDescription:
    """The robot named (a shipped robot), at a path (a description file), or the default (`tx200`).

    Raises:
        ModelError: Unknown name (lists the shipped robots), a missing or malformed file, or an MJCF that lacks
            a part the description names.
    """
    if isinstance(robot, RobotDescription):
        return robot
    if robot is None or (isinstance(robot, str) and not robot.endswith(".toml") and "/" not in robot):
        name = DEFAULT_ROBOT if robot is None else robot
        shipped = shipped_robots()
        if name not in shipped:
            raise ModelError(f"unknown robot {name!r}; shipped robots: {sorted(shipped)} (or a path to a .toml file)")
        path = shipped[name]
    else:
        path = Path(robot)
    if not path.is_file():
        raise ModelError(f"robot description not found: {path} (expected a {ROBOT_FORMAT} .toml file)")
    mjcf_stamp = path.stat().st_mtime_ns
    key = (str(path.resolve()), mjcf_stamp, _mjcf_stamp(path))
    if key not in _CACHE:
        _CACHE[key] = _read(path)
    return _CACHE[key]


def _mjcf_stamp(path: Path) -> int:
    """Modification time of the MJCF a description names (-1 when unreadable): a recalibrated model is re-read."""
    try:
        mjcf = path.parent / str(tomllib.loads(path.read_text(encoding="utf-8")).get("mjcf", ""))
        return mjcf.stat().st_mtime_ns
    except (OSError, tomllib.TOMLDecodeError):
        return -1


def _read(path: Path) -> RobotDescription:
    """Parse a description file and read the derived facts from its MJCF."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
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
    derived = _from_mjcf(mjcf, joints, names)
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
        calibrated_stiffness=stiffness_joints, calibrated_friction=friction_joints, **names,
    )


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
    return DhTable(
        tuple(rows["d_m"]), tuple(rows["a_m"]), tuple(float(np.deg2rad(v)) for v in rows["alpha_deg"]),
        tuple(float(np.deg2rad(v)) for v in rows["offset_deg"]), str(table.get("source", "")),
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
