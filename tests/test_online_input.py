"""No input passes the online servers in silence (KUKA RSI, ABB EGM over UDP; Stäubli VAL3 alter over TCP), each
driven by a fake robot on 127.0.0.1: a second sender is ignored and counted, the correction's rate is bounded per
second (not per packet), a spike held by a sensor slower than the cycle is rejected once, the first packet has its
own start timeout, a stream out of step resynchronises, and the command refuses an option given twice or one port
named for two things. Bounded: every loop has its count or timeout, every socket is closed."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from cli_refusal import refused
from test_online_egm import _robot_message
from test_online_rsi import ROB, parse_rkorr
from test_online_val3 import DrivenSource, _recv

from twin.apps.online import alter_protocol as proto
from twin.apps.online.cycle import ServeReport
from twin.apps.online.egm import EgmServer, egm_messages
from twin.apps.online.rsi import RsiServer
from twin.apps.online.val3 import Val3Server
from twin.cli import main
from twin.sim.online import OnlineCompensator, OnlineSettings
from twin.sim.spec import TwinSpec

SPEC = TwinSpec()
TWIN = SPEC.build()
ROBOT = TWIN.robot
Q_DEG = np.degrees(ROBOT.controller_angles(np.array(ROBOT.q_home_rad)))


def _rob(ipoc: int, force: tuple[float, float, float] | np.ndarray) -> bytes:
    ft = '<FT Fx="{:.3f}" Fy="{:.3f}" Fz="{:.3f}"/>'.format(*force)
    return ROB.format(a=Q_DEG, ft=ft, ipoc=ipoc).encode()


def _start(server: Any, cycles: int, idle_s: float, start_s: float = 2.0) -> tuple[threading.Thread, dict]:
    report: dict[str, ServeReport] = {}
    thread = threading.Thread(target=lambda: report.setdefault(
        "r", server.serve(TWIN.R_base_sheet, cycles, idle_s, start_timeout_s=start_s)), daemon=True)
    thread.start()
    return thread, report


def _udp(timeout_s: float = 0.5) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(timeout_s)
    return sock


def _paced(send: Callable[[int], bytes | None], n: int, cycle_s: float = 0.004) -> list[bytes | None]:
    """Call `send(k)` every `cycle_s` for k < n (a controller's clock); its answers."""
    start, answers = time.perf_counter(), []
    for k in range(n):
        answers.append(send(k))
        time.sleep(max(0.0, start + cycle_s * (k + 1) - time.perf_counter()))
    return answers


# ---------------------------------------------------------------- one peer per session
def test_rsi_packets_from_a_second_sender_are_ignored_and_counted() -> None:
    server = RsiServer(OnlineCompensator(SPEC), ROBOT)
    thread, report = _start(server, 20, 0.3)
    robot, intruder = _udp(), _udp(0.05)
    answers, intruded = [], 0
    try:
        for k in range(20):
            robot.sendto(_rob(4 * k, (200.0, -50.0, 1500.0)), ("127.0.0.1", server.port))
            answers.append(robot.recvfrom(4096)[0])
            if k in (3, 9, 15):  # another sender, its own clock and a force of its own
                intruder.sendto(_rob(999_000 + k, (0.0, 0.0, -8000.0)), ("127.0.0.1", server.port))
                try:
                    intruder.recvfrom(4096)
                    intruded += 1
                except TimeoutError:
                    pass
    finally:
        robot.close()
        intruder.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert intruded == 0 and r.foreign == 3 and r.cycles == 20 and r.unreadable == 0
    assert all(f"<IPOC>{4 * k}</IPOC>".encode() in a for k, a in enumerate(answers))
    assert r.spikes == 0  # the intruder's -8 kN never reached the compensator


def test_egm_messages_from_a_second_sender_are_ignored_and_counted() -> None:
    pb = egm_messages()
    server = EgmServer(OnlineCompensator(SPEC), ROBOT)
    thread, report = _start(server, 10, 0.3)
    robot, intruder = _udp(), _udp(0.05)
    seqs = []
    try:
        for k in range(10):
            robot.sendto(_robot_message(k, Q_DEG, np.array([200.0, -50.0, 1500.0])), ("127.0.0.1", server.port))
            answer = pb.EgmSensorPathCorr()
            answer.ParseFromString(robot.recvfrom(4096)[0])
            seqs.append(answer.header.tm)
            if k == 4:
                intruder.sendto(_robot_message(500, Q_DEG, np.array([0.0, 0.0, -8000.0])), ("127.0.0.1", server.port))
                with pytest.raises(TimeoutError):
                    intruder.recvfrom(4096)
    finally:
        robot.close()
        intruder.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert r.foreign == 1 and r.cycles == 10 and seqs == [4 * k for k in range(10)] and r.spikes == 0


def test_a_second_val3_connection_before_the_first_request_is_closed_at_once() -> None:
    lines: list[str] = []
    server = Val3Server(OnlineCompensator(SPEC), ROBOT, force=DrivenSource(), log=lines.append)
    thread, report = _start(server, 2, 0.5)
    first = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
    second = None
    try:
        time.sleep(0.05)  # the first is the session's peer
        second = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
        started = time.perf_counter()
        try:
            closed = second.recv(64) == b""
        except ConnectionResetError:
            closed = True
        assert closed and time.perf_counter() - started < 0.5  # at once, not at the session's end
        for seq in (1, 2):
            first.sendall(proto.encode_request(seq, Q_DEG))
            assert proto.decode_answer(_recv(first, proto.ANSWER_BYTES)).seq == seq
    finally:
        first.close()
        if second is not None:
            second.close()
        thread.join(timeout=5.0)
        server.close()
    assert report["r"].refused == 1 and report["r"].cycles == 2 and len(lines) == 1


# ---------------------------------------------------------------- the rate limit is per second
def test_a_burst_of_packets_moves_the_correction_no_faster_than_the_rate_limit() -> None:
    server = RsiServer(OnlineCompensator(SPEC), ROBOT)
    thread, report = _start(server, 60, 0.3)
    robot = _udp()
    corrections = []
    try:
        # a force whose correction is the 5 mm limit: the filter starts there, the correction at 0
        robot.sendto(_rob(0, (3000.0, 0.0, 15000.0)), ("127.0.0.1", server.port))
        robot.recvfrom(4096)
        time.sleep(0.05)
        start = time.perf_counter()
        for k in range(1, 51):  # 50 packets as fast as they are answered, each claiming a 4 ms cycle
            robot.sendto(_rob(4 * k, (3000.0, 0.0, 15000.0)), ("127.0.0.1", server.port))
            corrections.append(parse_rkorr(robot.recvfrom(4096)[0]))
        elapsed = time.perf_counter() - start
    finally:
        robot.close()
        thread.join(timeout=5.0)
        server.close()
    rate = OnlineSettings().max_rate_mm_s
    moved = float(np.linalg.norm(corrections[-1] - corrections[0]))
    # from the burst's first answer to its last: at most the rate over the burst's wall time (50 cycles' worth,
    # 4 mm, before the rate was per second), and it does move
    assert 0.0 < moved <= rate * elapsed + 2e-4, (moved, elapsed)
    # from zero: at most one cycle's worth for the first packet and one for the pause before the burst, then the
    # burst's wall time (a loaded machine answers slower, so the bound is the burst's own time, not a fixed size)
    cycle_s = OnlineSettings().cycle_s
    assert np.linalg.norm(corrections[-1]) <= rate * (elapsed + 2 * cycle_s) + 2e-4 and report["r"].cycles == 51


# ---------------------------------------------------------------- a spike held by a slow sensor
def _spiked(k: int) -> tuple[float, float, float]:
    """A 30 Hz sensor read each 4 ms cycle: each sample held ~8 cycles; the one at samples 12 is a 6 kN spike."""
    sample = int(k * 0.004 * 30.0)
    return (200.0, -50.0, 6000.0) if sample == 12 else (200.0, -50.0, 1500.0)


def test_a_spike_from_a_sensor_slower_than_the_cycle_is_rejected_in_rsi_packets() -> None:
    server = RsiServer(OnlineCompensator(SPEC), ROBOT)
    n = 150
    thread, report = _start(server, n, 0.3)
    robot = _udp()

    def send(k: int) -> bytes:
        robot.sendto(_rob(4 * k, _spiked(k)), ("127.0.0.1", server.port))
        return robot.recvfrom(4096)[0]

    try:
        answers = _paced(send, n)
    finally:
        robot.close()
        thread.join(timeout=5.0)
        server.close()
    corr = np.array([parse_rkorr(a) for a in answers if a is not None])
    spike = [k for k in range(n) if _spiked(k)[2] > 5000.0]
    assert len(spike) >= 6  # the spike sample is repeated over several cycles
    error = np.linalg.norm(corr[spike[0]:] - corr[spike[0] - 1], axis=1).max()
    assert error < 0.01, error  # mm: no step toward the spike's level
    assert report["r"].spikes == 1


def test_a_spike_from_a_sensor_slower_than_the_cycle_is_rejected_in_val3() -> None:
    source = DrivenSource()
    server = Val3Server(OnlineCompensator(SPEC), ROBOT, force=source)
    n = 150
    answers: list[proto.Answer] = []
    stamps: dict[int, float] = {}

    def robot(client: socket.socket) -> None:
        def send(k: int) -> None:
            sample = int(k * 0.004 * 30.0)
            if sample not in stamps:  # a new 30 Hz sample: stamped when it came
                stamps[sample] = time.perf_counter()
                source.put(np.array(_spiked(k)), stamps[sample])
            client.sendall(proto.encode_request(k + 1, Q_DEG))
            answers.append(proto.decode_answer(_recv(client, proto.ANSWER_BYTES)))
            return None

        _paced(send, n)

    thread, report = _start(server, n, 0.5)
    client = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
    try:
        robot(client)
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    corr = np.array([a.correction_mm for a in answers])
    first = next(k for k in range(n) if _spiked(k)[2] > 5000.0)
    # issue #50's outcome: the spike changes the correction by < 0.05 mm (a step toward it would be a rate limit's
    # cycle, 0.08 mm). VAL3's samples are stamped on this computer's clock: on a loaded CI machine the correction was
    # seen still settling after the spike, four steps of 0.0034 mm (0.0135 mm in all), none toward the spike
    assert np.linalg.norm(corr[first:] - corr[first - 1], axis=1).max() < 0.05
    assert report["r"].spikes == 1


# ---------------------------------------------------------------- the start timeout
def test_the_first_packet_has_its_own_start_timeout_then_the_idle_one_counts() -> None:
    server = RsiServer(OnlineCompensator(SPEC), ROBOT)
    thread, report = _start(server, 100, 0.1, start_s=2.0)
    robot = _udp()
    try:
        time.sleep(0.4)  # the robot comes later than the idle timeout, well within the start timeout
        for k in range(5):
            robot.sendto(_rob(4 * k, (0.0, 0.0, 100.0)), ("127.0.0.1", server.port))
            robot.recvfrom(4096)
        time.sleep(0.3)  # then it goes silent: the idle timeout ends the session
    finally:
        robot.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert not thread.is_alive() and r.cycles == 5 and r.stopped == "idle"


def test_a_val3_robot_that_connects_but_sends_late_is_served() -> None:
    server = Val3Server(OnlineCompensator(SPEC), ROBOT, force=DrivenSource())
    thread, report = _start(server, 3, 0.1, start_s=2.0)
    client = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
    try:
        time.sleep(0.4)
        for seq in (1, 2, 3):
            client.sendall(proto.encode_request(seq, Q_DEG))
            assert proto.decode_answer(_recv(client, proto.ANSWER_BYTES)).seq == seq
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    assert report["r"].cycles == 3 and report["r"].stopped == "cycles"


@pytest.mark.parametrize("serve", ["rsi", "val3"])
def test_a_session_that_answered_no_packet_exits_non_zero_saying_so(serve: str, capsys) -> None:
    extra = ["--ft-rdt", "127.0.0.1:9"] if serve == "val3" else []
    started = time.perf_counter()
    assert main(["online", "--serve", serve, "--port", "0", "--idle-timeout-s", "0.05", "--start-timeout-s", "0.3",
                 *extra]) == 1
    out = capsys.readouterr().out
    assert "no packet answered" in out and "--start-timeout-s 0.3" in out
    # at least the start timeout; at most a bound that a loaded CI worker (building the compensator) stays under
    assert 0.3 <= time.perf_counter() - started < 10.0


# ---------------------------------------------------------------- a stream out of step
def test_a_val3_stream_out_of_step_resynchronises_on_the_next_frame() -> None:
    source = DrivenSource()
    server = Val3Server(OnlineCompensator(SPEC), ROBOT, force=source)
    thread, report = _start(server, 10, 0.5)
    client = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
    seqs = []
    try:
        client.sendall(b"xyz")  # three stray bytes: every later frame would be read 3 bytes off
        for seq in (1, 2, 3):
            client.sendall(proto.encode_request(seq, Q_DEG))
            seqs.append(proto.decode_answer(_recv(client, proto.ANSWER_BYTES)).seq)
        client.sendall(proto.encode_request(4, Q_DEG)[:20])  # a frame cut short, then whole ones again
        for seq in (5, 6):
            client.sendall(proto.encode_request(seq, Q_DEG))
            seqs.append(proto.decode_answer(_recv(client, proto.ANSWER_BYTES)).seq)
        client.shutdown(socket.SHUT_WR)
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert seqs == [1, 2, 3, 5, 6] and r.cycles == 5 and r.unreadable == 2


# ---------------------------------------------------------------- the same input twice
@pytest.mark.parametrize(("argv", "needles"), [
    (["--serve", "rsi", "--port", "5000", "--port", "6000"], ("--port given twice", "5000", "6000")),
    (["--serve", "rsi", "--serve", "egm"], ("--serve given twice", "rsi", "egm")),
    (["--serve", "rsi", "--start-timeout-s", "5", "--start-timeout-s", "7"], ("--start-timeout-s given twice",)),
    (["--serve", "egm", "--ft-rdt", "127.0.0.1", "--ft-rdt", "127.0.0.2"], ("--ft-rdt given twice",)),
])
def test_an_option_given_twice_is_refused_by_name(argv, needles, capsys) -> None:
    refused(["online", *argv], capsys, *needles)  # the CLI's rule (twin/cli/_repeats.py), on online's options


@pytest.mark.parametrize(("argv", "needles"), [
    (["--serve", "rsi", "--ft-rdt", "127.0.0.1"], ("--port 49152", "rsi's default", "--ft-rdt 127.0.0.1:49152",
                                                   "the same UDP port")),
    (["--serve", "egm", "--port", "7001", "--ft-rdt", "localhost:7001"], ("--port 7001", "--ft-rdt localhost:7001")),
])
def test_one_port_for_the_server_and_the_sensor_is_refused_by_name(argv, needles, capsys) -> None:
    refused(["online", *argv], capsys, *needles)


def test_distinct_ports_are_taken() -> None:
    from twin.apps.tasks.online import OnlineRequest, RdtSettings

    OnlineRequest("rsi", port=7002, ft=RdtSettings("127.0.0.1", 7003))
    # the sensor's port on another host (a name only: no packet is sent)
    OnlineRequest("rsi", port=7002, ft=RdtSettings("ft-sensor.invalid", 7002))
    OnlineRequest("val3", port=7002, ft=RdtSettings("127.0.0.1", 7002))  # TCP and UDP: two ports


@pytest.mark.parametrize(("argv", "needles"), [
    (["--start-timeout-s", "-1"], ("--start-timeout-s -1", "expected seconds > 0 and <= 3600")),
    (["--max-rate-mm-s", "0"], ("--max-rate-mm-s 0", "expected mm/s > 0 and <= 1000")),
])
def test_a_bad_timeout_or_rate_is_refused_by_name(argv, needles, capsys) -> None:
    refused(["online", "--serve", "rsi", "--port", "0", *argv], capsys, *needles)
