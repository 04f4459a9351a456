"""KUKA RSI on the twin's side: a UDP server that answers each `<Rob>` packet with a `<Sen>` packet carrying the
online compensator's correction (`RKorr`) and echoing the packet's `IPOC`.

Each interpolation cycle (4 or 12 ms) the controller sends `<Rob Type="KUKA">` with the actual pose (`RIst`), the
axes (`AIPos`, degrees) and `<IPOC>` (its time stamp, ms); the answer must come within the cycle (KUKA RSI; the
ros-industrial `kuka_rsi_hw_interface` reads the same fields). The F/T sample comes in the robot's packet, as an
`<FT Fx= Fy= Fz=/>` element the cell's RSI configuration adds from the sensor it reads (sheet frame, N); a packet
without one is a cycle without a new sample, which the compensator's watchdog handles. `RKorr` X Y Z is the
correction in the robot's base frame [mm], absolute (the RSI object's correction mode `#ABSOLUTE`), A B C zero.

The server's loop is bounded: it stops after `max_cycles` packets, or when no packet came for `idle_timeout_s`.
It reports the per-cycle compute time (parse, compensate, answer) and the packets it could not read.
"""

from __future__ import annotations

import math
import re
import socket
import time
from typing import NamedTuple

import numpy as np

from twin.errors import InputError
from twin.robot.description import RobotDescription
from twin.sim.online import OnlineCompensator

_IPOC = re.compile(rb"<IPOC>\s*(\d+)\s*</IPOC>")
_AXES = re.compile(rb"<AIPos\b([^>]*)/>")
_FT = re.compile(rb"<FT\b([^>]*)/>")
_ATTR = re.compile(rb'(\w+)\s*=\s*"([^"]*)"')
#: The answer, its numbers filled in each cycle.
SEN = ('<Sen Type="ImFree"><RKorr X="{:.4f}" Y="{:.4f}" Z="{:.4f}" A="0.0000" B="0.0000" '
       'C="0.0000"/><IPOC>{}</IPOC></Sen>')
MAX_PACKET = 4096


class RobPacket(NamedTuple):
    """What the twin reads of a `<Rob>` packet: the stamp [ms], the axes [deg], the F/T sample (sheet frame, N)
    or None."""

    ipoc: int
    axes_deg: tuple[float, ...]
    force_n: tuple[float, float, float] | None


def parse_rob(packet: bytes, dof: int) -> RobPacket:
    """Read a `<Rob>` packet.

    Raises:
        InputError: No `IPOC`, or no `AIPos` with A1..A<dof> as numbers (naming what is missing).
    """
    ipoc = _IPOC.search(packet)
    axes = _AXES.search(packet)
    if ipoc is None or axes is None:
        raise InputError(f"RSI packet without {'<IPOC>' if ipoc is None else '<AIPos .../>'}: {packet[:120]!r}")
    attrs = dict(_ATTR.findall(axes.group(1)))
    try:
        angles = tuple(float(attrs[f"A{i + 1}".encode()]) for i in range(dof))
    except (KeyError, ValueError):
        raise InputError(f"RSI packet's AIPos needs A1..A{dof} as numbers: {axes.group(0)!r}") from None
    ft = _FT.search(packet)
    force = None
    if ft is not None:
        f = dict(_ATTR.findall(ft.group(1)))
        try:
            force = (float(f[b"Fx"]), float(f[b"Fy"]), float(f[b"Fz"]))
        except (KeyError, ValueError):
            raise InputError(f"RSI packet's FT needs Fx, Fy, Fz as numbers [N]: {ft.group(0)!r}") from None
    return RobPacket(int(ipoc.group(1)), angles, force)


def sen_packet(ipoc: int, correction_base_mm: np.ndarray) -> bytes:
    """The answer: `RKorr` X Y Z [mm] (base frame) and the echoed `IPOC`."""
    c = correction_base_mm
    return SEN.format(float(c[0]), float(c[1]), float(c[2]), ipoc).encode()


class ServeReport(NamedTuple):
    """What a served session did.

    Attributes:
        cycles: Packets answered.
        unreadable: Packets that were not a readable `<Rob>` (answered with no correction change).
        compute_us: Per-cycle compute (parse, compensate, answer), shape (cycles,) [µs].
        stopped: Why the loop ended: "cycles" or "idle".
    """

    cycles: int
    unreadable: int
    compute_us: np.ndarray
    stopped: str


class RsiServer:
    """The twin's side of RSI on a UDP port (`serve`).

    Args:
        compensator: The online compensator (its twin at the cell's placement).
        robot: The robot (its controller's axis signs and offsets turn `AIPos` into the twin's joints).
        port: UDP port to listen on (0: any free one, see `port`).
        host: Address to bind (tests: 127.0.0.1).
    """

    def __init__(self, compensator: OnlineCompensator, robot: RobotDescription, port: int = 0,
                 host: str = "127.0.0.1") -> None:
        self.compensator, self.robot = compensator, robot
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((host, port))
        except OSError as exc:
            self.sock.close()
            raise InputError(f"cannot listen on {host}:{port} (UDP): {exc.strerror}") from None
        self.port = int(self.sock.getsockname()[1])
        sign = np.array(robot.controller_sign or (1.0,) * robot.dof)
        offset = np.array(robot.controller_offset_rad or (0.0,) * robot.dof)
        self._sign, self._offset = sign, offset
        self._q = np.zeros(robot.dof)
        self._f = np.zeros(3)
        self._c_base_mm = np.zeros(3)

    def close(self) -> None:
        """Stop listening."""
        self.sock.close()

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0) -> ServeReport:
        """Answer packets until `max_cycles` were answered or none came for `idle_timeout_s`.

        Args:
            R_base_sheet: The sheet's axes in the robot base (the compensator's frame into RSI's base frame).
            max_cycles: Most packets to answer (a bound: the loop stops by itself).
            idle_timeout_s: Stop when no packet came for this long [s].
        """
        if max_cycles < 1 or not idle_timeout_s > 0:
            raise InputError(f"max_cycles {max_cycles!r} must be >= 1 and idle_timeout_s {idle_timeout_s!r} > 0")
        R = np.asarray(R_base_sheet, dtype=float)
        compute = np.zeros(max_cycles)
        self.sock.settimeout(idle_timeout_s)
        cycles = unreadable = 0
        stopped = "cycles"
        stamp = math.nan
        while cycles < max_cycles:
            try:
                packet, peer = self.sock.recvfrom(MAX_PACKET)
            except TimeoutError:
                stopped = "idle"
                break
            start = time.perf_counter()
            try:
                rob = parse_rob(packet, self.robot.dof)
            except InputError:
                unreadable += 1
                continue
            t = 1e-3 * rob.ipoc
            self._q[:] = rob.axes_deg
            self._q *= math.pi / 180.0
            self._q -= self._offset
            self._q /= self._sign
            if rob.force_n is not None:
                self._f[:] = rob.force_n
                stamp = t
            self.compensator.step(t, stamp, self._f, self._q)
            np.dot(R, self.compensator.correction_m, out=self._c_base_mm)
            self._c_base_mm *= 1e3
            self.sock.sendto(sen_packet(rob.ipoc, self._c_base_mm), peer)
            compute[cycles] = 1e6 * (time.perf_counter() - start)
            cycles += 1
        return ServeReport(cycles, unreadable, compute[:cycles], stopped)
