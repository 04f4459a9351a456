"""One served cycle, the part every interface shares: the controller's axes into the twin's joints, the F/T
sample into the compensator, its correction into the robot's base frame [mm].

Each interface (`rsi`, `egm`, `val3`) only reads its packet and writes its answer around `ServedCycle.step`; the
arrays are allocated once, here, so a cycle allocates nothing of its own.
"""

from __future__ import annotations

import math
import socket
from typing import NamedTuple, Protocol

import numpy as np

from twin.errors import InputError
from twin.robot.description import RobotDescription
from twin.sim.online import OnlineCompensator


class ServeReport(NamedTuple):
    """What a served session did.

    Attributes:
        cycles: Packets answered.
        unreadable: Packets that were not readable (answered with no correction change, or not answered).
        compute_us: Per-cycle compute (read, compensate, answer), shape (cycles,) [µs].
        stopped: Why the loop ended: "cycles", "idle" or "disconnected".
    """

    cycles: int
    unreadable: int
    compute_us: np.ndarray
    stopped: str


def udp_socket(host: str, port: int) -> tuple[socket.socket, int]:
    """A UDP socket bound to `host`:`port` (0: any free port) and the port it got.

    Raises:
        InputError: The address cannot be bound (naming it and why).
    """
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise InputError(f"cannot listen on {host}:{port} (UDP): {exc.strerror}") from None
    return sock, int(sock.getsockname()[1])


class Server(Protocol):
    """The twin's side of one real-time interface: bound to `port` when built, `serve` answers until its bound."""

    port: int

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0) -> ServeReport:
        """Answer the robot's packets until `max_cycles` were answered or none came for `idle_timeout_s` [s]."""
        ...

    def close(self) -> None:
        """Stop listening."""
        ...


class ServedCycle:
    """The compensator behind a controller's axes (module docstring).

    Args:
        compensator: The online compensator (its twin at the cell's placement).
        robot: The robot: its controller's axis signs and offsets turn the controller's axes into the twin's joints.
        R_base_sheet: The sheet's axes in the robot base (the compensator's frame into the robot's base frame).
    """

    def __init__(self, compensator: OnlineCompensator, robot: RobotDescription, R_base_sheet: np.ndarray) -> None:
        self.compensator = compensator
        self.R_base_sheet = np.array(R_base_sheet, dtype=float)
        self._sign = np.array(robot.controller_sign or (1.0,) * robot.dof)
        self._offset = np.array(robot.controller_offset_rad or (0.0,) * robot.dof)
        self.q_rad = np.zeros(robot.dof)
        self.force_n = np.zeros(3)
        self.stamp_s = math.nan
        self.correction_base_mm = np.zeros(3)

    def step(self, t_s: float, axes_deg: np.ndarray | tuple[float, ...]) -> np.ndarray:
        """One cycle: the controller's axes [deg] at time `t_s` [s], with the F/T sample last put in `force_n`
        (sheet frame [N]) measured at `stamp_s` [s] (NaN: none yet). Returns the correction, base frame [mm]
        (a view of `correction_base_mm`)."""
        self.q_rad[:] = axes_deg
        self.q_rad *= math.pi / 180.0
        self.q_rad -= self._offset
        self.q_rad /= self._sign
        self.compensator.step(t_s, self.stamp_s, self.force_n, self.q_rad)
        np.dot(self.R_base_sheet, self.compensator.correction_m, out=self.correction_base_mm)
        self.correction_base_mm *= 1e3
        return self.correction_base_mm
