"""Pinocchio model of the TX200 built from the SAME MJCF as MuJoCo, as an independent kinematics check.

pin 4.1.0 places a site on a body nested two or more levels below the last jointed body without the
offsets of the intermediate jointless bodies (fixed upstream after 4.1.0). The tool tip `tcp` sits on
link6 -> ft_sensor -> tool, exactly that layout, so this module composes the tcp frame itself: the link6
body frame times the local poses of ft_sensor, tool and the tcp site, read from the MuJoCo model.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from twin.base.resources import robot_xml
from twin.errors import InputError, ModelError

TCP_FRAME = "tcp_composed"
_CHAIN = ("ft_sensor", "tool")  # jointless bodies between link6 and the tcp site


def _se3(pos: np.ndarray, quat_wxyz: np.ndarray) -> pin.SE3:
    """SE3 from a MuJoCo position [m] and unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    return pin.SE3(R, np.asarray(pos, dtype=float).copy())


class PinKinematics:
    """Forward kinematics and tcp Jacobian with Pinocchio; q is MuJoCo's qpos (q1..q6) [rad].

    Args:
        xml: MJCF of the robot; None uses `models/tx200.xml`.
    """

    def __init__(self, xml: str | Path | None = None) -> None:
        path = Path(xml) if xml is not None else robot_xml()
        if not path.is_file():
            raise ModelError(f"model file not found: {path}")
        self.model = pin.buildModelFromMJCF(str(path))
        mj = mujoco.MjModel.from_xml_path(str(path))
        if self.model.nq != 6 or list(self.model.names)[1:] != [f"joint{i}" for i in range(1, 7)]:
            raise ModelError(f"expected joints joint1..joint6 in {path}, got {list(self.model.names)[1:]}")
        link6 = self.model.getFrameId("link6", pin.FrameType.BODY)
        placement = self.model.frames[link6].placement
        for body in _CHAIN:
            placement = placement * _se3(mj.body(body).pos, mj.body(body).quat)
        site = mj.site("tcp")
        placement = placement * _se3(site.pos, site.quat)
        joint6 = self.model.frames[link6].parentJoint
        self._tcp = self.model.addFrame(
            pin.Frame(TCP_FRAME, joint6, link6, placement, pin.FrameType.OP_FRAME)
        )
        self.data = self.model.createData()

    def _update(self, q: np.ndarray) -> None:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (6,) or not np.all(np.isfinite(arr)):
            raise InputError(f"q must be 6 finite joint angles q1..q6 [rad], got shape {arr.shape}: {arr}")
        pin.forwardKinematics(self.model, self.data, arr)
        pin.updateFramePlacements(self.model, self.data)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tool-tip pose: p_base_tcp (3,) [m] and R_base_tcp (3, 3)."""
        self._update(q)
        oMf = self.data.oMf[self._tcp]
        return oMf.translation.copy(), oMf.rotation.copy()

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Tcp Jacobian, LOCAL_WORLD_ALIGNED, rows [linear; angular] (6, 6) [m/rad; 1]."""
        self._update(q)
        pin.computeJointJacobians(self.model, self.data, np.asarray(q, dtype=float))
        return pin.getFrameJacobian(
            self.model, self.data, self._tcp, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        ).copy()

    def site_position(self, q: np.ndarray, name: str) -> np.ndarray:
        """Position of a frame pin built from the MJCF (e.g. its own `tcp`, affected by the 4.1.0 bug) [m]."""
        self._update(q)
        return self.data.oMf[self.model.getFrameId(name)].translation.copy()
