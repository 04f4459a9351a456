"""One served cycle, the part every interface shares: the controller's axes into the twin's joints, the F/T
sample into the compensator, its correction into the robot's base frame [mm].

Each interface (`rsi`, `egm`, `val3`) only reads its packet and writes its answer around `ServedCycle.step`; the
arrays are allocated once, here, so a cycle allocates nothing of its own.

What every session does with its input, whatever the interface:

* **one peer**: a UDP server answers the first sender whose packet it could read and take (`serve_udp`); packets
  from any other address are counted (`ServeReport.foreign`), never answered, never given to the compensator. The
  TCP server (`val3`) takes one connection and closes any other at once.
* **start, then idle**: the server waits `start_timeout_s` for its first answered packet (a robot program is
  started by hand after the twin; default `DEFAULT_START_TIMEOUT_S`), then stops when none was answered for
  `idle_timeout_s`. A session that answered nothing stops as "start_timeout".
* **rate per second**: the correction moves at most `OnlineSettings.max_rate_mm_s` [mm/s] per second of the
  cycle's clock *and* of the server's clock (`time.perf_counter`), and never more than one `cycle_s` worth in one
  cycle: a burst of packets (50 in 5 ms) moves it by 5 ms worth, not by 50 cycles' worth.
* **samples, not cycles**: the compensator's spike test sees each F/T sample once. A source's sample is new when
  its stamp is; a packet's force (which carries no sample number) that equals the last rejected spike is that
  sample held by a sensor slower than the cycle, not tested again. A sensor that sticks at one value after a jump
  is so never taken: the watchdog holds the correction, then ramps it out.
* **counted**: cycles with no sample yet (`no_sample`: zero correction), cycles whose sample was stale (`stale`:
  the watchdog held or ramped out), spikes rejected; the task reports them and fails a session that never had a
  sample.
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
from twin.robot.facts import RobotDescription
from twin.sim.online import HOLDING, NO_SENSOR, RAMPING, SPIKE, OnlineCompensator
from twin.sim.online_settings import AT_LIMIT_MM


class ServeReport(NamedTuple):
    """What a served session did.

    Attributes:
        cycles: Packets answered.
        unreadable: Packets that were not readable (answered with no correction change, or not answered), a
            value not finite (inf, NaN) among them.
        compute_us: Per-cycle compute (read, compensate, answer), shape (cycles,) [µs].
        stopped: Why the loop ended: "cycles", "idle", "disconnected" or "start_timeout" (nothing answered).
        refused: Further connections refused while a session ran (a TCP server serves one peer per session).
        foreign: Packets from another address than the session's peer, ignored (a UDP server).
        no_sample: Cycles answered before the compensator had any F/T sample (zero correction).
        stale: Cycles whose newest sample was older than the watchdog's `stale_s` (held, then ramped out).
        spikes: F/T samples rejected as spikes.
        sampled: Whether the compensator had an F/T sample in any cycle.
        at_limit: Cycles answered with the correction at its size limit, `limit_mm` (a cell that bends further than
            the limit lets the correction follow: raise `--max-correction-mm`).
        limit_mm: The correction's size limit [mm].
        rate_mm_s: Its rate limit [mm/s].
    """

    cycles: int
    unreadable: int
    compute_us: np.ndarray
    stopped: str
    refused: int = 0
    foreign: int = 0
    no_sample: int = 0
    stale: int = 0
    spikes: int = 0
    sampled: bool = False
    at_limit: int = 0
    limit_mm: float = math.nan
    rate_mm_s: float = math.nan


#: The longest idle or start timeout a server takes [s] (an hour: a socket's timeout has a platform limit, and a
#: session that waits longer for its robot waits for nothing).
MAX_IDLE_TIMEOUT_S = 3600.0
#: How long a server waits for its first packet by default [s]: the robot's program is started after the twin.
DEFAULT_START_TIMEOUT_S = 60.0
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


def check_bounds(max_cycles: int, idle_timeout_s: float, start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> None:
    """Every server's loop is bounded: at least one cycle, idle and start timeouts > 0 and <= `MAX_IDLE_TIMEOUT_S`.

    Raises:
        InputError: One is not (naming them).
    """
    if (max_cycles < 1 or not 0 < idle_timeout_s <= MAX_IDLE_TIMEOUT_S
            or not 0 < start_timeout_s <= MAX_IDLE_TIMEOUT_S):
        raise InputError(f"max_cycles {max_cycles!r} must be >= 1, idle_timeout_s {idle_timeout_s!r} and "
                         f"start_timeout_s {start_timeout_s!r} > 0 and <= {MAX_IDLE_TIMEOUT_S:g}")


def serve_udp(sock: socket.socket, max_cycles: int, idle_timeout_s: float,
              answer: Callable[[bytes, float], bytes | None], cycle: ServedCycle,
              start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> ServeReport:
    """The loop of a UDP interface: each packet to `answer(packet, t_received)` (the time on `time.perf_counter`
    [s]), its reply sent back to the sender; None: the packet was unreadable (counted, not answered).

    The first sender answered with a cycle `cycle` took (not rejected) is the session's peer; packets from any other
    address are counted in `foreign` and dropped unread. Stops after `max_cycles` replies, when no packet was
    answered for `start_timeout_s` [s] before the first reply or `idle_timeout_s` [s] after the last (a stream of
    unreadable or foreign packets keeps neither alive). The packets `cycle` rejected as not finite
    (`ServedCycle.rejected`) were answered with the held correction; they count among the cycles and the
    unreadable ones.
    """
    check_bounds(max_cycles, idle_timeout_s, start_timeout_s)
    compute = np.zeros(max_cycles)
    cycles = unreadable = foreign = 0
    peer: object = None
    deadline = time.perf_counter() + start_timeout_s
    stopped = "cycles"
    while cycles < max_cycles:
        left = deadline - time.perf_counter()
        if left <= 0.0:
            stopped = "idle" if cycles else "start_timeout"
            break
        sock.settimeout(left)
        try:
            packet, sender = sock.recvfrom(MAX_PACKET)
        except TimeoutError:
            continue
        if peer is not None and sender != peer:
            foreign += 1
            continue
        start = time.perf_counter()
        rejected = cycle.rejected
        reply = answer(packet, start)
        if reply is None:
            unreadable += 1
            continue
        sock.sendto(reply, sender)
        if peer is None and cycle.rejected == rejected:
            peer = sender
        now = time.perf_counter()
        compute[cycles] = 1e6 * (now - start)
        deadline = now + idle_timeout_s
        cycles += 1
    return cycle.report(cycles, unreadable, compute[:cycles], stopped, foreign=foreign)


class Server(Protocol):
    """The twin's side of one real-time interface: bound to `port` when built, `serve` answers until its bound."""

    port: int

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0,
              start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> ServeReport:
        """Answer the robot's packets until `max_cycles` were answered, none came for `start_timeout_s` [s] before
        the first or for `idle_timeout_s` [s] after the last."""
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
        self.q_planned_rad = np.zeros(robot.dof)
        self.force_n = np.zeros(3)
        self.stamp_s = math.nan
        self.correction_base_mm = np.zeros(3)
        self.rejected = self.no_sample = self.stale = self.at_limit = 0
        self._limit_m = 1e-3 * (compensator.settings.max_correction_mm - AT_LIMIT_MM)  # at the size limit [m]
        self.sampled = False
        self._spikes0 = compensator.spikes_rejected
        self._rate_m_s = 1e-3 * compensator.settings.max_rate_mm_s
        self._cycle_s = compensator.settings.cycle_s
        self._before_m = np.zeros(3)  # the correction before this cycle's step, sheet frame [m]
        self._t_prev = self._wall_prev = math.nan  # the last step's cycle time and server time [s]
        self._given_stamp = math.nan  # the stamp of the sample last given to the compensator [s]
        self._spike_n = np.full(3, math.nan)  # the last sample rejected as a spike [N]

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

    def step(self, t_s: float, axes_deg: np.ndarray | tuple[float, ...],
             planned_deg: np.ndarray | tuple[float, ...] | None = None) -> np.ndarray:
        """One cycle: the controller's axes [deg] at time `t_s` [s] (and its planned axes [deg], without the
        correction, where its interface reports them: their motion signs the friction's lag, `twin.sim.online`),
        with the F/T sample last put in `force_n`
        (sheet frame [N]) measured at `stamp_s` [s] (NaN: none yet). Returns the correction, base frame [mm]
        (a view of `correction_base_mm`). A time or an axis not finite is not given to the compensator (its state
        would stay NaN): the cycle is rejected and answered with the last correction (`hold`). A sample already
        given, or a packet's force equal to the last spike, is not a new sample (module docstring); the
        correction's change is bounded per second (`_limit_rate`)."""
        planned = None if planned_deg is None else self.q_planned_rad
        if not (math.isfinite(t_s) and self._joints(axes_deg, self.q_rad)
                and (planned_deg is None or self._joints(planned_deg, self.q_planned_rad))):
            return self.hold()
        f, spike = self.force_n, self._spike_n
        sample_s = self.stamp_s
        if sample_s == self._given_stamp or (f[0] == spike[0] and f[1] == spike[1] and f[2] == spike[2]):
            sample_s = math.nan  # no new sample this cycle: the compensator's clock and watchdog go on
        self._before_m[:] = self.compensator.correction_m
        status = self.compensator.step(t_s, sample_s, f, self.q_rad, planned)
        if status == SPIKE:
            spike[:] = f
        elif sample_s == sample_s:  # a new sample taken: the spike (if any) is over
            spike[:] = math.nan
        if sample_s == sample_s:
            self._given_stamp = sample_s
        self._limit_rate(t_s)
        c = self.compensator.correction_m
        if c[0] * c[0] + c[1] * c[1] + c[2] * c[2] >= self._limit_m * self._limit_m:
            self.at_limit += 1
        if status == NO_SENSOR:
            self.no_sample += 1
        elif status in (HOLDING, RAMPING):
            self.stale += 1
            self.sampled = True
        else:
            self.sampled = True
        np.dot(self.R_base_sheet, self.compensator.correction_m, out=self.correction_base_mm)
        self.correction_base_mm *= 1e3
        return self.correction_base_mm

    def _joints(self, axes_deg: np.ndarray | tuple[float, ...], out: np.ndarray) -> bool:
        """The controller's axes [deg] as the twin's joints [rad], into `out`; False (out not to be used) for an
        axis not finite."""
        out[:] = axes_deg
        if not math.isfinite(float(out.sum())):
            return False
        out *= math.pi / 180.0
        out -= self._offset
        out /= self._sign
        return True

    def _limit_rate(self, t_s: float) -> None:
        """Bound this step of the compensator's correction (in place) to `max_rate_mm_s` times the time since the
        last step, on the cycle's clock and on the server's, whichever is shorter, and at most one `cycle_s`."""
        wall = time.perf_counter()
        dt = self._cycle_s
        if self._t_prev == self._t_prev:
            dt = min(dt, t_s - self._t_prev, wall - self._wall_prev)
        self._t_prev, self._wall_prev = t_s, wall
        allowed = self._rate_m_s * max(dt, 0.0)
        c, b = self.compensator.correction_m, self._before_m
        d0, d1, d2 = c[0] - b[0], c[1] - b[1], c[2] - b[2]
        size = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if size > allowed:
            scale = allowed / size
            c[0], c[1], c[2] = b[0] + d0 * scale, b[1] + d1 * scale, b[2] + d2 * scale

    def report(self, cycles: int, unreadable: int, compute_us: np.ndarray, stopped: str, refused: int = 0,
               foreign: int = 0) -> ServeReport:
        """The session's `ServeReport`, with this cycle's counts (the packets rejected as not finite added to
        `unreadable`)."""
        return ServeReport(cycles, unreadable + self.rejected, compute_us, stopped, refused, foreign,
                           self.no_sample, self.stale, self.compensator.spikes_rejected - self._spikes0,
                           self.sampled, self.at_limit, self.compensator.settings.max_correction_mm,
                           self.compensator.settings.max_rate_mm_s)
