"""KUKA RSI on loopback: a client plays the robot at a 4 ms cycle over 127.0.0.1; the twin's server answers each
packet with the compensator's correction and the packet's IPOC. Bounded: the server stops after its cycles."""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest

from twin.apps.online.rsi import RsiServer, parse_rob, sen_packet
from twin.errors import InputError
from twin.robot.description import load_robot
from twin.sim.online import OnlineCompensator
from twin.sim.spec import TwinSpec

CYCLES = 250  # 1 s at 4 ms
ROB = ('<Rob Type="KUKA"><RIst X="1467.0" Y="-4.1" Z="423.7" A="0" B="0" C="180"/>'
       '<AIPos A1="{a[0]:.4f}" A2="{a[1]:.4f}" A3="{a[2]:.4f}" A4="{a[3]:.4f}" A5="{a[4]:.4f}" A6="{a[5]:.4f}"/>'
       '{ft}<Delay D="0"/><IPOC>{ipoc}</IPOC></Rob>')


def _ft(k: int) -> np.ndarray:
    return np.array([200.0, -50.0, 1500.0]) * min(1.0, k / 100.0)  # the force builds up over 0.4 s


def test_a_rob_packet_is_read_and_a_bad_one_is_named() -> None:
    rob = parse_rob(ROB.format(a=np.arange(6.0), ft='<FT Fx="1" Fy="2" Fz="3"/>', ipoc=42).encode(), 6)
    assert rob.ipoc == 42 and rob.axes_deg == (0.0, 1.0, 2.0, 3.0, 4.0, 5.0) and rob.force_n == (1.0, 2.0, 3.0)
    assert parse_rob(ROB.format(a=np.zeros(6), ft="", ipoc=1).encode(), 6).force_n is None
    with pytest.raises(InputError, match="without <IPOC>"):
        parse_rob(b'<Rob><AIPos A1="0"/></Rob>', 6)
    with pytest.raises(InputError, match=r"A1\.\.A6"):
        parse_rob(b'<Rob><AIPos A1="0" A2="x"/><IPOC>3</IPOC></Rob>', 6)
    assert b'<RKorr X="1.0000" Y="-2.0000" Z="0.5000"' in sen_packet(7, np.array([1.0, -2.0, 0.5]))


def test_the_server_answers_every_cycle_with_the_compensators_correction() -> None:
    spec = TwinSpec()
    twin = spec.build()
    robot = twin.robot
    server = RsiServer(OnlineCompensator(spec), robot)
    report = {}
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, CYCLES, 2.0)))
    thread.start()
    q_deg = np.degrees(robot.controller_angles(np.array(robot.q_home_rad)))
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.5)
    answers, round_trip = [], []
    try:
        start = time.perf_counter()
        for k in range(CYCLES):
            packet = ROB.format(a=q_deg, ft='<FT Fx="{:.3f}" Fy="{:.3f}" Fz="{:.3f}"/>'.format(*_ft(k)), ipoc=4 * k)
            sent = time.perf_counter()
            client.sendto(packet.encode(), ("127.0.0.1", server.port))
            answers.append(client.recvfrom(4096)[0])
            round_trip.append(time.perf_counter() - sent)
            time.sleep(max(0.0, start + 0.004 * (k + 1) - time.perf_counter()))
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    r = report["r"]
    assert r.cycles == CYCLES and r.unreadable == 0 and r.stopped == "cycles"
    assert all(f"<IPOC>{4 * k}</IPOC>".encode() in a for k, a in enumerate(answers))
    # the same inputs through a compensator of our own: the RKorr of the last answer, base frame, mm
    direct = OnlineCompensator(spec)
    q = np.array(robot.q_home_rad)
    for k in range(CYCLES):
        direct.step(0.004 * k, 0.004 * k, _ft(k), q)
    expected_mm = 1e3 * twin.R_base_sheet @ direct.correction_m
    last = parse_rkorr(answers[-1])
    np.testing.assert_allclose(last, expected_mm, atol=1e-4)  # the packet's 4 decimals
    assert np.linalg.norm(last) > 0.5
    print(f"round trip p50 {1e3 * np.median(round_trip):.3f} ms, p99 {1e3 * np.percentile(round_trip, 99):.3f} ms; "
          f"compute p99 {np.percentile(r.compute_us, 99):.1f} us")


def parse_rkorr(answer: bytes) -> np.ndarray:
    import re

    m = re.search(rb'<RKorr X="([-\d.]+)" Y="([-\d.]+)" Z="([-\d.]+)"', answer)
    assert m is not None
    return np.array([float(v) for v in m.groups()])


def test_the_server_stops_by_itself_when_no_packet_comes() -> None:
    spec = TwinSpec()
    server = RsiServer(OnlineCompensator(spec), load_robot())
    try:
        report = server.serve(np.eye(3), 10, idle_timeout_s=0.05, start_timeout_s=0.05)
    finally:
        server.close()
    assert report.cycles == 0 and report.stopped == "start_timeout"


def test_the_command_serves_and_stops_when_idle(capsys) -> None:
    import json

    from twin.cli import main

    assert main(["online", "--serve", "rsi", "--port", "0", "--cycles", "5", "--idle-timeout-s", "0.05",
                 "--start-timeout-s", "0.05", "--json", "-"]) == 1  # no robot came: a failed session
    doc = json.loads(capsys.readouterr().out)
    assert doc["cycles"] == 0 and doc["stopped"] == "start_timeout" and doc["port"] > 0
    assert doc["failure"].startswith("no packet answered")


def test_export_online_writes_krl_with_rsi_and_its_ethernet_configuration(tmp_path, capsys) -> None:
    import xml.etree.ElementTree as ET

    from twin.cli import main

    assert main(["path", "--shape", "groove", "--out", str(tmp_path / "g.csv")]) == 0
    assert main(["export", str(tmp_path / "g.csv"), "--robot", "kr210", "--online",
                 "--out", str(tmp_path / "ISF.src")]) == 0
    src = (tmp_path / "ISF.src").read_text().splitlines()
    on, off = src.index("ret=RSI_ON(#ABSOLUTE,#IPO_FAST)"), src.index("ret=RSI_OFF()")
    create = src.index('ret=RSI_CREATE("ISF_RSI.rsix",CONTID,TRUE)')
    assert src.index("PTP XHOME_ISF") < src.index("PTP P_PATH[1]") < create < on
    assert (tmp_path / "ISF_RSI.rsix").is_file()  # the context RSI_CREATE names
    retract = max(i for i, line in enumerate(src) if line.startswith("SLIN P_PATH["))  # the path's last move
    assert on < src.index("SLIN P_PATH[2]") < src.index("SPLINE") < retract < off  # RSI on over the whole path
    assert src[off + 4 :] == ["PTP XHOME_ISF", "END"]  # off before the move HOME
    assert (tmp_path / "ISF.dat").is_file()
    root = ET.parse(tmp_path / "ISF_rsi_ethernet.xml").getroot()
    assert root.findtext("CONFIG/PORT") == "49152" and root.findtext("CONFIG/SENTYPE") == "ImFree"
    sent = [e.get("TAG") for e in root.iter("ELEMENT") if e.get("INDX") != "INTERNAL" and "RKorr" not in e.get("TAG")]
    received = [e.get("TAG") for e in root.find("RECEIVE").iter("ELEMENT")]
    assert sent == ["FT.Fx", "FT.Fy", "FT.Fz"] and received == [f"RKorr.{a}" for a in "XYZABC"]
    capsys.readouterr()
    assert main(["export", str(tmp_path / "g.csv"), "--online", "--format", "krl", "--out", str(tmp_path / "x")]) == 2
    assert "the online formats are krl-rsi, rapid-egm, val3-alter" in capsys.readouterr().err
