"""ABB EGM position guidance on the twin's side: a UDP server that answers each `EgmRobot` message with an
`EgmSensor` whose `planned.cartesian` is the path's pose at the moment plus the online compensator's correction.

The program (`twin.apps.export.rapid_egm_pose`) stands at the approach point and runs `EGMRunPose` with the tool
`tIsf` and the work object `wSheet` as correction and sensor frame: the pose the PC sends is the tool tip's in the
sheet frame [mm] with its orientation (quaternion w x y z, `EgmQuaternion` u0..u3), `header.mtype`
`MSGTYPE_CORRECTION`, as `abb-robot-client`'s `EGM.send_to_robot_cart` writes it. The path is the guidance table
the export wrote (`GuidancePath.load`: the approach point, the path's points, the time each is reached at the
programmed feeds).

The path's clock:

* it starts at the robot's **first valid message** (readable, every joint, force and pose finite): that message is
  answered with the approach point (plus the correction);
* it advances by the **robot's stamps** (`header.tm` [ms]) from one valid message to the next, never by this
  computer's clock; a stamp behind the latest does not move it, and one step moves it by at most `MAX_STEP_S`
  (a stamp that jumps, a restarted controller clock, does not jump the pose along the path);
* at the table's end it **holds the last point**: the robot converges there and `EGMRunPose` returns.

The correction (base frame, `ServedCycle.step`: its size and rate limits) is turned into the sheet frame and added
to the position on every axis; the orientation is the table's. Everything else is `EgmServer`'s (`egm`): the F/T
from a `ForceSource` or the message's `measuredForce`, one peer per session, a message with a value not finite
answered with the last pose and counted (the clock does not move: the next valid message is answered as if it
never came), the bounded loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.apps.online.cycle import DEFAULT_START_TIMEOUT_S, ServedCycle, ServeReport, serve_udp
from twin.apps.online.egm import EgmServer, finite_pose, read_feedback
from twin.apps.online.source import ForceSource
from twin.base.csvio import check_monotonic, read_table
from twin.errors import DataFileError
from twin.robot.facts import RobotDescription
from twin.sim.online import OnlineCompensator

#: The table's columns (`twin.apps.export.rapid_egm_pose.GUIDANCE_COLUMNS`).
COLUMNS = ("t_s", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz")
#: The most one message moves the path's clock [s] (25 cycles of 4 ms).
MAX_STEP_S = 0.1


@dataclass(frozen=True)
class GuidancePath:
    """The poses the PC streams: the time each point is reached [s], the points (n, 3) [mm] and the orientations
    (n, 4) (w x y z), sheet frame."""

    t_s: np.ndarray
    points_mm: np.ndarray
    quaternions: np.ndarray

    @classmethod
    def load(cls, path: str | Path) -> GuidancePath:
        """The guidance table `NAME_egm_pose.csv` the export wrote.

        Raises:
            DataFileError: A missing column, a value not finite, times that start elsewhere than 0 or go back, an
                orientation that is not a unit quaternion.
        """
        table = read_table(path, COLUMNS, min_rows=2)
        t = table["t_s"]
        if t[0] != 0.0:
            raise DataFileError(path, f"column 't_s' starts at {float(t[0])!r}, expected 0 (the approach point)", 1)
        check_monotonic(path, "t_s", t, strict=False)
        q = np.column_stack([table[c] for c in COLUMNS[4:]])
        bad = np.flatnonzero(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-3)
        if bad.size:
            raise DataFileError(path, f"qw..qz {q[bad[0]].tolist()} is not a unit quaternion", int(bad[0]) + 1)
        return cls(t, np.column_stack([table[c] for c in COLUMNS[1:4]]), q)

    @property
    def duration_s(self) -> float:
        """When the last point is reached [s]."""
        return float(self.t_s[-1])

    def at(self, t_s: float, out: np.ndarray) -> int:
        """The point at time `t_s` [s] into `out` (linear between points, the last one held after the end);
        returns the index of the point the segment starts at (its orientation is the pose's)."""
        t = self.t_s
        k = int(np.searchsorted(t, t_s, side="right")) - 1
        if k >= len(t) - 1:
            out[:] = self.points_mm[-1]
            return len(t) - 1
        k = max(k, 0)
        span = t[k + 1] - t[k]
        s = 0.0 if span <= 0.0 else min(max((t_s - t[k]) / span, 0.0), 1.0)
        out[:] = self.points_mm[k] + s * (self.points_mm[k + 1] - self.points_mm[k])
        return k


class EgmPoseServer(EgmServer):
    """The twin's side of EGM position guidance on a UDP port (`serve`).

    Args:
        compensator: The online compensator (its twin at the cell's placement).
        robot: The robot (its controller's axis signs and offsets turn the feedback joints into the twin's).
        guidance: The path to stream (`GuidancePath.load`).
        port, host, force: As `EgmServer`'s.

    Attributes:
        path_time_s: Where the path's clock stands [s] (NaN before the first valid message).
        pose_mm: The last position sent, sheet frame [mm].
    """

    def __init__(self, compensator: OnlineCompensator, robot: RobotDescription, guidance: GuidancePath,
                 port: int = 0, host: str = "127.0.0.1", force: ForceSource | None = None) -> None:
        super().__init__(compensator, robot, port, host, force)
        self.guidance = guidance
        self.path_time_s = math.nan
        self.pose_mm = np.array(guidance.points_mm[0], dtype=float)

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0,
              start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> ServeReport:
        """Answer messages until `max_cycles` were answered or none came for the start or idle timeout (as
        `EgmServer.serve`), each with the path's pose plus the correction."""
        pb = self.pb
        cycle = ServedCycle(self.compensator, self.robot, R_base_sheet)
        self.path_time_s, self.pose_mm[:] = math.nan, self.guidance.points_mm[0]  # a session's clock is its own
        R_sheet_base = np.array(R_base_sheet, dtype=float).T
        robot_msg, reply = pb.EgmRobot(), pb.EgmSensor()
        reply.header.mtype = pb.EgmHeader.MessageType.Value("MSGTYPE_CORRECTION")
        pos, orient = reply.planned.cartesian.pos, reply.planned.cartesian.orient
        q0 = self.guidance.quaternions[0]
        orient.u0, orient.u1, orient.u2, orient.u3 = (float(v) for v in q0)
        pos.x, pos.y, pos.z = (float(v) for v in self.pose_mm)
        axes = np.zeros(self.robot.dof)
        corr_sheet, point = np.zeros(3), np.zeros(3)
        last_tm: list[int] = []  # the stamp of the last valid message [ms]

        def answer(packet: bytes, received_s: float) -> bytes | None:
            if not read_feedback(robot_msg, packet, axes):
                return None
            tm = int(robot_msg.header.tm)
            t = received_s if self.force is not None else 1e-3 * tm
            feedback = robot_msg.feedBack.cartesian
            rejected = cycle.rejected
            if self._take_force(robot_msg, cycle, t) and finite_pose(
                    feedback.pos, feedback.orient if feedback.HasField("orient") else None):
                corr_base = cycle.step(t, axes)  # a joint not finite: rejected there
            else:
                corr_base = cycle.hold()
            reply.header.seqno += 1
            reply.header.tm = robot_msg.header.tm
            if cycle.rejected == rejected:  # a valid message: the clock moves by its stamp, the pose follows
                step = 0.0 if not last_tm else min(max(1e-3 * (tm - last_tm[0]), 0.0), MAX_STEP_S)
                last_tm[:] = [tm if not last_tm else max(tm, last_tm[0])]  # a stamp gone back is not the clock
                self.path_time_s = step if self.path_time_s != self.path_time_s else self.path_time_s + step
                k = self.guidance.at(self.path_time_s, point)
                np.dot(R_sheet_base, corr_base, out=corr_sheet)
                np.add(point, corr_sheet, out=self.pose_mm)
                pos.x, pos.y, pos.z = float(self.pose_mm[0]), float(self.pose_mm[1]), float(self.pose_mm[2])
                q = self.guidance.quaternions[k]
                orient.u0, orient.u1, orient.u2, orient.u3 = float(q[0]), float(q[1]), float(q[2]), float(q[3])
            return reply.SerializeToString()

        return serve_udp(self.sock, max_cycles, idle_timeout_s, answer, cycle, start_timeout_s)


def pose_of(reply: Any) -> tuple[np.ndarray, np.ndarray]:
    """An `EgmSensor`'s planned position [mm] and orientation (w x y z), for a reader of the answers."""
    c = reply.planned.cartesian
    return np.array([c.pos.x, c.pos.y, c.pos.z]), np.array([c.orient.u0, c.orient.u1, c.orient.u2, c.orient.u3])
