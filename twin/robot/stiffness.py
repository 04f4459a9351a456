"""The joint springs K_q of a robot: the gains of its arm joints' position actuators.

Joint friction is MuJoCo's own `frictionloss` of the arm joints (Coulomb friction against the link's motion); the
quasi-static twin reads it from `model.dof_frictionloss` (see `twin.sim.quasi_static`).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription


def set_joint_stiffness(
    model: mujoco.MjModel, k_q_nm_per_rad: np.ndarray, robot: str | Path | RobotDescription | None = None
) -> None:
    """Set the joint springs K_q (position-actuator gains) of the robot's arm joints in place.

    Args:
        model: Compiled model of the robot (position actuators on its arm joints).
        k_q_nm_per_rad: Joint stiffness [N·m/rad], one per arm joint, all > 0.
        robot: The robot; None: the default robot.
    """
    description = load_robot(robot)
    k = description.joint_vector(k_q_nm_per_rad, "joint stiffness", "N·m/rad", positive=True)
    for act, value in zip(description.addresses(model).actuator, k, strict=True):
        model.actuator_gainprm[act, 0] = value
        model.actuator_biasprm[act, 1] = -value


def joint_stiffness(model: mujoco.MjModel, robot: str | Path | RobotDescription | None = None) -> np.ndarray:
    """K_q of the robot's arm joints in `model` [N·m/rad], shape (dof,)."""
    return model.actuator_gainprm[load_robot(robot).addresses(model).actuator, 0].copy()
