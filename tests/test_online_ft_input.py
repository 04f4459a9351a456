"""The F/T sensor's RDT stream (`--ft-rdt`, twin/apps/online/rdt.py) passes nothing in silence: a fake ATI Net F/T on
127.0.0.1 sends bad datagrams among good ones (each counted by why and skipped, the next good one taken at once),
restarts its sequence, or never answers; a session whose compensator never had a sample exits 1 saying so, with
the counts in its summary. Bounded: every loop has its count or timeout, every socket is closed."""

from __future__ import annotations

import json
import socket
import threading
import time

import numpy as np
import pytest
from test_online_rsi import ROB

from twin.apps.online.rdt import RESTART_RUN, START_STREAMING, RdtSource, parse_request, record
from twin.cli import main
from twin.sim.spec import TwinSpec

ROBOT = TwinSpec().build().robot
Q_DEG = np.degrees(ROBOT.controller_angles(np.array(ROBOT.q_home_rad)))
GOOD = (np.array([10.0, 20.0, 30.0, 0.0, 0.0, 0.0]) * 1e6).astype(int)  # 10, 20, 30 N at 1e6 counts/N


class FakeSensor:
    """An ATI Net F/T on 127.0.0.1: after the start request, sends `datagrams` (None: nothing, ever), 1 ms apart."""

    def __init__(self, datagrams: list[bytes] | None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(3.0)
        self.port = int(self.sock.getsockname()[1])
        self.datagrams, self.started = datagrams, threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            while True:
                packet, peer = self.sock.recvfrom(64)
                if parse_request(packet)[0] == START_STREAMING:
                    break
            self.started.set()
            for datagram in self.datagrams or ():
                self.sock.sendto(datagram, peer)
                time.sleep(0.001)
        except (TimeoutError, OSError):
            pass

    def close(self) -> None:
        self.thread.join(timeout=5.0)
        self.sock.close()


def _read(source: RdtSource, until: int, seconds: float = 2.0) -> None:
    deadline = time.perf_counter() + seconds
    while source.samples + source.malformed + source.faulted + source.absurd + source.stale < until:
        if time.perf_counter() > deadline:
            break
        source.poll()
        time.sleep(0.002)


def test_bad_datagrams_are_counted_by_why_and_the_next_good_one_is_taken() -> None:
    sensor = FakeSensor([
        record(1, 1, 0, GOOD),
        b"\x12\x34\x00\x02\x00\x00\x00\x00",  # a request's header and command, not a record: malformed
        record(2, 2, 0, 2 * GOOD) + b"\0\0\0\0",  # 40 bytes: malformed, not read as its first 36
        record(3, 3, 0, GOOD)[:30],  # cut short: malformed
        record(4, 4, 0x80000000, GOOD),  # the sensor's error flag
        record(5, 5, 0, (2**31 - 1, 0, 0, 0, 0, 0)),  # a saturated count: absurd
        record(6, 6, 0, (0, 0, 2_000_000_000, 0, 0, 0)),  # 2000 N, above this sensor's 1000 N: absurd
        record(1, 1, 0, 2 * GOOD),  # out of order
        record(9, 9, 0, 3 * GOOD),  # the next good one: taken at once
    ])
    source = RdtSource("127.0.0.1", sensor.port, bind_host="127.0.0.1", max_force_n=1000.0)
    try:
        _read(source, 9)
    finally:
        sensor.close()
        source.close()
    assert (source.malformed, source.faulted, source.absurd, source.stale) == (3, 1, 2, 1)
    assert source.samples == 2 and source.lost == 7  # 2..8 are missing between 1 and 9
    np.testing.assert_allclose(source.force_n, 3 * GOOD[:3] / 1e6)
    assert "2 good samples; 3 malformed, 1 with an error status, 2 absurd, 1 out of order, 7 lost" in source.counts()


def test_a_sensor_that_restarts_its_sequence_is_taken_again_after_a_run() -> None:
    restart = [record(k, k, 0, GOOD * (k + 1)) for k in range(RESTART_RUN + 2)]
    sensor = FakeSensor([record(1000, 1000, 0, GOOD), *restart])
    source = RdtSource("127.0.0.1", sensor.port, bind_host="127.0.0.1")
    try:
        _read(source, 1 + len(restart))
    finally:
        sensor.close()
        source.close()
    assert source.stale == RESTART_RUN - 1 and source.restarts == 1 and source.samples == 4
    np.testing.assert_allclose(source.force_n, GOOD[:3] * (RESTART_RUN + 2) / 1e6)


def _robot(port: int, n: int, ft: bool, done: threading.Event) -> None:
    """Plays the KUKA controller: `n` packets at 4 ms (with or without an FT element), 3 s at most."""
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.05)
    deadline, k, answered = time.perf_counter() + 3.0, 0, 0
    try:
        while answered < n and time.perf_counter() < deadline:
            element = '<FT Fx="0" Fy="0" Fz="500"/>' if ft else ""
            client.sendto(ROB.format(a=Q_DEG, ft=element, ipoc=4 * k).encode(), ("127.0.0.1", port))
            k += 1
            try:
                client.recvfrom(4096)
                answered += 1
            except (TimeoutError, ConnectionRefusedError):
                continue
            time.sleep(0.004)
    finally:
        client.close()
        done.set()


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.parametrize(("datagrams", "cycles", "needles"), [
    (None, 300, ("the RDT sensor at 127.0.0.1:", "gave no good sample", "0 good samples; 0 malformed")),
    ([b"junk"] * 5 + [record(1, 1, 1, GOOD)] * 3, 40, ("gave no good sample", "5 malformed, 3 with an error status")),
])
def test_a_session_whose_sensor_never_gave_a_good_sample_exits_1_saying_so(datagrams, cycles, needles,
                                                                             capsys) -> None:
    sensor, port, done = FakeSensor(datagrams), _free_port(), threading.Event()
    thread = threading.Thread(target=_robot, args=(port, cycles, False, done))
    thread.start()
    try:
        code = main(["online", "--serve", "rsi", "--port", str(port), "--cycles", str(cycles), "--idle-timeout-s",
                     "1", "--start-timeout-s", "3", "--ft-rdt", f"127.0.0.1:{sensor.port}", "--json", "-"])
    finally:
        thread.join(timeout=5.0)
        sensor.close()
    captured = capsys.readouterr()
    assert code == 1 and "Traceback" not in captured.err
    doc = json.loads(captured.out)
    assert doc["cycles"] == cycles and doc["no_sample"] == cycles and doc["ft"]["samples"] == 0
    assert "FAILED: no F/T sample in any of the" in captured.err
    for needle in needles:
        assert needle in captured.err, (needle, captured.err)
    if datagrams is None:  # told while it ran, not only at the end
        assert "online: no good F/T sample from the RDT sensor" in captured.err


def test_rsi_packets_that_never_carry_a_force_fail_the_session_and_one_that_does_passes(capsys) -> None:
    for ft, code in ((False, 1), (True, 0)):
        port, done = _free_port(), threading.Event()
        thread = threading.Thread(target=_robot, args=(port, 20, ft, done))
        thread.start()
        try:
            assert main(["online", "--serve", "rsi", "--port", str(port), "--cycles", "20", "--idle-timeout-s", "1",
                         "--start-timeout-s", "3"]) == code
        finally:
            thread.join(timeout=5.0)
        out = capsys.readouterr().out
        assert ("no packet carried an F/T sample" in out) == (not ft)
