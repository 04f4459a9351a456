"""ABB EGM and ATI RDT on loopback: a client plays the robot (EgmRobot messages at a 4 ms cycle), a thread plays
the F/T sensor (RDT samples); the twin's servers answer over 127.0.0.1. Bounded: each loop stops by itself."""

from __future__ import annotations

import math
import socket
import threading
import time

import numpy as np
import pytest

from twin.apps.online.egm import EgmServer, PathFrame, egm_messages
from twin.apps.online.rdt import (
    RECORD_BYTES,
    SET_BIAS,
    START_STREAMING,
    RdtSource,
    parse_request,
    record,
    request,
)
from twin.errors import InputError
from twin.sim.online import OnlineCompensator
from twin.sim.spec import TwinSpec

CYCLES = 250  # 1 s at 4 ms
pb = egm_messages()


def _ft(k: int) -> np.ndarray:
    return np.array([200.0, -50.0, 1500.0]) * min(1.0, k / 100.0)  # the force builds up over 0.4 s


def _robot_message(k: int, q_deg: np.ndarray, force: np.ndarray | None) -> bytes:
    """An EgmRobot as a controller sends it: header, feedback joints, the planned pose moving along base +x at
    20 mm/s with the tool pointing down, and (optionally) the measured force."""
    msg = pb.EgmRobot()
    msg.header.seqno, msg.header.tm = k, 4 * k
    msg.header.mtype = pb.EgmHeader.MessageType.Value("MSGTYPE_DATA")
    msg.feedBack.joints.joints.extend(q_deg.tolist())
    cart = msg.planned.cartesian
    cart.pos.x, cart.pos.y, cart.pos.z = 1600.0 + 0.08 * k, 0.0, 500.0
    cart.orient.u0, cart.orient.u1, cart.orient.u2, cart.orient.u3 = 0.0, 0.0, 1.0, 0.0  # 180 deg about y
    if force is not None:
        msg.measuredForce.fcActive = True
        msg.measuredForce.force.extend([*force.tolist(), 0.0, 0.0, 0.0])
    return msg.SerializeToString()


def test_the_path_frame_follows_the_motion_and_the_tool() -> None:
    frame = PathFrame()
    robot = pb.EgmRobot()
    c = robot.planned.cartesian
    c.orient.u0, c.orient.u2 = 0.0, 1.0  # tool z = base -z
    for k in range(3):
        c.pos.x, c.pos.y = 1600.0, 10.0 * k  # moving along +y
        frame.update(c.pos, c.orient)
    np.testing.assert_allclose(frame.axes, [[0, 1, 0], [1, 0, 0], [0, 0, -1]], atol=1e-12)
    frame.update(c.pos, c.orient)  # standing: the last direction is kept
    np.testing.assert_allclose(frame.axes[0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(frame.axes @ frame.axes.T, np.eye(3), atol=1e-12)


def test_the_egm_server_answers_every_message_with_the_path_correction() -> None:
    spec = TwinSpec()
    twin = spec.build()
    robot = twin.robot
    server = EgmServer(OnlineCompensator(spec), robot)
    report: dict[str, object] = {}
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, CYCLES + 1, 0.5)))
    thread.start()
    q_deg = np.degrees(robot.controller_angles(np.array(robot.q_home_rad)))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.5)
    answers = []
    try:
        start = time.perf_counter()
        for k in range(CYCLES):
            client.sendto(_robot_message(k, q_deg, _ft(k)), ("127.0.0.1", server.port))
            answer = pb.EgmSensorPathCorr()
            answer.ParseFromString(client.recvfrom(4096)[0])
            answers.append(answer)
            time.sleep(max(0.0, start + 0.004 * (k + 1) - time.perf_counter()))
        client.sendto(b"\x08\xff garbage", ("127.0.0.1", server.port))  # not an EgmRobot: counted, unanswered
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert r.cycles == CYCLES and r.stopped == "idle" and r.unreadable == 1  # type: ignore[attr-defined]
    assert all(a.header.tm == 4 * k and a.header.mtype == pb.EgmHeader.MessageType.Value("MSGTYPE_PATH_CORRECTION")
               for k, a in enumerate(answers))
    direct = OnlineCompensator(spec)
    q = np.array(robot.q_home_rad)
    for k in range(CYCLES):
        direct.step(0.004 * k, 0.004 * k, _ft(k), q)
    base_mm = 1e3 * twin.R_base_sheet @ direct.correction_m
    path_axes = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])  # along +x, tool down
    last = answers[-1].pathCorr
    np.testing.assert_allclose([last.pos.x, last.pos.y, last.pos.z], path_axes @ base_mm, atol=1e-9)
    assert np.linalg.norm(base_mm) > 0.5


def test_without_a_force_the_egm_server_corrects_nothing() -> None:
    spec = TwinSpec()
    twin = spec.build()
    server = EgmServer(OnlineCompensator(spec), twin.robot)
    thread = threading.Thread(target=server.serve, args=(twin.R_base_sheet, 20, 2.0))
    thread.start()
    q_deg = np.degrees(twin.robot.controller_angles(np.array(twin.robot.q_home_rad)))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.5)
    try:
        for k in range(20):
            client.sendto(_robot_message(k, q_deg, None), ("127.0.0.1", server.port))
            answer = pb.EgmSensorPathCorr()
            answer.ParseFromString(client.recvfrom(4096)[0])
            assert (answer.pathCorr.pos.x, answer.pathCorr.pos.y, answer.pathCorr.pos.z) == (0.0, 0.0, 0.0)
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()


class _Sensor:
    """An ATI Net F/T playing its RDT protocol on 127.0.0.1: waits for the start request, then streams `n`
    samples every 1 ms (the force `_ft`, 1e6 counts/N), with one bad status, one repeat and one gap."""

    def __init__(self, n: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(2.0)
        self.port = int(self.sock.getsockname()[1])
        self.n, self.requests = n, []
        self.thread = threading.Thread(target=self._run)
        self.thread.start()

    def _run(self) -> None:
        try:
            packet, peer = self.sock.recvfrom(64)
            self.requests.append(parse_request(packet))
            while self.requests[-1][0] != START_STREAMING:
                packet, peer = self.sock.recvfrom(64)
                self.requests.append(parse_request(packet))
            for k in range(self.n):
                counts = np.round(1e6 * np.r_[_ft(k), 0.0, 0.0, 0.0])
                if k == 5:
                    self.sock.sendto(record(k, k, 0x80000000, counts), peer)  # the sensor's error flag
                    continue
                if k == 7:
                    continue  # lost
                self.sock.sendto(record(k, k, 0, counts), peer)
                if k == 9:
                    self.sock.sendto(record(k - 1, k - 1, 0, counts), peer)  # late, reordered
                time.sleep(0.001)
        except TimeoutError:
            pass

    def close(self) -> None:
        self.thread.join(timeout=5.0)
        self.sock.close()


def test_the_rdt_source_reads_the_sensors_stream() -> None:
    assert len(record(1, 1, 0, (0,) * 6)) == RECORD_BYTES and parse_request(request(2, 0)) == (2, 0)
    with pytest.raises(InputError, match="0x1234"):
        parse_request(b"\x00\x01" + bytes(6))
    sensor = _Sensor(120)
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # the sensor turned 90 deg about z
    source = RdtSource("127.0.0.1", sensor.port, R_sheet_sensor=R, bias=True, bind_host="127.0.0.1")
    try:
        deadline = time.perf_counter() + 3.0
        while source.samples < 118 and time.perf_counter() < deadline:
            source.poll()
            time.sleep(0.002)
    finally:
        sensor.close()
        source.close()
    assert sensor.requests[:2] == [(SET_BIAS, 0), (START_STREAMING, 0)]
    assert (source.samples, source.faulted, source.stale) == (118, 1, 1)
    assert source.lost == 2  # 5 (faulted) and 7 (never sent) are missing from the sequence
    np.testing.assert_allclose(source.force_n, R @ _ft(119), atol=1e-6)
    assert math.isfinite(source.stamp_s)


def test_the_rdt_source_refuses_a_bad_calibration() -> None:
    with pytest.raises(InputError, match="counts per N"):
        RdtSource("127.0.0.1", 9, counts_per_n=0.0)
    with pytest.raises(InputError, match="proper rotation"):
        RdtSource("127.0.0.1", 9, R_sheet_sensor=np.diag([1.0, 1.0, -1.0]))


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_the_command_serves_egm_with_the_force_from_the_sensors_rdt_stream(capsys) -> None:
    import json

    from twin.cli import main

    twin = TwinSpec().build()
    q_deg = np.degrees(twin.robot.controller_angles(np.array(twin.robot.q_home_rad)))
    sensor, port, answers = _Sensor(400), _free_udp_port(), []

    def robot() -> None:  # plays the controller until 40 answers came, 3 s at most
        client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        client.settimeout(0.05)
        deadline, k = time.perf_counter() + 3.0, 0
        try:
            while len(answers) < 40 and time.perf_counter() < deadline:
                client.sendto(_robot_message(k, q_deg, None), ("127.0.0.1", port))
                k += 1
                try:
                    answer = pb.EgmSensorPathCorr()
                    answer.ParseFromString(client.recvfrom(4096)[0])
                    answers.append(answer)
                except (TimeoutError, ConnectionRefusedError):
                    continue
                time.sleep(0.004)
        finally:
            client.close()

    thread = threading.Thread(target=robot)
    thread.start()
    try:
        code = main(["online", "--serve", "egm", "--port", str(port), "--cycles", "40", "--idle-timeout-s", "2",
                     "--ft-rdt", f"127.0.0.1:{sensor.port}", "--json", "-"])
    finally:
        thread.join(timeout=5.0)
        sensor.close()
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["cycles"] == 40 and doc["transport"] == "UDP" and doc["stopped"] == "cycles"
    assert len(answers) == 40
    # the force came from the sensor (the messages carry none): the correction grew from zero
    last = answers[-1].pathCorr.pos
    assert math.hypot(last.x, last.y, last.z) > 0.0


def test_the_command_refuses_a_bad_sensor_address(capsys) -> None:
    from twin.cli import main

    assert main(["online", "--serve", "egm", "--ft-rdt", "sensor:99999"]) == 2
    err = capsys.readouterr().err
    assert "--ft-rdt 'sensor:99999'" in err and "Traceback" not in err
    assert main(["online", "--serve", "egm", "--ft-rdt", "127.0.0.2", "--ft-counts-per-n", "0"]) == 2
    assert "--ft-counts-per-n" in capsys.readouterr().err


def test_each_interface_listens_where_its_exported_program_looks() -> None:
    from twin.apps.export.krl_rsi import DEFAULT_PORT as RSI_PORT
    from twin.apps.export.rapid_egm import DEFAULT_PORT as EGM_PORT
    from twin.apps.online.alter_protocol import DEFAULT_PORT as ALTER_PORT
    from twin.apps.tasks.online import INTERFACES

    assert {name: i.default_port for name, i in INTERFACES.items()} == {"rsi": RSI_PORT, "egm": EGM_PORT,
                                                                        "val3": ALTER_PORT}


def test_the_command_serves_val3_over_tcp_and_stops_when_idle(capsys) -> None:
    import json

    from twin.cli import main

    assert main(["online", "--serve", "val3", "--port", "0"]) == 2  # no force: nothing would ever be corrected
    assert "--serve val3 needs --ft-rdt" in capsys.readouterr().err
    assert main(["online", "--serve", "val3", "--port", "0", "--cycles", "5", "--idle-timeout-s", "0.05",
                 "--start-timeout-s", "0.05", "--ft-rdt", "127.0.0.1:9", "--json", "-"]) == 1  # no robot came
    doc = json.loads(capsys.readouterr().out)
    assert doc["cycles"] == 0 and doc["stopped"] == "start_timeout" and doc["transport"] == "TCP" and doc["port"] > 0
