"""KUKA RSI on the twin's side: a UDP server that answers each `<Rob>` packet with a `<Sen>` packet carrying the
online compensator's correction (`RKorr`) and echoing the packet's `IPOC`.

Each interpolation cycle (4 or 12 ms) the controller sends `<Rob Type="KUKA">` with the actual pose (`RIst`), the
axes (`AIPos`, degrees), the set-point axes (`ASPos`, degrees: the planned motion without the correction, which
signs the friction's lag, `twin.sim.online`) and `<IPOC>` (its time stamp, ms); the answer must come within the cycle (KUKA RSI; the
ros-industrial `kuka_rsi_hw_interface` reads the same fields). The F/T sample comes in the robot's packet, as an
`<FT Fx= Fy= Fz=/>` element the cell's RSI configuration adds from the sensor it reads (sheet frame, N); a packet
without one is a cycle without a new sample, which the compensator's watchdog handles. Or it comes from the
sensor's own stream (a `ForceSource`, e.g. ATI RDT), read by the server. `RKorr` X Y Z is the
correction in the **robot's base frame** [mm], absolute (`RSI_ON(#ABSOLUTE,#IPO_FAST)`: each answer the whole
correction, every 4 ms), A B C zero. Not in the program's `$BASE`, which is the sheet frame (`BASE_DATA[b]`, the
sheet's yaw): the exported RSI context (`twin.apps.export.krl_rsi`) has its POSCORR object correct in `#WORLD`,
which is the robot base when the cell's `$ROBROOT` is the null frame, as the program's header says; a cell with
another `$ROBROOT` would need the correction rotated (or sent in the sheet frame with POSCORR in `#BASE`).

The server's loop is bounded: it stops after `max_cycles` packets, when no first packet was answered within
`start_timeout_s`, or when none was answered for `idle_timeout_s` after the last. It answers one peer per session
(the first whose packet it took) and counts, never answers, any other sender's packets (`twin.apps.online.cycle`).
It reports the per-cycle compute time (parse, compensate, answer) and the packets it could not read. A packet with
an axis or a force not finite (`inf`, `nan`, `1e999`) is answered with the last correction, unchanged, and counted
unreadable: the compensator never sees it, and the session goes on.
"""

from __future__ import annotations

import re
from typing import NamedTuple

import numpy as np

from twin.apps.online.cycle import DEFAULT_START_TIMEOUT_S, ServedCycle, ServeReport, serve_udp, udp_socket
from twin.apps.online.source import ForceSource
from twin.errors import InputError
from twin.robot.facts import RobotDescription
from twin.sim.online import OnlineCompensator

_IPOC = re.compile(rb"<IPOC>\s*(\d+)\s*</IPOC>")
_AXES = re.compile(rb"<AIPos\b([^>]*)/>")
_PLANNED = re.compile(rb"<ASPos\b([^>]*)/>")
_FT = re.compile(rb"<FT\b([^>]*)/>")
_ATTR = re.compile(rb'(\w+)\s*=\s*"([^"]*)"')
#: The answer, its numbers filled in each cycle.
SEN = ('<Sen Type="ImFree"><RKorr X="{:.4f}" Y="{:.4f}" Z="{:.4f}" A="0.0000" B="0.0000" '
       'C="0.0000"/><IPOC>{}</IPOC></Sen>')


class RobPacket(NamedTuple):
    """What the twin reads of a `<Rob>` packet: the stamp [ms], the axes [deg], the F/T sample (sheet frame, N)
    or None, the set-point axes (`ASPos`) [deg] or None."""

    ipoc: int
    axes_deg: tuple[float, ...]
    force_n: tuple[float, float, float] | None
    planned_deg: tuple[float, ...] | None = None


def parse_rob(packet: bytes, dof: int) -> RobPacket:
    """Read a `<Rob>` packet.

    Raises:
        InputError: No `IPOC`, no `AIPos` with A1..A<dof> as numbers, or an `ASPos` without them (naming what is
            missing).
    """
    ipoc = _IPOC.search(packet)
    axes = _AXES.search(packet)
    if ipoc is None or axes is None:
        raise InputError(f"RSI packet without {'<IPOC>' if ipoc is None else '<AIPos .../>'}: {packet[:120]!r}")
    angles = _angles(axes, dof, "AIPos")
    aspos = _PLANNED.search(packet)
    planned = None if aspos is None else _angles(aspos, dof, "ASPos")
    ft = _FT.search(packet)
    force = None
    if ft is not None:
        f = dict(_ATTR.findall(ft.group(1)))
        try:
            force = (float(f[b"Fx"]), float(f[b"Fy"]), float(f[b"Fz"]))
        except (KeyError, ValueError):
            raise InputError(f"RSI packet's FT needs Fx, Fy, Fz as numbers [N]: {ft.group(0)!r}") from None
    return RobPacket(int(ipoc.group(1)), angles, force, planned)


def _angles(element: re.Match[bytes], dof: int, tag: str) -> tuple[float, ...]:
    """A1..A<dof> of an axes element [deg]."""
    attrs = dict(_ATTR.findall(element.group(1)))
    try:
        return tuple(float(attrs[f"A{i + 1}".encode()]) for i in range(dof))
    except (KeyError, ValueError):
        raise InputError(f"RSI packet's {tag} needs A1..A{dof} as numbers: {element.group(0)!r}") from None


def sen_packet(ipoc: int, correction_base_mm: np.ndarray) -> bytes:
    """The answer: `RKorr` X Y Z [mm] (base frame) and the echoed `IPOC`."""
    c = correction_base_mm
    return SEN.format(float(c[0]), float(c[1]), float(c[2]), ipoc).encode()


class RsiServer:
    """The twin's side of RSI on a UDP port (`serve`).

    Args:
        compensator: The online compensator (its twin at the cell's placement).
        robot: The robot (its controller's axis signs and offsets turn `AIPos` into the twin's joints).
        port: UDP port to listen on (0: any free one, see `port`).
        host: Address to bind (tests: 127.0.0.1).
        force: Where the F/T sample comes from (the sensor's own stream, `twin.apps.online.rdt`); None: the
            packets' `<FT>` element. With a source, the cycle's clock is the server's (`time.perf_counter`), as
            its samples are stamped.
    """

    def __init__(self, compensator: OnlineCompensator, robot: RobotDescription, port: int = 0,
                 host: str = "127.0.0.1", force: ForceSource | None = None) -> None:
        self.compensator, self.robot, self.force = compensator, robot, force
        self.sock, self.port = udp_socket(host, port)

    def close(self) -> None:
        """Stop listening."""
        self.sock.close()

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0,
              start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> ServeReport:
        """Answer packets until `max_cycles` were answered or none came for the start or idle timeout.

        Args:
            R_base_sheet: The sheet's axes in the robot base (the compensator's frame into RSI's base frame).
            max_cycles: Most packets to answer (a bound: the loop stops by itself).
            idle_timeout_s: Stop when no packet was answered for this long after the last [s].
            start_timeout_s: Stop when no first packet was answered for this long [s].
        """
        cycle = ServedCycle(self.compensator, self.robot, R_base_sheet)

        def answer(packet: bytes, received_s: float) -> bytes | None:
            try:
                rob = parse_rob(packet, self.robot.dof)
            except InputError:
                return None
            if self.force is not None:
                t = received_s
                cycle.take(self.force)
            else:
                t = 1e-3 * rob.ipoc
                if rob.force_n is not None and not cycle.put_force(*rob.force_n, t):
                    return sen_packet(rob.ipoc, cycle.hold())  # an F/T value not finite: the last correction
            return sen_packet(rob.ipoc, cycle.step(t, rob.axes_deg, rob.planned_deg))

        return serve_udp(self.sock, max_cycles, idle_timeout_s, answer, cycle, start_timeout_s)
