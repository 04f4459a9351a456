"""Reach: every point of a program (approach, path, retract) must be a pose the robot's IK solves, tool down.

`solve_reach` runs the robot's IK along the points (`Kinematics.ik_path`, warm-started, seeded at home); when it
fails, the points are solved one by one from the previous solution to find the first that cannot be reached,
and the error names it as the user knows it (the path CSV's row, or the approach / retract point), with its
position in the robot base, its distance from the base origin, the robot's datasheet reach where it has one,
and the solver's reason. Every format is checked, not only the robot languages: a G-code or point list the
robot cannot follow is refused too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twin.errors import InputError, SingularityError, UnreachableError
from twin.robot.facts import RobotDescription

if TYPE_CHECKING:
    from twin.robot.kinematics import Kinematics


def first_unreachable(kin: Kinematics, p_base_tcp_m: np.ndarray) -> tuple[int, str]:
    """The first point the IK cannot solve when warm-started from the previous one, and the solver's reason.

    Args:
        kin: The robot's kinematics.
        p_base_tcp_m: Tool-tip points of the robot model in the base frame, shape (n, 3) [m].

    Returns:
        (index, reason); (-1, "") when every point is solved.
    """
    q = kin.q_home.copy()
    for i, p in enumerate(np.asarray(p_base_tcp_m, dtype=float)):
        try:
            q = kin.ik(p, q)
        except (UnreachableError, SingularityError) as exc:
            return i, str(exc)
    return -1, ""


def solve_reach(
    kin: Kinematics,
    p_model_tcp_m: np.ndarray,
    p_program_tip_m: np.ndarray,
    source: str,
    label: Callable[[int], str],
) -> np.ndarray:
    """The joint angles along a program's points, or the error that names the first point out of reach.

    Args:
        kin: The robot's kinematics.
        p_model_tcp_m: The robot model's tool-tip targets in the base frame, shape (n, 3) [m] (the program's tool
            tips moved along the tool axis when the program's tool is not the model's).
        p_program_tip_m: The program's tool-tip points in the base frame, shape (n, 3) [m], for the message.
        source: The path, for the message.
        label: Point index -> how the message names it (`ProgramPath.label`).

    Returns:
        Joint angles, shape (n, dof) [rad].

    Raises:
        UnreachableError, SingularityError: Naming the first point out of reach, where it is and how far.
    """
    try:
        return kin.ik_path(p_model_tcp_m)
    except (UnreachableError, SingularityError) as exc:
        i, reason = first_unreachable(kin, p_model_tcp_m)
        if i < 0:  # the warm-started path failed where single points do not: report the path's own error
            i, reason = 0, str(exc)
        p_mm = 1e3 * np.asarray(p_program_tip_m, dtype=float)[i]
        sheet = kin.robot.datasheet
        stated = f"; its datasheet reach is {1e3 * sheet.reach_m:.0f} mm" if sheet is not None else ""
        raise type(exc)(
            f"{source}, {label(i)}: robot {kin.robot.name!r} cannot reach the tool tip at "
            f"({p_mm[0]:.1f}, {p_mm[1]:.1f}, {p_mm[2]:.1f}) mm in its base frame, {float(np.linalg.norm(p_mm)):.1f} mm "
            f"from the base origin{stated} ({reason}); expected every point within reach: place the sheet "
            "nearer (--origin-mm) or move the path"
        ) from None


def path_joint_angles(
    robot: str | Path | RobotDescription,
    p_base_tip_m: np.ndarray,
    R_base_tool: np.ndarray,
    tool_length_m: float,
    source: str,
    label: Callable[[int], str],
) -> tuple[Kinematics, np.ndarray]:
    """The robot's IK along a program's tool-tip points, tool down (`Kinematics.R_tool_down`).

    Args:
        robot: The robot.
        p_base_tip_m: Tool-tip points in the robot base frame, shape (n, 3) [m].
        R_base_tool: The program's tool orientation in the base; must be the twin's `R_tool_down`.
        tool_length_m: The program's tool (flange to tip along the flange z) [m]; the robot model's own tool tip
            is moved along the tool axis to where this tool puts the flange.
        source: The path, for messages.
        label: Point index -> how messages name it (`ProgramPath.label`).

    Returns:
        The robot's kinematics and the joint angles, shape (n, dof) [rad].

    Raises:
        InputError: The tool orientation is not the twin's.
        UnreachableError, SingularityError: A point out of reach (`solve_reach`).
    """
    from twin.robot.kinematics import Kinematics  # MuJoCo: only when a program is made

    kin = Kinematics(robot=robot)
    gap = float(np.linalg.norm(np.asarray(R_base_tool, dtype=float) - kin.R_tool_down))  # = 2√2 sin(angle / 2)
    turn = math.degrees(2.0 * math.asin(min(1.0, gap / (2.0 * math.sqrt(2.0)))))
    if turn > 1e-6:
        raise InputError(
            f"the program's tool is turned {turn:.3g}° from the twin's tool-down orientation "
            "(Kinematics.R_tool_down); the arm configuration is solved for that orientation (build the cell with "
            "default_cell)"
        )
    tool_axis = kin.R_tool_down[:, 2]
    p_model_tip = np.asarray(p_base_tip_m, dtype=float) - (tool_length_m - kin.robot.tool_length_m) * tool_axis
    return kin, solve_reach(kin, p_model_tip, p_base_tip_m, source, label)
