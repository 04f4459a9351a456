"""A robot as data: what the twin needs to know of a robot, read from its model folder.

A robot is an MJCF (robot only, in the menagerie manner: joints with ranges, position actuators as the joint
springs K_q, joint friction, a `home` keyframe, a flange site, a tool-tip site, an F/T site and force sensor)
and a description file beside it (`models/tx200.toml`, format `tx200-twin-robot/1`) that names those parts and
states what an MJCF cannot hold: vendor, controller and its language, the lost-motion joints, the DH table of
the independent kinematics check, joint-stiffness priors with their sources, the near-singularity threshold and
the scene site of the default sheet placement. Every fact is stated once: the home pose is the keyframe's, the
tool length the flange-to-tool-site distance, the joint ranges the MJCF's, all read from the compiled model.
This module holds the records (`RobotDescription` and its parts); `twin.robot.robot_file` reads them from a
description file and `twin.robot.description` finds and loads a robot by name or path.

Everything outside `twin.robot` asks a `RobotDescription` for joint names, counts, addresses and the tool; no
other module names a joint or a TX200 number.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from twin.errors import InputError, ModelError

if TYPE_CHECKING:  # a description is data: MuJoCo loads with the model it describes
    import mujoco

ROBOT_FORMAT = "tx200-twin-robot/1"
#: Rounding of the tool offset read from the MJCF [m]: the sites' float sum, to the nanometre.
TOOL_ROUNDING_DIGITS = 9


@dataclass(frozen=True)
class DhTable:
    """Denavit-Hartenberg parameters, A_i = Rot_z(θ_i) Trans_z(d_i) Trans_x(a_i) Rot_x(α_i), θ_i = q_i + offset_i.

    Attributes:
        d_m, a_m: Offsets [m], one per joint.
        alpha_rad, offset_rad: Twists and joint-angle offsets [rad], one per joint.
        source: Where the table comes from.
        geometry: True: the table is the robot's geometry, and the MJCF's link offsets are set from it when the
            model compiles (`twin.robot.model.dh_geometry`); False: the table only cross-checks the MJCF.
    """

    d_m: tuple[float, ...]
    a_m: tuple[float, ...]
    alpha_rad: tuple[float, ...]
    offset_rad: tuple[float, ...]
    source: str
    geometry: bool = False


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


@dataclass(frozen=True)
class Datasheet:
    """The maker's numbers of a robot, with their source.

    Attributes:
        reach_m: Maximum reach (wrist centre or flange, as the maker states it) [m].
        payload_kg: Rated payload [kg].
        joint_speed_rad_s: Maximum speed of each joint [rad/s], or None where not given.
        source: Datasheet, URDF or page the numbers come from.
    """

    reach_m: float
    payload_kg: float
    joint_speed_rad_s: tuple[float, ...] | None
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
        datasheet: The maker's reach, payload and joint speeds with their source, or None.
        controller_sign: Per joint, +1 or -1: the controller's axis value turns the way the MJCF's q does or not.
        controller_offset_rad: Per joint, the controller's axis value at q = 0 [rad].
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
    datasheet: Datasheet | None = None
    controller_sign: tuple[float, ...] = ()
    controller_offset_rad: tuple[float, ...] = ()

    def controller_angles(self, q_rad: np.ndarray) -> np.ndarray:
        """The controller's axis values (A1..A6, J1..J6) of MJCF joint angles [rad], shape as `q_rad`."""
        q = np.asarray(q_rad, dtype=float)
        sign = np.array(self.controller_sign or (1.0,) * self.dof)
        offset = np.array(self.controller_offset_rad or (0.0,) * self.dof)
        return sign * q + offset

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
