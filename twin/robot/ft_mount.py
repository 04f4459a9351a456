"""The F/T sensor's mounting on the flange (a cell's `[ft_sensor]`), and its axes in the sheet frame while forming.

A cell declares the sensor's axes in the flange frame as roll, pitch, yaw (R_flange_sensor = Rz(yaw) Ry(pitch)
Rx(roll); a sensor turned about the flange z is a yaw alone) and its measuring origin's offset from the flange.
While forming, the tool is held down (`Kinematics.R_tool_down`: its axis along −z of the base, the flange's x as
at home), so the sensor's axes in the sheet frame are constant:

    R_sheet_sensor = R_base_sheetᵀ R_base_tool_down R_tool_flange R_flange_sensor

with R_base_sheet the placement's yaw about the base z. Forces turn with this rotation alone; the offset moves
torques only (a torque about the measuring origin), and the twin's force path reads forces: it is recorded, not used.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from twin.robot.facts import RobotDescription


def rpy_matrix(rpy_deg: Sequence[float]) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) for (roll, pitch, yaw) [deg], (3, 3)."""
    r, p, y = (math.radians(float(v)) for v in rpy_deg)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def sensor_in_sheet(robot: str | Path | RobotDescription | None, rpy_deg: Sequence[float],
                    yaw_deg: float | None = None) -> np.ndarray:
    """The sensor's axes in the sheet frame while the tool is held down (module docstring), (3, 3).

    Args:
        robot: The robot (its flange and tool-down orientation); None: the default robot.
        rpy_deg: The sensor's axes in the flange frame, (roll, pitch, yaw) [deg].
        yaw_deg: The sheet's yaw about the base z [deg]; None: 0.
    """
    from twin.robot.kinematics import Kinematics  # MuJoCo: only when a mount is turned into the sheet frame

    kin = Kinematics(robot=robot)
    _, R_base_tool = kin.fk(kin.q_home)
    R_base_flange = kin.data.site_xmat[kin.model.site(kin.robot.flange_site).id].reshape(3, 3)
    R_tool_flange = R_base_tool.T @ R_base_flange
    R_base_sheet = rpy_matrix((0.0, 0.0, 0.0 if yaw_deg is None else yaw_deg))
    R = R_base_sheet.T @ kin.R_tool_down @ R_tool_flange @ rpy_matrix(rpy_deg)
    u, _, vt = np.linalg.svd(R)  # exactly orthonormal (the products carry rounding)
    return np.asarray(u @ vt)
