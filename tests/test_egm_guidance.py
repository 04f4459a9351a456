"""ABB EGM position guidance (#50): the RAPID export `rapid-egm-pose` (twin/apps/export/rapid_egm_pose.py) and the
guidance server (twin/apps/online/egm_pose.py), with a fake robot on 127.0.0.1 (bounded loops that stop by
themselves).

The program is run by the RAPID checker of `tests/test_export_rapid_egm.py`: EGM set up after the joint move to the
approach point, checked (`EGMGetState`), activated for a pose target in the sheet frame at a sample rate that is a
multiple of 4 ms, run on every axis, stopped before the uncorrected retract; the lost-link handler lifts the tool
out of the sheet; no controller slot (tool0, wobj0) written. The server streams the exported table's path from the
robot's first valid message at the programmed feeds (by the robot's stamps), adds the correction on every axis,
holds the last point, answers a message with a NaN with the last pose without moving its clock, and ignores a
second sender.
"""

from __future__ import annotations

import math
import re
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from test_export_rapid_egm import MOVES, Program, check_egm_program

from twin.apps.export import export_path, rapid_egm, rapid_egm_pose
from twin.apps.export.program import CellSetup, default_cell
from twin.apps.online.egm import egm_messages
from twin.apps.online.egm_pose import MAX_STEP_S, EgmPoseServer, GuidancePath, pose_of
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.runs.write import write_path_csv
from twin.sim.online import OnlineCompensator
from twin.sim.spec import TwinSpec

ROBOT = "irb6640"
pb = egm_messages()


@pytest.fixture(scope="module")
def path_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2-pass groove, 279 points."""
    return write_path_csv(groove_path(GrooveSpec(passes=2, bottom_length_m=0.066)),
                          tmp_path_factory.mktemp("guide") / "short.csv")


@pytest.fixture(scope="module")
def two_feeds_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 3-pass groove with its second pass at half the feed (the program keeps a feed below the process feed)."""
    path = groove_path(GrooveSpec(passes=3, bottom_length_m=0.066))
    dt = np.diff(path.t_s, prepend=0.0)
    dt[path.pass_index == 2] *= 2.0
    path = type(path)(np.cumsum(dt), path.p_sheet_m, path.pass_index, path.direction)
    return write_path_csv(path, tmp_path_factory.mktemp("guide2") / "two_feeds.csv")


@pytest.fixture(scope="module")
def cell() -> CellSetup:
    return default_cell(robot=ROBOT)


def _files(path_csv: Path, out: Path, cell: CellSetup, fmt: str = "rapid-egm-pose") -> dict[str, str]:
    return {f.name: f.read_text() for f in export_path(path_csv, fmt, out, cell=cell).files}


def test_the_pose_program_guides_every_axis_from_the_approach_point(path_csv: Path, cell: CellSetup,
                                                                    tmp_path: Path) -> None:
    exported = export_path(path_csv, "rapid-egm-pose", tmp_path / "ISF.mod", cell=cell)
    files = {f.name: f.read_text() for f in exported.files}
    assert sorted(files) == ["ISF.mod", "ISF.pgf", "ISF_egm_moc.cfg", "ISF_egm_pose.csv", "ISF_egm_sio.cfg"]
    program, text = Program(files), files["ISF.mod"]
    kinds = [s.kind for s in program.steps]
    order = ["MoveJ", "EGMReset", "EGMGetId", "EGMSetupUC", "EGMActPose", "EGMRunPose", "EGMStop", "MoveL"]
    assert [k for k in kinds if k in order] == order  # each once, in this order, on the normal run
    assert kinds[0] == "ConfJ" and kinds.count("MoveAbsJ") == 2 and kinds[-1] == "MoveAbsJ"
    assert not {"EGMMoveL", "EGMActMove"} & set(kinds)  # no path correction in a guidance program
    steps = {s.kind: s for s in program.steps}
    moves = [s for s in program.steps if s.kind in MOVES]
    np.testing.assert_allclose(np.array([moves[0].point, moves[-1].point], dtype=float), exported.path.points_mm[[0, -1]], atol=1e-4)
    setup = steps["EGMSetupUC"].args
    assert setup[:2] == ["ROB_1", "egmID"] and re.fullmatch(r'"UCdevice"\\Pose\\CommTimeout:=\d+', setup[3])
    act = ",".join(steps["EGMActPose"].args)
    assert act.startswith("egmID\\Tool:=tIsf\\WObj:=wSheet,pose0,EGM_FRAME_WOBJ,pose0,EGM_FRAME_WOBJ")
    rate = re.search(r"\\SampleRate:=(\d+)", act)
    assert rate and int(rate.group(1)) > 0 and int(rate.group(1)) % 4 == 0
    limits = dict(re.findall(r"CONST egm_minmax (\w+):=\[([^\]]*)\];", text))
    for axis in ("x", "y", "z", "rx", "ry", "rz"):
        found = re.search(rf"\\{axis}:=(\w+)", act)
        assert found and found.group(1) in limits, axis  # every axis's convergence limit declared
        low, high = (float(v) for v in limits[found.group(1)].split(","))
        assert low < 0 < high
    run = steps["EGMRunPose"].args
    assert run[0] == "egmID" and run[1].startswith("EGM_STOP_HOLD\\x\\y\\z\\Rx\\Ry\\Rz\\CondTime:=")
    assert "\\RampInTime:=" in run[1] and "NoWaitCond" not in run[1]
    assert steps["EGMStop"].args == ["egmID", "EGM_STOP_HOLD"]
    assert "CONST pose pose0:=[[0,0,0],[1,0,0,0]];" in text
    body = program.main.procs[program.entry]
    check = next(i for i, line in enumerate(body) if line.startswith("IF EGMGetState("))
    setup_at = next(i for i, line in enumerate(body) if line.startswith("EGMSetupUC"))
    act_at = next(i for i, line in enumerate(body) if line.startswith("EGMActPose"))
    assert setup_at < check < act_at and "EXIT;" in body[check:body.index("ENDIF", check)]
    end = next(i for i, line in enumerate(body) if line.startswith("IF Distance("))
    assert body.index(next(x for x in body if x.startswith("EGMStop"))) < end  # where guidance ended, checked
    assert body[end + 2].startswith("MoveL Offs(CRobT(\\Tool:=tIsf\\WObj:=wSheet),0,0,nLift),")
    handler = program.main.handlers[program.entry]
    assert handler[0] == "IF ERRNO = ERR_UDPUC_COMM THEN" and handler[-1] == "RAISE;"  # a lost PC
    words = [line.split()[0].rstrip(";") for line in handler]
    assert words.index("StopMove") < words.index("ClearPath") < words.index("EGMReset") < words.index(
        "MoveL") < words.index("EXIT")  # stop, end EGM, lift out of the sheet, end
    assert next(x for x in handler if x.startswith("MoveL ")).startswith(
        "MoveL Offs(CRobT(\\Tool:=tIsf\\WObj:=wSheet),0,0,nLift),")
    n_lift = program.value(program.main, "nLift")
    assert isinstance(n_lift, int | float)
    assert n_lift >= exported.path.points_mm[-1, 2] - exported.path.points_mm[1:-1, 2].min() - 1e-3
    assert not re.search(r"\b(tool0|wobj0|tool1|wobj1)\b", text)  # the program's own tool and work object only
    assert re.search(r"^  PERS tooldata tIsf:=", text, re.M) and re.search(r"^  PERS wobjdata wSheet:=", text, re.M)


def test_the_guidance_table_is_the_path_at_its_programmed_feeds(two_feeds_csv: Path, cell: CellSetup,
                                                                 tmp_path: Path) -> None:
    """Against the path-correction program of the same path: its points and its `vPath` speeds (two feeds)."""
    path_csv = two_feeds_csv
    pose = _files(path_csv, tmp_path / "p" / "ISF.mod", cell)
    table = GuidancePath.load(tmp_path / "p" / "ISF_egm_pose.csv")
    corrected = export_path(path_csv, "rapid-egm", tmp_path / "c" / "ISF.mod", cell=cell)
    moves = [s for s in Program({f.name: f.read_text() for f in corrected.files}).steps if s.kind in MOVES]
    points = np.array([m.point for m in moves[:-1]])  # the approach and the corrected points, not the retract
    np.testing.assert_allclose(table.points_mm, points, atol=1e-4)
    speeds = np.array([m.speed for m in moves[1:-1]])
    assert speeds.max() > 1.5 * speeds.min()
    durations = np.linalg.norm(np.diff(points, axis=0), axis=1) / speeds
    np.testing.assert_allclose(table.t_s, np.concatenate([[0.0], np.cumsum(durations)]), rtol=1e-4, atol=1e-5)
    q = re.search(r"pApproach:=\[\[[^\]]*\],\[([^\]]*)\]", pose["ISF.mod"])
    assert q and np.allclose(table.quaternions, [float(v) for v in q.group(1).split(",")])
    end = re.search(r"pEnd:=\[\[([^\]]*)\]", pose["ISF.mod"])
    assert end and np.allclose([float(v) for v in end.group(1).split(",")], table.points_mm[-1])


def test_the_configurations_name_the_pose_profile(path_csv: Path, cell: CellSetup, tmp_path: Path) -> None:
    files = _files(path_csv, tmp_path / "ISF.mod", cell)
    profile = re.search(r'EGMSetupUC ROB_1,egmID,"(\w+)","(\w+)"', files["ISF.mod"])
    assert profile and profile.group(2) == rapid_egm.DEVICE
    level = re.search(rf'-name "{profile.group(1)}" -ext_motion_level (\d)', files["ISF_egm_moc.cfg"])
    assert level and int(level.group(1)) in (0, 1)  # position guidance: raw or filtered, never 2 (path)
    assert files["ISF_egm_sio.cfg"] == rapid_egm.sio_config()  # the same device and port as path correction


def test_export_online_for_abb_defaults_to_guidance_and_refuses_bad_modes(
    path_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert rapid_egm_pose.DEFAULT_MODE == "pose"
    base = ["export", str(path_csv), "--online"]
    assert main([*base, "--robot", ROBOT, "--out", str(tmp_path / "a" / "ISF.mod")]) == 0
    said = capsys.readouterr()
    assert "rapid-egm-pose" in said.out and "--guidance" in said.err
    assert (tmp_path / "a" / "ISF_egm_pose.csv").exists()
    assert main([*base, "--robot", ROBOT, "--egm-mode", "path", "--out", str(tmp_path / "b" / "ISF.mod")]) == 0
    files = {f.name: f.read_text() for f in (tmp_path / "b").iterdir()}
    plain = export_path(path_csv, "rapid", tmp_path / "plain" / "ISF.mod", cell=default_cell(robot=ROBOT)).path
    check_egm_program(files, plain)  # path correction, as before #50
    assert "along-path part" in capsys.readouterr().err
    for extra, words in ((["--robot", ROBOT, "--egm-mode", "path", "--format", "rapid-egm-pose"],
                          "contradicts --format"),
                         (["--egm-mode", "pose", "--robot", "kr210"], "--egm-mode chooses ABB's EGM program")):
        assert main([*base, *extra, "--out", str(tmp_path / "c" / "ISF.mod")]) == 2
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err
    with pytest.raises(SystemExit) as exited:  # argparse's choices
        main([*base, "--robot", ROBOT, "--egm-mode", "joint", "--out", str(tmp_path / "c" / "ISF.mod")])
    assert exited.value.code == 2
    assert "invalid choice: 'joint'" in capsys.readouterr().err
    with pytest.raises(InputError, match="--egm-mode 'joint'"):
        rapid_egm_pose.egm_format("rapid-egm", "joint", chosen=False)


# -- the server, with a fake robot ---------------------------------------------------------------------------------

#: A path: down 20 mm at 20 mm/s, then along x 10 mm at 10 mm/s (quaternion: the tool pointing down).
TABLE = GuidancePath(np.array([0.0, 1.0, 2.0]), np.array([[0.0, 0.0, 20.0], [0.0, 0.0, 0.0], [10.0, 0.0, 0.0]]),
                     np.tile([0.0, 0.0, 1.0, 0.0], (3, 1)))


def _message(tm: int, q_deg: np.ndarray, force: np.ndarray | None = None) -> bytes:
    msg = pb.EgmRobot()
    msg.header.seqno, msg.header.tm = tm // 4, tm
    msg.header.mtype = pb.EgmHeader.MessageType.Value("MSGTYPE_DATA")
    msg.feedBack.joints.joints.extend(q_deg.tolist())
    c = msg.feedBack.cartesian.pos
    c.x, c.y, c.z = 1700.0, 0.0, 500.0
    if force is not None:
        msg.measuredForce.fcActive = True
        msg.measuredForce.force.extend([*force.tolist(), 0.0, 0.0, 0.0])
    return msg.SerializeToString()


def _serve(server: EgmPoseServer, R: np.ndarray, cycles: int) -> tuple[threading.Thread, dict[str, object]]:
    report: dict[str, object] = {}
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(R, cycles, 0.5, 5.0)))
    thread.start()
    return thread, report


def _ask(client: socket.socket, port: int, packet: bytes) -> tuple[np.ndarray, np.ndarray]:
    client.sendto(packet, ("127.0.0.1", port))
    reply = pb.EgmSensor()
    reply.ParseFromString(client.recvfrom(4096)[0])
    assert reply.header.mtype == pb.EgmHeader.MessageType.Value("MSGTYPE_CORRECTION")
    return pose_of(reply)


def test_the_server_streams_the_path_by_the_robots_stamps_and_holds_its_end() -> None:
    """No force: no correction, so each pose is the path's point at the robot's time since its first valid message.
    A NaN message (first, and mid-way) is answered with the last pose and does not move the clock; a stamp that jumps
    moves it by `MAX_STEP_S` at most; a second sender is not answered."""
    twin = TwinSpec().build()
    q_deg = np.degrees(twin.robot.controller_angles(np.array(twin.robot.q_home_rad)))
    server = EgmPoseServer(OnlineCompensator(TwinSpec()), twin.robot, TABLE)
    thread, report = _serve(server, twin.R_base_sheet, 10_000)
    client, other = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    client.settimeout(0.5)
    other.settimeout(0.2)
    bad = q_deg.copy()
    bad[2] = math.nan
    poses: list[np.ndarray] = []
    times: list[float] = []
    try:
        p, q = _ask(client, server.port, _message(996, bad))  # NaN before any valid message: the approach point
        np.testing.assert_array_equal(p, TABLE.points_mm[0])
        np.testing.assert_array_equal(q, [0.0, 0.0, 1.0, 0.0])
        assert math.isnan(server.path_time_s)
        start = 1000  # the robot's clock is not the path's: the path starts at the first valid message
        for k in range(600):  # 2.4 s of the robot's stamps (sent as fast as answered: the stamps are the clock)
            if k == 300:
                p_nan, _ = _ask(client, server.port, _message(start + 4 * k, bad))
                np.testing.assert_array_equal(p_nan, poses[-1])  # the last pose again
                other.sendto(_message(start + 4 * k, q_deg), ("127.0.0.1", server.port))
                with pytest.raises(TimeoutError):
                    other.recvfrom(4096)  # another sender: ignored
            p, q = _ask(client, server.port, _message(start + 4 * k, q_deg))
            poses.append(p)
            times.append(0.004 * k)
        jumped, _ = _ask(client, server.port, _message(start + 4 * 600 + 60_000, q_deg))  # a minute later
    finally:
        client.close()
        other.close()
        thread.join(timeout=5.0)
        server.close()
    expected = np.zeros((len(times), 3))
    for i, t in enumerate(times):
        TABLE.at(t, expected[i])
    np.testing.assert_allclose(poses, expected, atol=1e-9)  # the NaN message at 1.2 s never happened
    down = np.diff(np.array(poses)[:250, 2]) / 0.004
    along = np.diff(np.array(poses)[260:490, 0]) / 0.004
    np.testing.assert_allclose(down, -20.0, rtol=1e-9)  # the programmed feeds, by the stamps
    np.testing.assert_allclose(along, 10.0, rtol=1e-9)
    np.testing.assert_array_equal(poses[-1], TABLE.points_mm[-1])  # held at the end
    np.testing.assert_array_equal(jumped, TABLE.points_mm[-1])
    assert server.path_time_s == pytest.approx(times[-1] + MAX_STEP_S)
    r = report["r"]
    assert r.cycles == 603 and r.unreadable == 2 and r.foreign == 1  # type: ignore[attr-defined]  # NaN: answered


def _ft(k: int) -> np.ndarray:
    return np.array([200.0, -50.0, 1500.0]) * min(1.0, k / 100.0)  # the force builds up over 0.4 s


def test_the_server_adds_the_correction_on_every_axis() -> None:
    """The force of `test_online_egm` at a 4 ms pace: the last pose is the held end point plus the compensator's
    correction (computed here directly), along the path too."""
    spec = TwinSpec()
    twin = spec.build()
    robot = twin.robot
    q_deg = np.degrees(robot.controller_angles(np.array(robot.q_home_rad)))
    short = GuidancePath(TABLE.t_s * 0.1, TABLE.points_mm, TABLE.quaternions)  # ends at 0.2 s
    server = EgmPoseServer(OnlineCompensator(spec), robot, short)
    cycles = 250
    thread, report = _serve(server, twin.R_base_sheet, cycles)
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.5)
    try:
        begin = time.perf_counter()
        for k in range(cycles):
            last, _ = _ask(client, server.port, _message(4 * k, q_deg, _ft(k)))
            time.sleep(max(0.0, begin + 0.004 * (k + 1) - time.perf_counter()))
    finally:
        client.close()
        thread.join(timeout=5.0)
        server.close()
    assert report["r"].cycles == cycles  # type: ignore[attr-defined]
    direct = OnlineCompensator(spec)
    for k in range(cycles):
        direct.step(0.004 * k, 0.004 * k, _ft(k), np.array(robot.q_home_rad))
    correction = 1e3 * direct.correction_m  # sheet frame [mm]
    assert np.linalg.norm(correction) > 0.5
    np.testing.assert_allclose(last - short.points_mm[-1], correction, atol=1e-6)
    assert abs(correction[0]) > 0.01  # the last segment runs along x: the along-path part is sent


def test_the_guidance_table_is_checked(tmp_path: Path) -> None:
    header = "t_s,x_mm,y_mm,z_mm,qw,qx,qy,qz\n"
    good = "0,0,0,20,0,0,1,0\n1,0,0,0,0,0,1,0\n"
    for body, words in (("0.5,0,0,20,0,0,1,0\n1,0,0,0,0,0,1,0\n", "starts at 0.5"),
                        ("0,0,0,20,0,0,1,0\n1,0,0,0,0,0,1,0\n0.5,0,0,1,0,0,1,0\n", "not non-decreasing"),
                        ("0,0,0,20,0,0,1,0\n1,0,0,0,0,0,2,0\n", "not a unit quaternion"),
                        ("0,0,0,20,0,0,1,0\n1,0,0,nan,0,0,1,0\n", "finite")):
        (tmp_path / "t.csv").write_text(header + body)
        with pytest.raises(DataFileError, match=words):
            GuidancePath.load(tmp_path / "t.csv")
    (tmp_path / "t.csv").write_text(header.replace(",qz", "") + good.replace(",0\n", "\n"))
    with pytest.raises(DataFileError, match="missing column"):
        GuidancePath.load(tmp_path / "t.csv")


def test_the_command_serves_guidance_from_the_exported_table(path_csv: Path, tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["export", str(path_csv), "--robot", ROBOT, "--online", "--out", str(tmp_path / "ISF.mod")]) == 0
    table = tmp_path / "ISF_egm_pose.csv"
    capsys.readouterr()
    assert main(["online", "--serve", "rsi", "--guidance", str(table)]) == 2
    assert "expected --serve egm" in capsys.readouterr().err
    twin = TwinSpec().build()
    q_deg = np.degrees(twin.robot.controller_angles(np.array(twin.robot.q_home_rad)))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    poses: list[np.ndarray] = []

    def robot() -> None:  # plays the controller until 40 answers came, 5 s at most
        client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        client.settimeout(0.05)
        deadline, k = time.perf_counter() + 5.0, 0
        try:
            while len(poses) < 40 and time.perf_counter() < deadline:
                try:
                    poses.append(_ask(client, port, _message(4 * k, q_deg, _ft(k)))[0])
                    k += 1
                except (TimeoutError, ConnectionRefusedError):
                    time.sleep(0.01)
        finally:
            client.close()

    thread = threading.Thread(target=robot)
    thread.start()
    try:
        code = main(["online", "--serve", "egm", "--port", str(port), "--cycles", "40", "--idle-timeout-s", "2",
                     "--guidance", str(table), "--json", "-"])
    finally:
        thread.join(timeout=10.0)
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["cycles"] == 40 and doc["stopped"] == "cycles" and len(poses) == 40
    path = GuidancePath.load(table)
    assert np.linalg.norm(poses[0] - path.points_mm[0]) < 0.1  # from the approach point, then down the plunge
    assert poses[-1][2] < poses[0][2]
