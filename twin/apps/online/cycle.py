"""One served cycle, the part every interface shares: the controller's axes into the twin's joints, the F/T
sample into the compensator, its correction into the robot's base frame [mm].

Each interface (`rsi`, `egm`, `val3`) only reads its packet and writes its answer around `ServedCycle.step`; the
arrays are allocated once, here, so a cycle allocates nothing of its own.
"""

from __future__ import annotations

import math
import socket
import time
from collections.abc import Callable
from typing import NamedTuple, Protocol

import numpy as np

from twin.apps.online.source import ForceSource
from twin.errors import InputError
from twin.robot.description import RobotDescription
from twin.sim.online import OnlineCompensator


class ServeReport(NamedTuple):
    """What a served session did.

    Attributes:
        cycles: Packets answered.
        unreadable: Packets that were not readable (answered with no correction change, or not answered), a
            value not finite (inf, NaN) among them.
        compute_us: Per-cycle compute (read, compensate, answer), shape (cycles,) [µs].
        stopped: Why the loop ended: "cycles", "idle" or "disconnected".
        refused: Further connections refused while a session ran (a TCP server serves one peer per session).
    """

    cycles: int
    unreadable: int
    compute_us: np.ndarray
    stopped: str
    refused: int = 0


#: The longest idle timeout a server takes [s] (an hour: a socket's timeout has a platform limit, and a session
#: that waits longer for its robot waits for nothing).
MAX_IDLE_TIMEOUT_S = 3600.0
#: The largest packet a UDP server reads [bytes] (an RSI or EGM packet is a few hundred).
MAX_PACKET = 4096


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


def check_bounds(max_cycles: int, idle_timeout_s: float) -> None:
    """Every server's loop is bounded: at least one cycle, an idle timeout > 0 and <= `MAX_IDLE_TIMEOUT_S`.

    Raises:
        InputError: Either is not (naming both).
    """
    if max_cycles < 1 or not 0 < idle_timeout_s <= MAX_IDLE_TIMEOUT_S:
        raise InputError(f"max_cycles {max_cycles!r} must be >= 1 and idle_timeout_s {idle_timeout_s!r} > 0 and <= "
                         f"{MAX_IDLE_TIMEOUT_S:g}")


def serve_udp(sock: socket.socket, max_cycles: int, idle_timeout_s: float,
              answer: Callable[[bytes, float], bytes | None], cycle: ServedCycle | None = None) -> ServeReport:
    """The loop of a UDP interface: each packet to `answer(packet, t_received)` (the time on `time.perf_counter`
    [s]), its reply sent back to the sender; None: the packet was unreadable (counted, not answered). Stops after
    `max_cycles` replies or when no packet was answered for `idle_timeout_s` [s] (a stream of unreadable packets
    does not keep it alive). The packets `cycle` rejected as not finite (`ServedCycle.rejected`) were answered
    with the held correction; they count among the cycles and the unreadable ones."""
    check_bounds(max_cycles, idle_timeout_s)
    compute = np.zeros(max_cycles)
    sock.settimeout(idle_timeout_s)
    cycles = unreadable = 0
    last_answer = time.perf_counter()
    stopped = "cycles"
    while cycles < max_cycles:
        try:
            packet, peer = sock.recvfrom(MAX_PACKET)
        except TimeoutError:
            stopped = "idle"
            break
        start = time.perf_counter()
        reply = answer(packet, start)
        if reply is None:
            unreadable += 1
            left = idle_timeout_s - (time.perf_counter() - last_answer)
            if left <= 0.0:
                stopped = "idle"
                break
            sock.settimeout(left)
            continue
        sock.sendto(reply, peer)
        last_answer = time.perf_counter()
        compute[cycles] = 1e6 * (last_answer - start)
        if unreadable:
            sock.settimeout(idle_timeout_s)
        cycles += 1
    rejected = 0 if cycle is None else cycle.rejected
    return ServeReport(cycles, unreadable + rejected, compute[:cycles], stopped)


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
        self.rejected = 0

    def take(self, source: ForceSource) -> None:
        """The force source's newest sample (stamped on `time.perf_counter`) into `force_n` and `stamp_s`; a
        sample not finite is not taken (the last one stays)."""
        source.poll()
        f = source.force_n
        if math.isfinite(f[0]) and math.isfinite(f[1]) and math.isfinite(f[2]):
            self.force_n[:] = f
            self.stamp_s = source.stamp_s

    def put_force(self, fx: float, fy: float, fz: float, stamp_s: float) -> bool:
        """A packet's F/T sample (sheet frame [N]) measured at `stamp_s` [s] into `force_n` and `stamp_s`.

        Returns:
            False, and nothing taken, when a value is not finite (inf, NaN, or a number too large for a float):
            the caller rejects the packet (`hold`).
        """
        if not (math.isfinite(fx) and math.isfinite(fy) and math.isfinite(fz) and math.isfinite(stamp_s)):
            return False
        self.force_n[0], self.force_n[1], self.force_n[2] = fx, fy, fz
        self.stamp_s = stamp_s
        return True

    def hold(self) -> np.ndarray:
        """A rejected packet's answer: the last correction, unchanged (zero before the first), counted in
        `rejected`. Returns a view of `correction_base_mm`."""
        self.rejected += 1
        return self.correction_base_mm

    def step(self, t_s: float, axes_deg: np.ndarray | tuple[float, ...]) -> np.ndarray:
        """One cycle: the controller's axes [deg] at time `t_s` [s], with the F/T sample last put in `force_n`
        (sheet frame [N]) measured at `stamp_s` [s] (NaN: none yet). Returns the correction, base frame [mm]
        (a view of `correction_base_mm`). A time or an axis not finite is not given to the compensator (its state
        would stay NaN): the cycle is rejected and answered with the last correction (`hold`)."""
        self.q_rad[:] = axes_deg
        if not (math.isfinite(t_s) and math.isfinite(float(self.q_rad.sum()))):
            return self.hold()
        self.q_rad *= math.pi / 180.0
        self.q_rad -= self._offset
        self.q_rad /= self._sign
        self.compensator.step(t_s, self.stamp_s, self.force_n, self.q_rad)
        np.dot(self.R_base_sheet, self.compensator.correction_m, out=self.correction_base_mm)
        self.correction_base_mm *= 1e3
        return self.correction_base_mm
