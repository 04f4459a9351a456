"""Issue #46's bad-input catalogue, second part: a robot language not the robot's maker's, a second connection to
the VAL3 alter server, a path spacing that would make too many samples, a non-finite number in an import
mapping, absurd forces in a run. Each is refused with exit 2 (or, for a connection, closed at once and counted)
and a message naming the file, the option or the key and what was expected; never a traceback or a hang."""

from __future__ import annotations

import shutil
import socket
import threading
from pathlib import Path

import numpy as np
import pytest
from cli_refusal import refused
from test_online_val3 import _recv

from twin.apps.online import alter_protocol as proto
from twin.apps.online.cycle import ServeReport
from twin.apps.online.val3 import Val3Server
from twin.cli import main
from twin.errors import RunFormatError
from twin.robot.description import load_robot
from twin.sim.online import OnlineCompensator
from twin.sim.spec import TwinSpec


# ---------------------------------------------------------------- 1. another maker's robot language
@pytest.mark.parametrize(("fmt", "language", "robot", "own"), [
    ("krl", "KRL", "tx200", "'VAL3'"), ("rapid", "RAPID", "tx200", "'VAL3'"), ("val3", "VAL3", "kr210", "'KRL'"),
])
def test_another_makers_language_is_refused(
    fmt: str, language: str, robot: str, own: str, tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / f"o.{fmt}"
    refused(["export", str(tiny), "--robot", robot, "--format", fmt, "--out", str(out)], capsys,
            f"--format {fmt} writes {language}", f"robot {robot!r}", f"runs {own}", "gcode or csv")
    assert not any(tmp_path.glob("o*"))


def test_the_open_formats_stay_open_and_the_robots_own_language_is_written(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for fmt, name in (("gcode", "o.ngc"), ("csv", "o.csv"), ("val3", "o")):
        assert main(["export", str(tiny), "--format", fmt, "--out", str(tmp_path / name)]) == 0, fmt
    assert "note:" not in capsys.readouterr().err


def _user_model(folder: Path) -> Path:
    """A user's own robot model file (the TX200's robot-only MJCF copied, its meshes beside it): completed by
    `twin.robot.user_model` as a URDF is, it declares no vendor and no language."""
    shutil.copytree(load_robot().mjcf.parent / "assets", folder / "assets", dirs_exist_ok=True)
    target = folder / "arm.xml"
    target.write_text(load_robot().mjcf.read_text())
    return target


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_a_users_own_robot_model_exports_the_open_formats_and_is_told_what_to_declare(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    urdf = _user_model(tmp_path)
    for fmt, name in (("gcode", "u.ngc"), ("csv", "u.csv")):
        capsys.readouterr()
        assert main(["export", str(tiny), "--robot", str(urdf), "--format", fmt, "--out", str(tmp_path / name)]) == 0, (
            fmt, capsys.readouterr().err)
    refused(["export", str(tiny), "--robot", str(urdf), "--format", "krl", "--out", str(tmp_path / "u.src")],
            capsys,
            "--format krl writes KRL", "robot 'arm'", "runs 'unknown'", "gcode or csv",
            "declares vendor and language = 'KRL'")
    refused(["export", str(tiny), "--robot", str(urdf), "--out", str(tmp_path / "u.x")], capsys,
            "robot 'arm' runs 'unknown'", "--format")
    assert not (tmp_path / "u.src").exists() and not (tmp_path / "u.x").exists()


# ---------------------------------------------------------------- 2. a second connection to the VAL3 server
def test_a_second_connection_to_the_val3_server_is_closed_at_once_counted_and_logged() -> None:
    twin = TwinSpec().build()
    lines: list[str] = []
    server = Val3Server(OnlineCompensator(TwinSpec()), load_robot(), log=lines.append)
    report: dict[str, ServeReport] = {}
    thread = threading.Thread(target=lambda: report.setdefault("r", server.serve(twin.R_base_sheet, 4, 2.0)))
    thread.start()
    q_deg = np.degrees(load_robot().controller_angles(np.array(load_robot().q_home_rad)))
    first = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
    second = None
    try:
        first.sendall(proto.encode_request(1, q_deg))
        assert proto.decode_answer(_recv(first, proto.ANSWER_BYTES)).seq == 1
        second = socket.create_connection(("127.0.0.1", server.port), timeout=2.0)
        try:
            closed = second.recv(64) == b""  # closed by the server, not left waiting (2 s bound)
        except ConnectionResetError:
            closed = True
        assert closed
        first.sendall(proto.encode_request(2, q_deg))  # the first session goes on
        assert proto.decode_answer(_recv(first, proto.ANSWER_BYTES)).seq == 2
    finally:
        first.close()
        if second is not None:
            second.close()
        thread.join(timeout=10.0)
        server.close()
    assert not thread.is_alive()
    r = report["r"]
    assert r.cycles == 2 and r.stopped == "disconnected" and r.refused == 1
    assert len(lines) == 1 and "refused a second connection from 127.0.0.1:" in lines[0]
    assert "one peer per session" in lines[0]


# ---------------------------------------------------------------- 3. a spacing that would make too many samples
@pytest.mark.parametrize("shape", ["groove", "cone", "pyramid"])
@pytest.mark.parametrize("spacing", ["1e-300", "1e-6"])
def test_a_spacing_that_would_make_too_many_samples_is_refused_before_allocating(
    shape: str, spacing: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "p.csv"
    extra = ["--mode", "z-level"] if shape == "pyramid" else []
    refused(["path", "--shape", shape, *extra, "--spacing-mm", spacing, "--no-reach-check", "--out", str(out)],
            capsys, f"--spacing-mm {float(spacing):g}", "samples or more", "expected at most 5,000,000 samples",
            "a spacing of at least")
    assert not out.exists()


def test_a_gcode_program_at_a_tiny_spacing_is_refused_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    program = tmp_path / "p.ngc"
    program.write_text("G21 G90\nG0 X0 Y0 Z0\nG1 X50 Y0 F600\nG2 X0 Y50 I-50 J0\n")
    out = tmp_path / "p.csv"
    for spacing in ("1e-300", "1e-6"):
        refused(["path", "--gcode", str(program), "--spacing-mm", spacing, "--no-reach-check", "--out", str(out)],
                capsys, f"--spacing-mm {float(spacing):g}", str(program), "expected at most 5,000,000 samples")
    assert not out.exists()
    assert main(["path", "--gcode", str(program), "--spacing-mm", "0.5", "--no-reach-check", "--out", str(out)]) == 0


# ---------------------------------------------------------------- 4. a number in an import mapping not finite
@pytest.fixture(scope="module")
def mapping_cell(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from test_import_mapping import cell  # the synthetic cell's raw files and mapping

    return cell.__wrapped__(tmp_path_factory)  # type: ignore[attr-defined]


@pytest.mark.parametrize(("old", "new", "key", "written"), [
    ("offset_s = 2.0", "offset_s = 1e999", "forces.clock.offset_s", "1e999"),
    ("rate_hz = 30", "rate_hz = inf", "forces.rate_hz", "inf"),
    ("points_sheet = [[0, 0, 0], [100, 0, 0]", "points_sheet = [[0, 0, nan], [100, 0, 0]",
     "tracker.frame.points_sheet[0][2]", "nan"),
    ('scenario = "synthetic"', 'scenario = "synthetic"\nyaw_deg = -inf', "run.yaw_deg", "-inf"),
])
def test_a_number_in_an_import_mapping_not_finite_is_refused_naming_the_key(
    old: str, new: str, key: str, written: str, mapping_cell: Path, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    text = mapping_cell.read_text()
    assert old in text
    for name in ("cmd.csv", "tracker.csv", "forces.csv"):
        (tmp_path / name).write_bytes((mapping_cell.parent / name).read_bytes())
    mapping = tmp_path / "mapping.toml"
    mapping.write_text(text.replace(old, new, 1))
    line = next(n for n, row in enumerate(mapping.read_text().splitlines(), 1) if written in row and "=" in row)
    refused(["import", "--mapping", str(mapping), "--out", str(tmp_path / "run")], capsys,
            f"{mapping}, line {line}, {key.split('[')[0]}: {key} = {written} is not finite",
            "expected a finite number")
    assert not (tmp_path / "run").exists()


# ---------------------------------------------------------------- 5. absurd forces in a run or an import
def test_a_run_whose_forces_are_a_million_times_too_large_is_refused_on_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from twin.process.toolpath.groove import GrooveSpec, groove_path
    from twin.runs.format import Run, Stream, run_meta
    from twin.runs.read import read_commanded_csv, read_run
    from twin.runs.write import write_path_csv, write_run

    path_csv = write_path_csv(groove_path(GrooveSpec(passes=2, bottom_length_m=0.066)), tmp_path / "p.csv")

    stream = read_commanded_csv(path_csv)
    rate = 1.0 / float(np.median(np.diff(stream.t_s)))
    meta = run_meta(scenario="cell", source="test", tracker_rate_hz=rate, sensor_rate_hz=rate, seed=0,
                    tool_length_m=0.27494, robot="tx200")
    forces = np.tile([20.0, -5.0, 1500.0], (len(stream.t_s), 1))
    run = write_run(tmp_path / "run", Run(None, meta, stream, stream, Stream(stream.t_s, forces)))
    out = tmp_path / "o.csv"
    assert main(["export", str(path_csv), "--run", str(run), "--format", "csv", "--out", str(out)]) == 0
    out.unlink()
    lines = (run / "forces.csv").read_text().splitlines()
    fields = lines[8].split(",")  # data row 8 (line 1: the header)
    lines[8] = ",".join([*fields[:-1], "1.5e9"])  # 1500 N written in µN
    (run / "forces.csv").write_text("\n".join(lines) + "\n")
    refused(["export", str(path_csv), "--run", str(run), "--format", "csv", "--out", str(out)], capsys,
            str(run / "forces.csv"), "row 8", "force component 1.5e+09 N (fz_n)", "-50000..50000 N",
            "expected a value in that range")
    assert not out.exists()
    with pytest.raises(RunFormatError, match="row 8: force component"):
        read_run(run)


def test_an_import_whose_forces_are_a_million_times_too_large_is_refused(
    mapping_cell: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("cmd.csv", "tracker.csv", "mapping.toml"):
        (tmp_path / name).write_bytes((mapping_cell.parent / name).read_bytes())
    rows = (mapping_cell.parent / "forces.csv").read_text().splitlines()
    scaled = [";".join(f"{float(v.replace(',', '.')) * 1e6:.1f}".replace(".", ",") for v in row.split(";"))
              for row in rows]
    (tmp_path / "forces.csv").write_text("\n".join(scaled) + "\n")
    refused(["import", "--mapping", str(tmp_path / "mapping.toml"), "--out", str(tmp_path / "run")], capsys,
            str(tmp_path / "forces.csv"), "forces.unit", "expected at most 50000 N")
    assert not (tmp_path / "run").exists()
