"""The arm configuration of a joint solution as each controller writes it, and the check that a path keeps one.

A pose of a six-axis arm with a spherical wrist has up to eight joint solutions; three geometric facts tell them
apart (`RobotConfiguration`), computed from the robot's DH table (`RobotDescription.dh`, whose angles are the
MJCF's q: θ_i = q_i + offset_i, as `twin.robot.dh` reads it) and the controller's axis values
(`RobotDescription.controller_angles`):

- **behind axis 1**: the wrist centre (flange origin - d6 · flange z, d6 the table's last d) lies behind axis 1:
  its x in the frame that turns with axis 1 is negative, "forward" being DH frame 1's x axis, towards the shoulder
  (the sign of a1; frame 1's x when a1 = 0). KUKA's overhead area, ABB's "wrist centre behind axis 1";
- **behind the lower arm**: in the arm's plane, the wrist centre lies on the back side of the line from the
  shoulder (frame 1's origin, on axis 2) to the elbow (frame 2's origin, on axis 3), the front side being the one
  that faces forward when the lower arm points up. It flips where the arm is stretched, so it is KUKA's "A3 below
  the stretched-arm angle φ" and ABB's "wrist centre behind the lower arm"; false is the elbow-up solution;
- **axis 5 negative**: A5 mod 360° >= 180° (KUKA: A5 in [-180°, 0°) or >= 180°).

Encodings (axis values in degrees, rounded to 1e-6° so that a joint at 0 up to solver noise counts as 0):

- KUKA KRL `S` (Status): bit 0 behind axis 1, bit 1 NOT behind the lower arm, bit 2 axis 5 negative; `T` (Turn):
  bit i set when axis i+1 < 0. Written as KRL binary literals, `S 'B010'`, `T 'B000011'` (an INT either way: `S 2`
  is the same value). Only a PTP reads them; LIN keeps the current configuration.
- ABB RAPID robconf [cf1, cf4, cf6, cfx]: cfN = floor(axis N / 90°) (0 for [0°, 90°), -1 for [-90°, 0°), ...);
  cfx = 4 · behind axis 1 + 2 · behind the lower arm + axis 5 negative (ABB's table of the eight configurations).
- Stäubli VAL3 pointRx: shoulder `lefty` (wrist centre in front of axis 1) / `righty` (behind), elbow `epositive`
  (in front of the lower arm) / `enegative`, wrist `wpositive` / `wnegative` (axis 5 negative).

Sources (read, not copied): RoboDK's post-processors (github.com/ros-industrial-attic/robodk_postprocessors,
d7e6c1c): `KUKA_KRC4_Config.py` (`conf_2_str`: S = 'B' + flip + (lower arm == 0) + rear; `joints_2_turn_str`: T
bit i when joint i < 0), `ABB_RAPID_IRC5.py` (cf = floor(joint / 90), cfx = 4·rear + 2·lowerarm + flip,
`ConfJ \\On; ConfL \\Off;`), `Staubli_VAL3.py` (righty if rear, enegative if lower arm, wnegative if flip; default
lefty/epositive/wpositive). visose/Robots (github.com/visose/Robots, 47bb90f): `KRLPostProcessor.cs` (S =
shoulder + 2·(not its elbow flag) + 4·wrist, T from the signs of the axes, on PTP only), `RapidPostProcessor.cs`,
`VAL3PostProcessor.cs` (shoulder -> righty, wrist -> wnegative). Autodesk's KUKA KRL post (kuka.cps, FORKID
{E86D1E53-6B40-4EEB-A94E-552C25F118A4}, 2022): PTP `{X,Y,Z,A,B,C,...,S 'B110',T 'B110010'}` for axes
{5, -80, 100, 75, -60, -65}. KUKA's wording of the bits (KSS expert programming manual, as quoted on
robot-forum.com threads 7173 and 45777 and summarised on industrialmonitordirect.com). Where they disagree:
visose decrements a negative cf once more (floor(-30° / 90°) - 1 = -2; ABB's quadrants and RoboDK give -1, as
here) and flips ABB's and Stäubli's elbow for a rear shoulder; one summary states bit 1 the other way round,
against RoboDK, Autodesk's example (A3 = 100°, elbow up: bit 1 set) and visose, whose convention is taken here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from twin.apps.export.reach import path_joint_angles
from twin.errors import InputError, ModelError
from twin.robot.description import load_robot
from twin.robot.dh import dh_transforms
from twin.robot.facts import DhTable, RobotDescription

#: The vendors' definitions (S/T bits, cf1/cf4/cf6, shoulder/elbow/wrist) are those of six-axis arms.
ARM_AXES = 6
#: Axis values are rounded to this many decimals of a degree before their signs and quadrants are read.
ANGLE_DECIMALS = 6


class RobotConfiguration(NamedTuple):
    """One joint solution's configuration (module docstring for the definitions and sources).

    Attributes:
        axes_deg: The controller's axis values A1..A6 / J1..J6 [deg], rounded to 1e-6°.
        behind_axis1: The wrist centre is behind axis 1 (KUKA overhead area, ABB rear, Stäubli righty).
        behind_lower_arm: The wrist centre is behind the lower arm (elbow down; KUKA A3 below φ, Stäubli enegative).
        axis5_negative: Axis 5 is negative (A5 mod 360° >= 180°; the wrist flipped).
    """

    axes_deg: tuple[float, ...]
    behind_axis1: bool
    behind_lower_arm: bool
    axis5_negative: bool

    @property
    def arm(self) -> tuple[bool, bool, bool]:
        """What a path must keep: (behind axis 1, behind the lower arm, axis 5 negative)."""
        return (self.behind_axis1, self.behind_lower_arm, self.axis5_negative)

    @property
    def kuka_status(self) -> int:
        """KRL `S`: bit 0 behind axis 1, bit 1 in front of the lower arm, bit 2 axis 5 negative."""
        return int(self.behind_axis1) + 2 * int(not self.behind_lower_arm) + 4 * int(self.axis5_negative)

    @property
    def kuka_turn(self) -> int:
        """KRL `T`: bit i set when axis i+1 < 0."""
        return sum(1 << i for i, a in enumerate(self.axes_deg) if a < 0.0)

    @property
    def krl(self) -> str:
        """`S 'B010',T 'B000011'`: the Status and Turn of a KRL POS/E6POS."""
        return f"S 'B{self.kuka_status:03b}',T 'B{self.kuka_turn:0{len(self.axes_deg)}b}'"

    @property
    def rapid(self) -> tuple[int, int, int, int]:
        """ABB robconf (cf1, cf4, cf6, cfx)."""
        cf1, cf4, cf6 = (math.floor(self.axes_deg[i] / 90.0) for i in (0, 3, 5))
        cfx = 4 * int(self.behind_axis1) + 2 * int(self.behind_lower_arm) + int(self.axis5_negative)
        return cf1, cf4, cf6, cfx

    @property
    def val3(self) -> tuple[str, str, str]:
        """Stäubli (shoulder, elbow, wrist)."""
        return (
            "righty" if self.behind_axis1 else "lefty",
            "enegative" if self.behind_lower_arm else "epositive",
            "wnegative" if self.axis5_negative else "wpositive",
        )

    def describe(self) -> str:
        """In words: `wrist centre in front of axis 1, elbow up, axis 5 positive`."""
        return (
            f"wrist centre {'behind' if self.behind_axis1 else 'in front of'} axis 1, "
            f"elbow {'down' if self.behind_lower_arm else 'up'}, "
            f"axis 5 {'negative' if self.axis5_negative else 'positive'}"
        )

    def text(self, language: str) -> str:
        """How a program in `language` (`VAL3`, `KRL`, `RAPID`; else in words) writes it."""
        if language == "KRL":
            return self.krl
        if language == "RAPID":
            return "[" + ",".join(str(v) for v in self.rapid) + "]"
        if language == "VAL3":
            return "/".join(self.val3)
        return self.describe()


def _arm_table(robot: RobotDescription) -> DhTable:
    """The robot's DH table, checked to describe a six-axis arm."""
    if robot.dh is None:
        raise ModelError(
            f"robot {robot.name!r} ({robot.source}) has no [dh] table; its arm configuration (wrist centre, "
            "shoulder and elbow from the DH frames) needs one"
        )
    if robot.dof != ARM_AXES or len(robot.dh.d_m) != ARM_AXES:
        raise ModelError(
            f"robot {robot.name!r} has {robot.dof} joints; the controllers' arm configurations are defined for "
            f"{ARM_AXES}-axis arms"
        )
    return robot.dh


def arm_geometry(robot: RobotDescription, q_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether the wrist centre is behind axis 1 and behind the lower arm, for MJCF joint angles.

    Args:
        robot: The robot (its DH table).
        q_rad: MJCF joint angles, shape (6,) or (n, 6) [rad].

    Returns:
        (behind_axis1, behind_lower_arm): booleans of shape () or (n,).

    Raises:
        ModelError: The robot has no DH table, is not a six-axis arm, or its axis 2 is not square to axis 1 and
            the forward direction (then front and back of the lower arm are undefined).
    """
    table = _arm_table(robot)
    T = dh_transforms(q_rad, 0.0, table)
    z0, o0 = T[..., 0, :3, 2], T[..., 0, :3, 3]
    x1, z1, o1 = T[..., 1, :3, 0], T[..., 1, :3, 2], T[..., 1, :3, 3]
    o2 = T[..., 2, :3, 3]
    flange = T[..., ARM_AXES, :3, :]
    wrist = flange[..., 3] - table.d_m[-1] * flange[..., 2]
    forward = -x1 if table.a_m[0] < 0.0 else x1
    behind_axis1 = np.einsum("...i,...i->...", wrist - o0, forward) < 0.0
    square = np.einsum("...i,...i->...", forward, np.cross(z0, z1))
    if np.any(np.abs(square) < 0.5):
        raise ModelError(
            f"robot {robot.name!r}: axis 2 is not square to axis 1 and the arm's forward direction in its DH table; "
            "the front and back of the lower arm are undefined"
        )
    front = np.sign(square)[..., None] * np.cross(o2 - o1, z1)
    behind_lower_arm = np.einsum("...i,...i->...", wrist - o1, front) < 0.0
    return behind_axis1, behind_lower_arm


def robot_configurations(robot: str | Path | RobotDescription, q_rad: np.ndarray) -> list[RobotConfiguration]:
    """The configuration of each row of MJCF joint angles.

    Args:
        robot: The robot (a name, a description file or a description).
        q_rad: MJCF joint angles, shape (6,) or (n, 6) [rad].
    """
    description = load_robot(robot)
    Q = np.atleast_2d(np.asarray(q_rad, dtype=float))
    behind_axis1, behind_lower_arm = arm_geometry(description, Q)
    axes = np.round(np.degrees(description.controller_angles(Q)), ANGLE_DECIMALS) + 0.0  # + 0.0: no -0.0
    wrapped = np.mod(axes[:, 4], 360.0)
    return [
        RobotConfiguration(tuple(float(v) for v in a), bool(b1), bool(b2), bool(w >= 180.0))
        for a, b1, b2, w in zip(axes, behind_axis1, behind_lower_arm, wrapped, strict=True)
    ]


def check_one_configuration(
    configs: Sequence[RobotConfiguration],
    source: str,
    language: str = "",
    label: Callable[[int], str] | None = None,
) -> None:
    """Refuse a path whose arm configuration changes: a program that flips mid-path is not run.

    Args:
        configs: One configuration per point, in path order.
        source: The path, for the message (`PATH.csv`).
        language: The program's language, for how the message writes the configurations.
        label: Point index -> how the message names it; None: `row i + 1` (the path CSV's data row).

    Raises:
        InputError: Naming the first point whose configuration differs from the first point's.
    """
    for i, config in enumerate(configs):
        if config.arm != configs[0].arm:
            raise InputError(
                f"{source}, {label(i) if label is not None else f'row {i + 1}'}: the robot's configuration changes here, from {configs[0].describe()} "
                f"({configs[0].text(language)}) to {config.describe()} ({config.text(language)}); expected one "
                "configuration along the path (split the path, or move it away from the singularity it crosses)"
            )


def path_configurations(
    robot: str | Path | RobotDescription,
    p_base_tip_m: np.ndarray,
    R_base_tool: np.ndarray,
    tool_length_m: float,
    source: str,
    language: str = "",
    label: Callable[[int], str] | None = None,
) -> list[RobotConfiguration]:
    """Solve the robot's IK along tool-tip points (tool down, `Kinematics.R_tool_down`) and give each configuration.

    Args:
        robot: The robot.
        p_base_tip_m: Tool-tip points in the robot base frame, shape (n, 3) [m].
        R_base_tool: The program's tool orientation in the base; must be the twin's `R_tool_down`.
        tool_length_m: The program's tool (flange to tip along the flange z) [m]; the robot model's own tool tip
            is moved along the tool axis to where this tool puts the flange.
        source: The path, for messages.
        language: The program's language, for messages.
        label: Point index -> how messages name it (`ProgramPath.label`); None: the path CSV's data row.

    Raises:
        InputError: The tool orientation is not the twin's, or the configuration changes along the path.
        UnreachableError, SingularityError: A point the robot cannot reach (`reach.solve_reach` names it).
    """
    name = label if label is not None else (lambda i: f"row {i + 1}")
    kin, Q = path_joint_angles(robot, p_base_tip_m, R_base_tool, tool_length_m, source, name)
    configs = robot_configurations(kin.robot, Q)
    check_one_configuration(configs, source, language, name)
    return configs
