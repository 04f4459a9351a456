"""Issue #46's bad-input catalogue: numbers too large for a float, non-finite values in a real-time packet, files
with a UTF-8 byte-order mark, misspelled keys of a model file, and zero counts. Each is refused with exit 2 and a
message naming the file, the key or the option as typed (or, for a packet, answered with the held correction),
never a traceback or a hang."""

from __future__ import annotations

import json
import socket
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from cli_refusal import TINY, refused

from twin.apps.online.rsi import RsiServer
from twin.base.csvio import read_table
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.robot.description import load_robot, shipped_robots
from twin.sim.model_file import model_payload, read_model_file, write_model_file
from twin.sim.online import OnlineCompensator
from twin.sim.servo import ServoTransient
from twin.sim.spec import TwinSpec

BOM = "\ufeff"
PROCESS = 'format = "tx200-twin-process/1"\nthickness_mm = {}\n'




def _robot_file(tmp_path: Path, text_change: tuple[str, str] = ("", ""), prefix: str = "") -> Path:
    """The shipped TX200's description file, its MJCF named absolutely, one text changed, written to tmp_path."""
    shipped = shipped_robots()["tx200"]
    text = shipped.read_text(encoding="utf-8")
    for key in ("mjcf", "scene"):
        text = text.replace(f'{key} = "', f'{key} = "{shipped.parent}/', 1)
    text = text.replace(*text_change)
    path = tmp_path / "robot.toml"
    path.write_text(prefix + text, encoding="utf-8")
    return path


# ---------------------------------------------------------------- 1. numbers too large for a float
@pytest.mark.parametrize("number", ["1e999", "1e400", "inf", "nan"])
def test_a_process_file_number_too_large_for_a_float_is_refused_naming_the_key(
    number: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    declared, out = tmp_path / "process.toml", tmp_path / "p.csv"
    declared.write_text(PROCESS.format(number))
    refused(["path", "--out", str(out), "--no-reach-check", "--process", str(declared)], capsys,
            str(declared), f"thickness_mm = {number}", "expected a finite number")
    assert not out.exists()


@pytest.mark.parametrize(("key", "where"), [
    (("lost_motion_takeup_mm",), "lost_motion_takeup_mm = 1e999"),
    (("process", "thickness_mm"), "process.thickness_mm = 1e999"),
    (("placement", "yaw_deg"), "placement.yaw_deg = 1e999"),
])
def test_a_model_file_number_too_large_for_a_float_is_refused_naming_the_key(
    key: tuple[str, ...], where: str, tmp_path: Path
) -> None:
    payload: dict[str, Any] = model_payload(TwinSpec())
    entry = payload
    for part in key[:-1]:
        entry = entry[part]
    entry[key[-1]] = 12345.678
    path = tmp_path / "model.json"
    path.write_text(json.dumps(payload).replace("12345.678", "1e999"))
    with pytest.raises(DataFileError, match=rf"{path.name}: {where.replace('.', '[.]')} is not finite"):
        read_model_file(path)
    path.write_text(json.dumps(payload).replace("12345.678", "NaN"))
    with pytest.raises(DataFileError, match="= NaN is not finite"):
        read_model_file(path)


def test_a_robot_file_number_too_large_for_a_float_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = _robot_file(tmp_path, ("det_j_min_m3 = 0.05", "det_j_min_m3 = 1e999"))
    refused(["info", "--robot", str(robot)], capsys, str(robot), "det_j_min_m3 = 1e999", "expected a finite number")


def test_an_idle_timeout_too_large_for_a_socket_is_refused_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    refused(["online", "--serve", "rsi", "--port", "0", "--idle-timeout-s", "1e300"], capsys,
            "--idle-timeout-s 1e+300", "<= 3600")
    with pytest.raises(SystemExit) as exited:  # argparse's own refusal
        main(["online", "--serve", "rsi", "--port", "0", "--idle-timeout-s", "1e999"])
    assert exited.value.code == 2 and "--idle-timeout-s: '1e999' is not finite" in capsys.readouterr().err


# ---------------------------------------------------------------- 2. non-finite values in an RSI packet
ROB = ('<Rob Type="KUKA"><AIPos A1="{a[0]}" A2="{a[1]}" A3="{a[2]}" A4="{a[3]}" A5="{a[4]}" A6="{a[5]}"/>'
       '<FT Fx="{f[0]}" Fy="{f[1]}" Fz="{f[2]}"/><IPOC>{ipoc}</IPOC></Rob>')


def _rkorr(answer: bytes) -> tuple[float, float, float]:
    text = answer.decode()
    return tuple(float(text.split(f'{axis}="')[1].split('"')[0]) for axis in "XYZ")  # type: ignore[return-value]


def _serve(server: RsiServer, cycles: int, idle_s: float) -> tuple[threading.Thread, dict[str, Any]]:
    report: dict[str, Any] = {}
    twin = TwinSpec().build()
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, cycles, idle_s,
                                                                                  start_timeout_s=idle_s)),
                              daemon=True)
    thread.start()
    return thread, report


@pytest.mark.parametrize("bad", ["inf", "nan", "1e999", "-inf"])
def test_an_rsi_packet_with_a_non_finite_force_or_axis_is_answered_held_and_the_session_goes_on(bad: str) -> None:
    spec = TwinSpec()
    robot = load_robot(None)
    server = RsiServer(OnlineCompensator(spec), robot)
    thread, report = _serve(server, 1000, 0.5)
    q = [f"{v:.4f}" for v in np.degrees(robot.controller_angles(np.array(robot.q_home_rad)))]
    good_f = ["200", "-50", "1500"]
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(2.0)
    answers = []
    try:
        for k in range(12):
            axes, force = list(q), list(good_f)
            if k == 5:
                force[2] = bad  # a force not finite
            if k == 8:
                axes[1] = bad  # an axis not finite
            client.sendto(ROB.format(a=axes, f=force, ipoc=4 * k).encode(), ("127.0.0.1", server.port))
            answers.append(client.recvfrom(4096)[0])
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    assert not thread.is_alive()
    r = report["r"]
    assert r.cycles == 12 and r.unreadable == 2 and r.stopped == "idle"
    assert all(f"<IPOC>{4 * k}</IPOC>".encode() in a for k, a in enumerate(answers))
    assert all(b"nan" not in a and b"inf" not in a for a in answers)
    corr = [_rkorr(a) for a in answers]
    assert corr[5] == corr[4] and corr[8] == corr[7]  # held: the last correction, unchanged
    assert corr[11] != corr[10] and np.linalg.norm(corr[11]) > np.linalg.norm(corr[4])  # and it goes on


def test_a_stream_of_unreadable_packets_does_not_keep_the_server_alive() -> None:
    server = RsiServer(OnlineCompensator(TwinSpec()), load_robot(None))
    thread, report = _serve(server, 1000, 0.3)
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    start = time.perf_counter()
    try:
        for _ in range(150):  # 1.5 s of garbage, every 10 ms: never answered
            client.sendto(b"<Rob>garbage</Rob>", ("127.0.0.1", server.port))
            time.sleep(0.01)
            if not thread.is_alive():
                break
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    assert not thread.is_alive() and time.perf_counter() - start < 1.4
    r = report["r"]
    assert r.cycles == 0 and r.unreadable > 0 and r.stopped == "start_timeout"  # nothing answered: nothing started


def test_an_egm_message_with_a_non_finite_force_is_answered_held() -> None:
    from twin.apps.online.egm import EgmServer, egm_messages

    pb = egm_messages()
    robot = load_robot(None)
    server = EgmServer(OnlineCompensator(TwinSpec()), robot)
    report: dict[str, Any] = {}
    twin = TwinSpec().build()
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, 1000, 0.5)),
                              daemon=True)
    thread.start()
    q_deg = np.degrees(robot.controller_angles(np.array(robot.q_home_rad)))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(2.0)
    answers = []
    try:
        for k in range(8):
            msg = pb.EgmRobot()
            msg.header.seqno, msg.header.tm = k, 4 * k
            msg.feedBack.joints.joints.extend(q_deg.tolist())
            cart = msg.planned.cartesian
            cart.pos.x, cart.pos.y, cart.pos.z = 1600.0 + 0.08 * k, 0.0, 500.0
            cart.orient.u0, cart.orient.u1, cart.orient.u2, cart.orient.u3 = 0.0, 0.0, 1.0, 0.0
            msg.measuredForce.fcActive = True
            msg.measuredForce.force.extend([200.0, -50.0, float("inf") if k == 5 else 1500.0, 0.0, 0.0, 0.0])
            client.sendto(msg.SerializeToString(), ("127.0.0.1", server.port))
            answer = pb.EgmSensorPathCorr()
            answer.ParseFromString(client.recvfrom(4096)[0])
            answers.append((answer.pathCorr.pos.x, answer.pathCorr.pos.y, answer.pathCorr.pos.z))
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert r.cycles == 8 and r.unreadable == 1 and r.stopped == "idle"
    assert answers[5] == answers[4] and answers[7] != answers[5]
    assert np.all(np.isfinite(answers))


# ---------------------------------------------------------------- 3. a UTF-8 byte-order mark
def test_a_csv_with_a_byte_order_mark_is_read(tmp_path: Path) -> None:
    path = tmp_path / "bom.csv"
    path.write_text(BOM + TINY, encoding="utf-8")
    table = read_table(path, ("t_s", "x_mm", "y_mm", "z_mm"))
    np.testing.assert_allclose(table["x_mm"], [0, 1, 2, 3])


def test_toml_files_with_a_byte_order_mark_are_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    declared, out = tmp_path / "process.toml", tmp_path / "p.csv"
    declared.write_text(BOM + PROCESS.format("1.5"), encoding="utf-8")
    assert main(["path", "--out", str(out), "--no-reach-check", "--process", str(declared)]) == 0
    assert out.exists()
    robot = _robot_file(tmp_path, prefix=BOM)
    assert main(["info", "--robot", str(robot)]) == 0
    assert "Traceback" not in capsys.readouterr().err


def test_a_scan_with_a_byte_order_mark_is_read(tmp_path: Path) -> None:
    from twin.runs.scan_file import _read_xyz

    path = tmp_path / "scan.xyz"
    path.write_text(BOM + "1 2 3\n4 5 6\n", encoding="utf-8")
    np.testing.assert_allclose(_read_xyz(path), [[1, 2, 3], [4, 5, 6]])


# ---------------------------------------------------------------- 4. misspelled keys of a model file
def test_a_model_written_by_the_code_reads_back(tmp_path: Path) -> None:
    spec = TwinSpec(joint_stiffness_nm_per_rad=[1.1e6, 2.2e6, 1.3e6, 4.0e5, 3.0e5, 2.0e5],
                    joint_friction_nm=[10.0, 20.0, 15.0, 5.0, 5.0, 2.0],
                    servo=ServoTransient((1e-7,) * 6, 0.02))
    path = write_model_file(tmp_path / "model.json", spec, note="round trip")
    back = read_model_file(path)
    assert back.joint_stiffness_nm_per_rad == spec.joint_stiffness_nm_per_rad
    assert back.servo == spec.servo and back.process == spec.process


@pytest.mark.parametrize(("change", "needles"), [
    ({"joint_stifness_nm_per_rad": [1e6] * 6}, ("'joint_stifness_nm_per_rad'", "a model file takes", "'joint_stiffness_nm_per_rad'")),
    ({"process": {"thicknes_mm": 1.5}}, ("'process.thicknes_mm'", "process takes", "'thickness_mm'")),
])
def test_a_misspelled_model_key_is_refused_naming_it_and_the_valid_keys(
    change: dict[str, Any], needles: tuple[str, ...], tmp_path: Path
) -> None:
    payload = model_payload(TwinSpec())
    for key, value in change.items():
        if isinstance(value, dict):
            payload[key].update(value)
        else:
            payload[key] = value
    path = tmp_path / "model.json"
    path.write_text(json.dumps(payload))
    with pytest.raises(DataFileError) as info:
        read_model_file(path)
    for needle in (str(path), "unknown key", *needles):
        assert needle in str(info.value), (needle, str(info.value))


# ---------------------------------------------------------------- 5. zero or negative counts
@pytest.mark.parametrize("cycles", ["0", "-1"])
def test_a_zero_or_negative_cycle_count_is_refused_by_name(cycles: str, capsys: pytest.CaptureFixture[str]) -> None:
    refused(["online", "--serve", "rsi", "--port", "0", "--cycles", cycles], capsys, f"--cycles {cycles}", ">= 1")
    server = RsiServer(OnlineCompensator(TwinSpec()), load_robot(None))
    try:
        with pytest.raises(InputError, match="max_cycles"):
            server.serve(np.eye(3), int(cycles), 1.0)
    finally:
        server.close()
