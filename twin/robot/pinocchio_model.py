"""Pinocchio model of a robot built from the SAME MJCF as MuJoCo, as an independent kinematics check.

pin 4.1.0 places a site on a body nested two or more levels below the last jointed body without the
offsets of the intermediate jointless bodies (fixed upstream after 4.1.0). A tool tip behind an F/T sensor
sits exactly there (the TX200: link6 -> ft_sensor -> tool -> tcp), so this module composes the tool frame
itself: the last jointed body's frame times the local poses of the jointless bodies below it and of the tool
site, read from the MuJoCo model.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from twin.errors import InputError, ModelError
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription

TCP_FRAME = "tcp_composed"


def _se3(pos: np.ndarray, quat_wxyz: np.ndarray) -> pin.SE3:
    """SE3 from a MuJoCo position [m] and unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    return pin.SE3(R, np.asarray(pos, dtype=float).copy())


class PinKinematics:
    """Forward kinematics and tool-tip Jacobian with Pinocchio; q is MuJoCo's qpos of the arm joints [rad].

    Args:
        xml: MJCF of the robot; None uses the robot's own.
        robot: The robot; None: the default robot.
    """

    def __init__(self, xml: str | Path | None = None, robot: str | Path | RobotDescription | None = None) -> None:
        self.robot = load_robot(robot)
        path = Path(xml) if xml is not None else self.robot.mjcf
        if not path.is_file():
            raise ModelError(f"model file not found: {path}")
        self.model = pin.buildModelFromMJCF(str(path))
        mj = mujoco.MjModel.from_xml_path(str(path))
        if self.model.nq != self.robot.dof or tuple(self.model.names)[1:] != self.robot.joints:
            raise ModelError(f"expected joints {list(self.robot.joints)} in {path}, got {list(self.model.names)[1:]}")
        site = mj.site(self.robot.tool_site)
        body = int(site.bodyid[0])
        chain = []  # jointless bodies between the last jointed body and the site, outermost last
        while mj.body_jntnum[body] == 0:
            chain.append(body)
            body = int(mj.body_parentid[body])
        link = self.model.getFrameId(mj.body(body).name, pin.FrameType.BODY)
        placement = self.model.frames[link].placement
        for b in reversed(chain):
            placement = placement * _se3(mj.body_pos[b], mj.body_quat[b])
        placement = placement * _se3(site.pos, site.quat)
        joint = self.model.frames[link].parentJoint
        self._tcp = self.model.addFrame(pin.Frame(TCP_FRAME, joint, link, placement, pin.FrameType.OP_FRAME))
        self.data = self.model.createData()

    def _update(self, q: np.ndarray) -> None:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.robot.dof,) or not np.all(np.isfinite(arr)):
            raise InputError(f"q must be {self.robot.dof} finite joint angles [rad], got shape {arr.shape}: {arr}")
        pin.forwardKinematics(self.model, self.data, arr)
        pin.updateFramePlacements(self.model, self.data)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool-tip pose: p_base_tcp (3,) [m] and R_base_tcp (3, 3)."""
        self._update(q)
        oMf = self.data.oMf[self._tcp]
        return oMf.translation.copy(), oMf.rotation.copy()

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Tool-tip Jacobian, LOCAL_WORLD_ALIGNED, rows [linear; angular] (6, dof) [m/rad; 1]."""
        self._update(q)
        pin.computeJointJacobians(self.model, self.data, np.asarray(q, dtype=float))
        return pin.getFrameJacobian(
            self.model, self.data, self._tcp, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        ).copy()

    def site_position(self, q: np.ndarray, name: str) -> np.ndarray:
        """Position of a frame pin built from the MJCF (e.g. its own `tcp`, affected by the 4.1.0 bug) [m]."""
        self._update(q)
        return self.data.oMf[self.model.getFrameId(name)].translation.copy()
