"""ABB EGM on the twin's side: a UDP server that answers each `EgmRobot` message with an `EgmSensorPathCorr`
carrying the online compensator's correction of the programmed path.

EGM (Externally Guided Motion, RobotWare option; protobuf over UDP, 4 ms) in path-correction mode: the RAPID
program moves with `EGMMoveL` after `EGMActMove` (`twin.apps.export.rapid_egm`), the controller streams
`EgmRobot` (header `seqno`/`tm`, feedback joints [deg] and Cartesian pose [mm, quaternion], the planned pose) and
takes each `EgmSensorPathCorr` (header `mtype` `MSGTYPE_PATH_CORRECTION`; `pathCorr.pos` [mm] and `age`) as the
path's current offset. The messages are `abb-robot-client`'s compiled classes of ABB's `egm.proto`.

The offset is in **path coordinates** (RAPID's `CorrWrite`; `abb-robot-client`'s `send_to_robot_path_corr`): x
along the direction of motion, z the tool's z axis made normal to it, y = z × x. The twin's correction is in the
robot's base frame; this server turns it into path coordinates from the planned pose of each message: the motion's
direction from the planned positions of successive messages (the last one kept while the robot stands), the
tool's z from the planned orientation. Which way ABB's path frame points at a standstill is not documented where
we could read it; the correction there is sent in the last moving frame. `age` is sent as 1 ms, as
`abb-robot-client` does. These conventions are read from those sources, not tried on a controller. The message's
planned joints (`planned.joints`, `egm.proto`'s `EgmPlanned`), where it carries them, sign the friction's lag
(`twin.sim.online`); a message without them leaves it to the feedback joints.

The F/T sample comes from a `ForceSource` (the sensor's own stream, `twin.apps.online.rdt`) or, without one, from
the message's `measuredForce` (ABB Force Control's sensor, its first three values taken as the sheet-frame force
[N]). The server's loop is bounded, and serves one peer per session, as `rsi`'s does; a message with a joint, a
force or a planned pose not finite is answered with the last correction and counted unreadable, as there.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from twin.apps.online.cycle import DEFAULT_START_TIMEOUT_S, ServedCycle, ServeReport, serve_udp, udp_socket
from twin.apps.online.source import ForceSource
from twin.robot.facts import RobotDescription
from twin.sim.online import OnlineCompensator

#: Below this motion between two messages the path direction is kept [mm].
MIN_STEP_MM = 1e-4


def egm_messages() -> Any:
    """ABB's EGM message classes (`abb_robot_client`'s compiled `egm.proto`), imported on first use."""
    from abb_robot_client._egm_protobuf import egm_pb2

    return egm_pb2


def _z_axis(q: Any, out: np.ndarray) -> None:
    """The z axis of the unit quaternion (u0 = w, u1..u3 = x y z) into `out`."""
    w, x, y, z = q.u0, q.u1, q.u2, q.u3
    out[0] = 2.0 * (x * z + w * y)
    out[1] = 2.0 * (y * z - w * x)
    out[2] = 1.0 - 2.0 * (x * x + y * y)


class PathFrame:
    """The path coordinates of the moving tool (module docstring), updated from each planned pose.

    Attributes:
        axes: Rows x (the motion), y, z (the tool's, normal to the motion), base frame, shape (3, 3).
    """

    def __init__(self) -> None:
        self.axes = np.eye(3)
        self._last: tuple[float, float, float] | None = None
        self._x = (1.0, 0.0, 0.0)
        self._z = (0.0, 0.0, -1.0)

    def update(self, pos: Any, orient: Any | None) -> None:
        """Move the frame to the planned position (mm) and orientation (quaternion or None). Plain floats: a
        3-vector costs more as an array than as numbers."""
        px, py, pz = pos.x, pos.y, pos.z
        if self._last is not None:
            dx, dy, dz = px - self._last[0], py - self._last[1], pz - self._last[2]
            length = math.sqrt(dx * dx + dy * dy + dz * dz)
            if length > MIN_STEP_MM:
                self._x = (dx / length, dy / length, dz / length)
        self._last = (px, py, pz)
        if orient is not None:
            w, a, b, c = orient.u0, orient.u1, orient.u2, orient.u3
            self._z = (2.0 * (a * c + w * b), 2.0 * (b * c - w * a), 1.0 - 2.0 * (a * a + b * b))
        x0, x1, x2 = self._x
        t0, t1, t2 = self._z
        along = t0 * x0 + t1 * x1 + t2 * x2
        z0, z1, z2 = t0 - along * x0, t1 - along * x1, t2 - along * x2  # the tool's z, made normal to the motion
        norm = math.sqrt(z0 * z0 + z1 * z1 + z2 * z2)
        if norm < 1e-9:  # moving along the tool's axis: any z normal to the motion
            z0, z1, z2 = (-x2, 0.0, x0) if abs(x1) < 0.9 else (0.0, x2, -x1)  # x × (0 1 0) or x × (1 0 0)
            norm = math.sqrt(z0 * z0 + z1 * z1 + z2 * z2)
        z0, z1, z2 = z0 / norm, z1 / norm, z2 / norm
        a = self.axes
        a[0, 0], a[0, 1], a[0, 2] = x0, x1, x2
        a[1, 0], a[1, 1], a[1, 2] = z1 * x2 - z2 * x1, z2 * x0 - z0 * x2, z0 * x1 - z1 * x0  # y = z × x
        a[2, 0], a[2, 1], a[2, 2] = z0, z1, z2


def read_planned(message: Any, planned: np.ndarray) -> np.ndarray | None:
    """The message's planned joints (`planned.joints`, without the correction) into `planned` (in place), or None
    where it carries fewer than `planned` holds."""
    if not message.planned.HasField("joints"):
        return None
    joints = message.planned.joints.joints
    if len(joints) < len(planned):
        return None
    for i in range(len(planned)):
        planned[i] = joints[i]
    return planned


def read_feedback(message: Any, packet: bytes, axes: np.ndarray) -> bool:
    """Parse a robot's EGM message into `message` and its feedback joints into `axes` (in place); False for one
    that cannot be read (protobuf's DecodeError, or fewer joints than `axes`)."""
    try:
        message.ParseFromString(packet)
        joints = message.feedBack.joints.joints
        if len(joints) < len(axes):
            return False
    except Exception:
        return False
    for i in range(len(axes)):
        axes[i] = joints[i]
    return True


class EgmServer:
    """The twin's side of EGM path correction on a UDP port (`serve`).

    Args:
        compensator: The online compensator (its twin at the cell's placement). The controller takes a path
            correction every 48 ms (the exported program's `\\SampleRate`) and holds it; predicting over the
            hold (`OnlineSettings.period_s`) was measured on the plant and did not help (docs/online.md), so the
            server leaves the compensator's setting as it is given (`correction_period_s` None).
        robot: The robot (its controller's axis signs and offsets turn the feedback joints into the twin's).
        port: UDP port to listen on (0: any free one, see `port`).
        host: Address to bind (tests: 127.0.0.1).
        force: Where the F/T sample comes from; None: the messages' `measuredForce`.
    """

    #: The hold the server sets the compensator to predict over [s]; None: the compensator's own setting (the
    #: default: over the program's 48 ms, `1e-3 * SAMPLE_RATE_MS`, it made the largest error grow on the plant).
    correction_period_s: float | None = None

    def __init__(self, compensator: OnlineCompensator, robot: RobotDescription, port: int = 0,
                 host: str = "127.0.0.1", force: ForceSource | None = None) -> None:
        self.compensator, self.robot, self.force = compensator, robot, force
        if self.correction_period_s is not None:
            compensator.hold_each_correction(self.correction_period_s)
        self.pb = egm_messages()
        self.sock, self.port = udp_socket(host, port)

    def close(self) -> None:
        """Stop listening."""
        self.sock.close()

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0,
              start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> ServeReport:
        """Answer messages until `max_cycles` were answered or none came for the start or idle timeout.

        Args:
            R_base_sheet: The sheet's axes in the robot base.
            max_cycles: Most messages to answer (a bound: the loop stops by itself).
            idle_timeout_s: Stop when no message was answered for this long after the last [s].
            start_timeout_s: Stop when no first message was answered for this long [s].
        """
        pb = self.pb
        cycle = ServedCycle(self.compensator, self.robot, R_base_sheet)
        frame = PathFrame()
        robot_msg, reply = pb.EgmRobot(), pb.EgmSensorPathCorr()
        reply.header.mtype = pb.EgmHeader.MessageType.Value("MSGTYPE_PATH_CORRECTION")
        reply.pathCorr.age = 1
        axes, planned_q = np.zeros(self.robot.dof), np.zeros(self.robot.dof)
        corr_path = np.zeros(3)

        def answer(packet: bytes, received_s: float) -> bytes | None:
            if not read_feedback(robot_msg, packet, axes):
                return None
            t = received_s if self.force is not None else 1e-3 * robot_msg.header.tm
            planned = robot_msg.planned.cartesian if robot_msg.planned.HasField("cartesian") else None
            cartesian = planned if planned is not None else robot_msg.feedBack.cartesian
            orient = cartesian.orient if cartesian.HasField("orient") else None
            rejected = cycle.rejected
            if not (self._take_force(robot_msg, cycle, t) and finite_pose(cartesian.pos, orient)):
                cycle.hold()  # a value not finite: the last correction, in the last frame
            else:
                frame.update(cartesian.pos, orient)
                np.dot(frame.axes, cycle.step(t, axes, read_planned(robot_msg, planned_q)), out=corr_path)
            reply.header.seqno += 1
            reply.header.tm = robot_msg.header.tm
            if cycle.rejected == rejected:
                reply.pathCorr.pos.x, reply.pathCorr.pos.y, reply.pathCorr.pos.z = corr_path
            return reply.SerializeToString()

        return serve_udp(self.sock, max_cycles, idle_timeout_s, answer, cycle, start_timeout_s)

    def _take_force(self, robot_msg: Any, cycle: ServedCycle, t: float) -> bool:
        """The newest F/T sample into the cycle: the force source's, or the message's measured force; False (nothing
        taken) when the message's force is not finite."""
        if self.force is not None:
            cycle.take(self.force)
        elif robot_msg.HasField("measuredForce") and len(robot_msg.measuredForce.force) >= 3 and (
                not robot_msg.measuredForce.HasField("fcActive") or robot_msg.measuredForce.fcActive):
            force = robot_msg.measuredForce.force
            return cycle.put_force(force[0], force[1], force[2], t)
        return True


def finite_pose(pos: Any, orient: Any | None) -> bool:
    """Whether a message's position (and orientation, if any) is finite."""
    if not (math.isfinite(pos.x) and math.isfinite(pos.y) and math.isfinite(pos.z)):
        return False
    return orient is None or (math.isfinite(orient.u0) and math.isfinite(orient.u1) and math.isfinite(orient.u2)
                              and math.isfinite(orient.u3))
