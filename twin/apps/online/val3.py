"""Stäubli VAL3 `alter` on the twin's side: a TCP server that answers each request of the robot's synchronous
task with the online compensator's correction, in the frames of `twin.apps.online.alter_protocol`.

The application `export --online` writes for a Stäubli (`twin.apps.export.val3_alter`) runs its path as `alterMovel`
moves and a synchronous task (`alterTask`, 4 ms) that sends the robot's joints (`herej()`, degrees) with a sequence
number and applies the twin's answer with `alter()`: the absolute correction in the robot's world/base frame [mm].
The robot is the TCP client (its `sio` socket `twin`); this server accepts one connection and answers each request
at once, echoing its sequence number. One peer per session: a further connection while the session runs is closed
at once (never left waiting for an answer), counted (`ServeReport.refused`) and logged with its address.

A VAL3 cell has no F/T channel in the robot's frame (unlike an RSI diagram), so the F/T sample comes from a
`ForceSource` on the PC (the sensor's own stream, `twin.apps.online.rdt`), polled once per request; its stamps and
the cycle's time are both on this process's `time.perf_counter` clock, so the compensator's watchdog compares
like with like. Without a force source the stamp stays NaN and the compensator corrects nothing (no start without
a sensor): every answer is zero.

The loop is bounded: it stops after `max_cycles` requests answered, when no connection and first request came
within `start_timeout_s` ("start_timeout"), when no request came for `idle_timeout_s` after the last answer, or when
the robot closes the connection. A request it cannot read (a negative sequence number, a joint not finite) is
counted unreadable and answered with the last correction and the frame's sequence number field (0 when negative).
A frame that holds `MAGIC` after its first byte is a stream out of step (stray bytes before a frame, a frame cut
short and the next one begun): the bytes before that magic are dropped unanswered (counted unreadable) and the
frame read from there, so one bad frame never puts every later one out of step; a wrong magic with none further on
is answered as unreadable. (A sequence number 826366804 or a joint of 2.8e-9 deg, whose bytes spell "TWA1", would
read as such a stream: a frame lost, no more.) Each cycle reads into, and answers from, buffers allocated once;
only the frame's unpacking makes a small tuple (and a resynchronisation, which is rare, one copy).
"""

from __future__ import annotations

import contextlib
import select
import socket
import sys
import time
from collections.abc import Callable

import numpy as np

from twin.apps.online.alter_protocol import (
    ANSWER_BYTES,
    JOINTS,
    MAGIC_BYTES,
    REQUEST_BYTES,
    decode_request_into,
    encode_answer_into,
    frame_seq,
)
from twin.apps.online.cycle import DEFAULT_START_TIMEOUT_S, ServedCycle, ServeReport, check_bounds
from twin.apps.online.source import ForceSource
from twin.errors import InputError
from twin.robot.facts import RobotDescription
from twin.sim.online import OnlineCompensator

__all__ = ["ServeReport", "Val3Server"]


class Val3Server:
    """The twin's side of the VAL3 `alter` task on a TCP port (`serve`).

    Args:
        compensator: The online compensator (its twin at the cell's placement).
        robot: The robot (its controller's axis signs and offsets turn `herej()`'s joints into the twin's).
        port: TCP port to listen on (0: any free one, see `port`; the controller's socket connects to
            `alter_protocol.DEFAULT_PORT` unless configured otherwise).
        host: Address to bind (tests: 127.0.0.1; a cell: the PC's address on the robot's network).
        force: Where the F/T sample comes from; None: no sensor, so no correction.
        log: Where the line about a refused second connection goes (default: stderr).

    Raises:
        InputError: A robot without six joints (the frames carry six), or a port that cannot be listened on.
    """

    def __init__(self, compensator: OnlineCompensator, robot: RobotDescription, port: int = 0,
                 host: str = "127.0.0.1", force: ForceSource | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        if robot.dof != JOINTS:
            raise InputError(f"robot {robot.name!r} has {robot.dof} joints; the VAL3 alter frames carry {JOINTS}")
        self.compensator, self.robot, self.force = compensator, robot, force
        self.log: Callable[[str], None] = log if log is not None else _stderr
        self.refused = 0
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.sock.bind((host, port))
            self.sock.listen(1)
        except OSError as exc:
            self.sock.close()
            raise InputError(f"cannot listen on {host}:{port} (TCP): {exc.strerror}") from None
        self.port = int(self.sock.getsockname()[1])

    def close(self) -> None:
        """Stop listening."""
        self.sock.close()

    def serve(self, R_base_sheet: np.ndarray, max_cycles: int, idle_timeout_s: float = 1.0,
              start_timeout_s: float = DEFAULT_START_TIMEOUT_S) -> ServeReport:
        """Accept the robot's connection and answer its requests until `max_cycles` were answered, no connection
        and first request came within `start_timeout_s`, none came for `idle_timeout_s` after the last answer, or
        the robot closed the connection.

        Args:
            R_base_sheet: The sheet's axes in the robot base (the compensator's frame into the base frame that
                `alterBegin(world, ...)` alters in).
            max_cycles: Most requests to answer (a bound: the loop stops by itself).
            idle_timeout_s: Stop when no request came for this long after the last answer [s].
            start_timeout_s: Stop when no connection and first request came for this long [s].

        Returns:
            Requests answered (the unreadable ones among them), per-cycle compute [µs], why it stopped:
            "cycles", "idle", "disconnected" or "start_timeout", and the further connections refused meanwhile.
        """
        check_bounds(max_cycles, idle_timeout_s, start_timeout_s)
        cycle = ServedCycle(self.compensator, self.robot, R_base_sheet)
        compute = np.zeros(max_cycles)
        self.refused = 0
        start_deadline = time.perf_counter() + start_timeout_s
        self.sock.settimeout(start_timeout_s)
        try:
            conn, peer = self.sock.accept()
        except TimeoutError:
            return cycle.report(0, 0, compute[:0], "start_timeout")
        with conn:
            conn.settimeout(max(idle_timeout_s, start_timeout_s))
            with contextlib.suppress(OSError):  # a socket that cannot take the option still works
                conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            cycles, unreadable, stopped = self._answer(conn, cycle, compute, max_cycles, idle_timeout_s, peer,
                                                       start_deadline)
            self._refuse_waiting(peer)  # none left waiting in the backlog for a session that is over
        return cycle.report(cycles, unreadable, compute[:cycles], stopped, self.refused)

    def _refuse(self, peer: object) -> None:
        """Close a connection that came while a session runs, count it and log a line."""
        try:
            extra, address = self.sock.accept()
        except OSError:  # it went away before it was taken
            return
        extra.close()
        self.refused += 1
        self.log(f"online val3: refused a second connection from {_address(address)} while the session with "
                 f"{_address(peer)} runs (one peer per session); {self.refused} refused so far")

    def _refuse_waiting(self, peer: object) -> None:
        """Refuse every connection already waiting to be accepted (bounded: the listen backlog)."""
        for _ in range(64):
            if self.sock.fileno() < 0 or not select.select([self.sock], [], [], 0.0)[0]:
                return
            self._refuse(peer)

    def _wait(self, conn: socket.socket, deadline: float, peer: object) -> bool:
        """Wait until the robot's connection has bytes (True) or `deadline` passed (False), refusing any further
        connection meanwhile."""
        while True:
            left = deadline - time.perf_counter()
            if left <= 0.0:
                return False
            ready, _, _ = select.select([conn, self.sock], [], [], left)
            if self.sock in ready:
                self._refuse(peer)
            if conn in ready:
                return True

    def _answer(self, conn: socket.socket, cycle: ServedCycle, compute: np.ndarray, max_cycles: int,
                idle_timeout_s: float, peer: object, start_deadline: float) -> tuple[int, int, str]:
        """The request loop on one connection; returns (answered, unreadable, why it stopped)."""
        request = bytearray(REQUEST_BYTES)
        view = memoryview(request)
        answer = bytearray(ANSWER_BYTES)
        axes_deg = np.zeros(JOINTS)
        cycles = unreadable = got = 0
        while cycles < max_cycles:
            deadline = start_deadline if cycles == 0 else time.perf_counter() + idle_timeout_s
            silent = "start_timeout" if cycles == 0 else "idle"
            while got < REQUEST_BYTES:  # a stream: a frame may come in pieces
                if not self._wait(conn, deadline, peer):
                    return cycles, unreadable, silent
                try:
                    n = conn.recv_into(view[got:], REQUEST_BYTES - got)
                except TimeoutError:
                    return cycles, unreadable, silent
                except OSError:  # reset by the robot
                    return cycles, unreadable, "disconnected"
                if n == 0:
                    return cycles, unreadable, "disconnected"
                got += n
            at = request.find(MAGIC_BYTES, 1)
            if at > 0:  # out of step: drop what comes before the next frame's magic, read that frame to its end
                unreadable += 1
                request[:REQUEST_BYTES - at] = request[at:]
                got = REQUEST_BYTES - at
                continue
            got = 0
            start = time.perf_counter()
            try:
                seq = decode_request_into(request, axes_deg)
            except InputError:
                unreadable += 1
                seq = max(frame_seq(request), 0)
                encode_answer_into(answer, seq, cycle.correction_base_mm)  # the last correction, unchanged
            else:
                if self.force is not None:
                    cycle.take(self.force)
                encode_answer_into(answer, seq, cycle.step(time.perf_counter(), axes_deg))
            try:
                conn.sendall(answer)
            except OSError:
                return cycles, unreadable, "disconnected"
            compute[cycles] = 1e6 * (time.perf_counter() - start)
            cycles += 1
        return cycles, unreadable, "cycles"


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _address(address: object) -> str:
    """host:port of a peer's address tuple."""
    if isinstance(address, tuple) and len(address) >= 2:
        return f"{address[0]}:{address[1]}"
    return str(address)
