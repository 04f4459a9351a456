"""Stäubli VAL3 `alter` on loopback: a client thread plays the robot's synchronous task at 4 ms over TCP 127.0.0.1
(the frames of `twin.apps.online.alter_protocol`); the twin's server answers each request with the compensator's
correction and its sequence number. The F/T sample comes from a source the test drives, so that a compensator of
the test's own, fed the same samples and stamps, gives the same correction. Bounded: every loop has its count or
timeout, every socket is closed."""

from __future__ import annotations

import math
import socket
import struct
import threading
import time
from collections.abc import Callable

import numpy as np
import pytest

from twin.apps.online import alter_protocol as proto
from twin.apps.online.cycle import ServeReport
from twin.apps.online.val3 import Val3Server
from twin.errors import InputError
from twin.robot.description import load_robot
from twin.sim.online import OnlineCompensator
from twin.sim.spec import TwinSpec

CYCLES = 250  # 1 s at 4 ms


def _ft(k: int) -> np.ndarray:
    return np.array([200.0, -50.0, 1500.0]) * min(1.0, k / 100.0)  # the force builds up over 0.4 s, then holds


class DrivenSource:
    """A `ForceSource` the robot's thread drives: it sets the next sample and its stamp before each request; the
    server's `poll` takes it. The stamps are `time.perf_counter` readings, the server's clock."""

    def __init__(self) -> None:
        self.force_n = np.zeros(3)
        self.stamp_s = math.nan
        self._next: tuple[np.ndarray, float] | None = None

    def put(self, force_n: np.ndarray, stamp_s: float) -> None:
        self._next = (force_n, stamp_s)

    def poll(self) -> int:
        if self._next is None:
            return 0
        self.force_n[:], self.stamp_s = self._next
        self._next = None
        return 1

    def close(self) -> None:
        self._next = None


def _recv(sock: socket.socket, n: int) -> bytes:
    """Exactly `n` bytes (a stream may deliver a frame in pieces)."""
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        assert chunk, "the server closed the connection"
        data += chunk
    return data


def _serve(server: Val3Server, cycles: int, robot: Callable[[socket.socket], None],
           idle_timeout_s: float = 2.0) -> ServeReport:
    """Run `server.serve` in a thread while `robot` talks to it on a fresh connection; close everything."""
    twin = TwinSpec().build()
    report: dict[str, ServeReport] = {}
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, cycles,
                                                                                  idle_timeout_s)))
    thread.start()
    client = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
    try:
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        robot(client)
    finally:
        client.close()
        thread.join(timeout=10.0)
        server.close()
    assert not thread.is_alive()
    return report["r"]


def _q_deg() -> np.ndarray:
    robot = load_robot()
    return np.degrees(robot.controller_angles(np.array(robot.q_home_rad)))


def test_frames_encode_decode_and_refuse_what_is_not_one() -> None:
    frame = proto.encode_request(7, np.arange(6.0) - 2.5)
    assert len(frame) == proto.REQUEST_BYTES == 32 and frame[:4] == b"TWA1"
    assert proto.decode_request(frame) == (7, (-2.5, -1.5, -0.5, 0.5, 1.5, 2.5)) and proto.frame_seq(frame) == 7
    answer = proto.decode_answer(proto.encode_answer(7, np.array([1.25, -0.5, 4.0])))
    assert answer == (7, (1.25, -0.5, 4.0)) and proto.ANSWER_BYTES == 20
    with pytest.raises(InputError, match="magic"):
        proto.decode_request(b"XXXX" + frame[4:])
    with pytest.raises(InputError, match="expected 32"):
        proto.decode_request(frame[:-1])
    with pytest.raises(InputError, match="joint 2"):
        proto.decode_request(struct.pack("<ii6f", proto.MAGIC, 3, 0.0, math.nan, 0, 0, 0, 0))
    with pytest.raises(InputError, match="sequence number"):
        proto.encode_request(-1, np.zeros(6))
    with pytest.raises(InputError, match="6 joints"):
        proto.encode_request(1, np.zeros(5))
    with pytest.raises(InputError, match="finite"):
        proto.encode_answer(1, np.array([0.0, math.inf, 0.0]))
    with pytest.raises(InputError, match="magic"):
        proto.decode_answer(b"\0" * proto.ANSWER_BYTES)


def test_the_server_answers_every_request_with_the_compensators_correction() -> None:
    spec = TwinSpec()
    source = DrivenSource()
    server = Val3Server(OnlineCompensator(spec), load_robot(), force=source)
    q_deg = _q_deg()
    stamps: list[float] = []
    answers: list[proto.Answer] = []
    round_trip: list[float] = []

    def robot(client: socket.socket) -> None:
        start = time.perf_counter()
        for k in range(CYCLES):
            stamps.append(time.perf_counter())
            source.put(_ft(k), stamps[-1])  # the sensor's sample of this cycle, stamped now
            client.sendall(proto.encode_request(k + 1, q_deg))
            answers.append(proto.decode_answer(_recv(client, proto.ANSWER_BYTES)))
            round_trip.append(time.perf_counter() - stamps[-1])
            time.sleep(max(0.0, start + 0.004 * (k + 1) - time.perf_counter()))

    r = _serve(server, CYCLES, robot)
    assert r.cycles == CYCLES and r.unreadable == 0 and r.stopped == "cycles" and r.compute_us.shape == (CYCLES,)
    assert [a.seq for a in answers] == list(range(1, CYCLES + 1))
    # the same samples and stamps through a compensator of our own: the last answer, base frame, mm
    direct = OnlineCompensator(spec)
    robot_q = np.array(load_robot().q_home_rad)
    for k in range(CYCLES):
        direct.step(stamps[k], stamps[k], _ft(k), robot_q)
    expected_mm = 1e3 * spec.build().R_base_sheet @ direct.correction_m
    last = np.array(answers[-1].correction_mm)
    np.testing.assert_allclose(last, expected_mm, atol=1e-4)
    assert np.linalg.norm(last) > 0.5
    print(f"round trip p50 {1e3 * np.median(round_trip):.3f} ms, p99 {1e3 * np.percentile(round_trip, 99):.3f} ms; "
          f"compute p99 {np.percentile(r.compute_us, 99):.1f} us")


def test_without_a_force_source_every_correction_is_zero() -> None:
    server = Val3Server(OnlineCompensator(TwinSpec()), load_robot())
    q_deg = _q_deg()
    answers: list[proto.Answer] = []

    def robot(client: socket.socket) -> None:
        for k in range(20):
            client.sendall(proto.encode_request(k + 1, q_deg))
            answers.append(proto.decode_answer(_recv(client, proto.ANSWER_BYTES)))

    r = _serve(server, 20, robot)
    assert r.cycles == 20 and r.stopped == "cycles"
    assert [a.seq for a in answers] == list(range(1, 21)) and all(a.correction_mm == (0.0, 0.0, 0.0) for a in answers)


def test_an_unreadable_request_is_counted_and_answered_with_the_last_correction() -> None:
    source = DrivenSource()
    server = Val3Server(OnlineCompensator(TwinSpec()), load_robot(), force=source)
    q_deg = _q_deg()
    answers: list[proto.Answer] = []

    def robot(client: socket.socket) -> None:
        for frame in (
            proto.encode_request(1, q_deg),
            b"ABCD" + proto.encode_request(2, q_deg)[4:],  # not the magic
            struct.pack("<ii6f", proto.MAGIC, 3, math.nan, *q_deg[1:]),  # a joint not finite
            proto.encode_request(4, q_deg),
        ):
            source.put(_ft(100), time.perf_counter())
            client.sendall(frame[:10])  # in two pieces: the server reads the stream to the frame's end
            time.sleep(0.002)
            client.sendall(frame[10:])
            answers.append(proto.decode_answer(_recv(client, proto.ANSWER_BYTES)))
        client.shutdown(socket.SHUT_WR)  # the robot leaves: the server stops by itself

    r = _serve(server, 10, robot)
    assert r.cycles == 4 and r.unreadable == 2 and r.stopped == "disconnected"
    assert [a.seq for a in answers] == [1, 2, 3, 4]
    assert np.linalg.norm(answers[0].correction_mm) > 0
    assert answers[1].correction_mm == answers[2].correction_mm == answers[0].correction_mm
    assert answers[3].correction_mm != answers[0].correction_mm  # a readable request moves on


def test_the_server_stops_by_itself_when_no_robot_comes() -> None:
    server = Val3Server(OnlineCompensator(TwinSpec()), load_robot())
    try:
        start = time.perf_counter()
        report = server.serve(np.eye(3), 10, idle_timeout_s=0.05, start_timeout_s=0.05)
    finally:
        server.close()
    assert report.cycles == 0 and report.stopped == "start_timeout" and time.perf_counter() - start < 5.0
    server = Val3Server(OnlineCompensator(TwinSpec()), load_robot())
    try:
        with pytest.raises(InputError, match="max_cycles"):
            server.serve(np.eye(3), 0)
    finally:
        server.close()
