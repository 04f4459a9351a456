"""Arm configurations in exported programs (twin/apps/export/configuration.py): the vendors' encodings on
hand-made joint vectors, the TX200's groove written in its own language with its IK solution's configuration,
a run's tool, and a path whose configuration changes refused at the row where it does."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from twin.apps.export import export_path, robot_format
from twin.apps.export.configuration import (
    RobotConfiguration,
    arm_geometry,
    check_one_configuration,
    robot_configurations,
)
from twin.apps.export.program import default_cell
from twin.cli import main
from twin.errors import InputError, ModelError
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.robot.description import load_robot
from twin.robot.kinematics import Kinematics
from twin.runs.format import Run, run_meta
from twin.runs.read import read_commanded_csv
from twin.runs.write import write_path_csv, write_run


def _config(q_deg: list[float]) -> RobotConfiguration:
    """The TX200's configuration at MJCF angles in degrees (its controller angles are the same)."""
    return robot_configurations("tx200", np.radians(q_deg))[0]


@pytest.fixture(scope="module")
def path_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2-pass groove, written as `tx200-twin path` does."""
    path = groove_path(GrooveSpec(passes=2, bottom_length_m=0.066))
    return write_path_csv(path, tmp_path_factory.mktemp("p") / "g.csv")


def _ik_configuration(path_csv: Path, tool_length_m: float | None = None) -> RobotConfiguration:
    """The program's first point's configuration from the twin's own IK (the cell's sheet origin, tool down): the
    approach point, 20 mm straight above the path's first point (the groove's highest points lie on the sheet
    top, z = 0)."""
    kin = Kinematics()
    p_sheet = read_commanded_csv(path_csv).values
    approach = p_sheet[0] + np.array([0.0, 0.0, 0.020])
    p_base = kin.p_base_sheet_origin + np.vstack([approach, p_sheet])
    if tool_length_m is not None:  # the flange where this tool puts it: the model's tool tip that far higher
        p_base = p_base + np.array([0.0, 0.0, tool_length_m - kin.robot.tool_length_m])
    return robot_configurations(kin.robot, kin.ik_path(p_base))[0]


def _tx200_run(path_csv: Path, directory: Path, tool_length_m: float) -> Path:
    """A run of the TX200 along the path (tracker = command) whose meta.json records `tool_length_m`."""
    stream = read_commanded_csv(path_csv)
    rate = 1.0 / float(np.median(np.diff(stream.t_s)))
    meta = run_meta(scenario="cell", source="test", tracker_rate_hz=rate, sensor_rate_hz=rate, seed=0,
                    tool_length_m=tool_length_m, robot="tx200")
    return write_run(directory, Run(None, meta, stream, stream))


def test_turn_bits_are_the_negative_axes() -> None:
    config = RobotConfiguration((-10.0, 20.0, -30.0, 40.0, -50.0, 60.0), False, False, True)
    assert config.kuka_turn == 0b010101
    assert config.krl == "S 'B110',T 'B010101'"
    assert RobotConfiguration((0.0,) * 6, False, False, False).krl == "S 'B010',T 'B000000'"


def test_autodesk_kuka_post_example_encodes_as_published() -> None:
    """Autodesk's KUKA post starts at {5, -80, 100, 75, -60, -65} with S 'B110', T 'B110010' (front, elbow up)."""
    config = RobotConfiguration((5.0, -80.0, 100.0, 75.0, -60.0, -65.0), False, False, True)
    assert config.krl == "S 'B110',T 'B110010'"


@pytest.mark.parametrize(("j1", "cf1"), [(-30.0, -1), (45.0, 0), (100.0, 1), (-100.0, -2), (0.0, 0), (-90.0, -1)])
def test_cf1_is_the_quadrant_of_axis_1(j1: float, cf1: int) -> None:
    config = RobotConfiguration((j1, 0.0, 0.0, 190.0, 10.0, -270.0), False, False, False)
    assert config.rapid == (cf1, 2, -3, 0)


def test_cfx_follows_abbs_table_of_eight() -> None:
    """cfx 0..7: (behind axis 1, behind the lower arm, axis 5 negative) as ABB lists them."""
    order = [(r, e, w) for r in (False, True) for e in (False, True) for w in (False, True)]
    assert [RobotConfiguration((0.0,) * 6, *flags).rapid[3] for flags in order] == list(range(8))


def test_wrist_flips_with_the_sign_of_axis_5() -> None:
    up, flipped = _config([0, 38, 90, 0, 30, 0]), _config([0, 38, 90, 0, -30, 0])
    assert (up.axis5_negative, flipped.axis5_negative) == (False, True)
    assert up.val3[2] == "wpositive" and flipped.val3[2] == "wnegative"
    assert flipped.kuka_status == up.kuka_status + 4 and flipped.rapid[3] == up.rapid[3] + 1
    assert _config([0, 38, 90, 0, 200, 0]).axis5_negative and not _config([0, 38, 90, 0, -200, 0]).axis5_negative


def test_elbow_is_the_side_of_the_lower_arm() -> None:
    """The TX200's arm is stretched at q3 = 0 (a3 = 0): q3 > 0 is elbow up (epositive), q3 < 0 elbow down."""
    up, down = _config([0, 38, 30, 0, 50, 0]), _config([0, 38, -30, 0, 50, 0])
    assert (up.behind_lower_arm, down.behind_lower_arm) == (False, True)
    assert (up.val3[1], down.val3[1]) == ("epositive", "enegative")
    assert up.kuka_status & 2 and not down.kuka_status & 2
    assert down.rapid[3] == 2 and down.kuka_turn == 0b000100


def test_shoulder_is_the_wrist_centre_against_axis_1() -> None:
    """Turning axis 1 turns the front with it; leaning back over axis 1 puts the wrist centre behind it."""
    assert not _config([180, 38, 90, 0, 50, 0]).behind_axis1
    back = _config([0, -80, -10, 0, 10, 0])
    assert back.behind_axis1 and back.val3[0] == "righty" and back.kuka_status & 1 and back.rapid[3] >= 4


def test_solver_noise_at_zero_is_not_a_negative_axis() -> None:
    config = robot_configurations("tx200", np.radians([0, 38, 90, 0, 50, 0]) + np.array([0, 0, 0, -1e-13, 0, 0]))[0]
    assert config.axes_deg[3] == 0.0 and config.kuka_turn == 0 and config.rapid[1] == 0


def test_a_configuration_change_is_refused_at_its_row() -> None:
    q = np.tile(np.radians([0.0, 38.0, 90.0, 0.0, 0.0, 0.0]), (9, 1))
    q[:, 4] = np.radians(np.linspace(20.0, -20.0, 9))  # through the wrist flip: row 6 is the first at -5°
    configs = robot_configurations("tx200", q)
    with pytest.raises(InputError, match=r"path\.csv, row 6: .*axis 5 positive .*lefty/epositive/wpositive.*"
                       r"axis 5 negative .*wnegative"):
        check_one_configuration(configs, "path.csv", "VAL3")
    check_one_configuration(configs[:5], "path.csv")


def test_a_robot_without_a_dh_table_is_named() -> None:
    robot = replace(load_robot(), name="no_dh", dh=None)
    with pytest.raises(ModelError, match=r"'no_dh'.*no \[dh\] table"):
        arm_geometry(robot, np.zeros(robot.dof))


def test_the_robots_language_is_the_default_format() -> None:
    robot = load_robot()
    assert robot_format(robot) == "val3"
    assert robot_format(replace(robot, language="KRL")) == "krl"
    assert robot_format(replace(robot, language="RAPID")) == "rapid"
    with pytest.raises(InputError, match=r"runs 'INFORM'.*--format"):
        robot_format(replace(robot, language="INFORM"))


def test_tx200_groove_exports_val3_by_default_with_the_ik_configuration(
    path_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "isf"
    assert main(["export", str(path_csv), "--out", str(out), "--json", str(tmp_path / "s.json")]) == 0
    assert "note:" not in capsys.readouterr().err
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["format"] == "val3" and summary["robot"] == "tx200"
    values = [v for d in ET.parse(out / "isf.dtx").getroot().iter() if d.get("name") == "pPath" for v in d]
    first = tuple(values[0].get(k) for k in ("shoulder", "elbow", "wrist"))
    assert first == _ik_configuration(path_csv).val3 == ("lefty", "epositive", "wpositive")
    assert {(v.get("shoulder"), v.get("elbow"), v.get("wrist")) for v in values[1:]} == {("ssame", "esame", "wsame")}


def test_krl_on_the_tx200_is_refused_and_the_writer_gives_status_and_turn(
    path_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the CLI refuses another maker's language (the writer itself still writes any robot's IK configuration)
    assert main(["export", str(path_csv), "--format", "krl", "--out", str(tmp_path / "cli.src")]) == 2
    err = capsys.readouterr().err
    assert "--format krl writes KRL" in err and "'tx200'" in err and "runs 'VAL3'" in err
    assert not (tmp_path / "cli.src").exists() and not (tmp_path / "cli.dat").exists()
    export_path(path_csv, "krl", tmp_path / "isf.src", cell=default_cell())
    dat = (tmp_path / "isf.dat").read_text()
    first = re.search(r"^P_PATH\[1\]=\{(.*)\}$", dat, re.M).group(1)  # type: ignore[union-attr]
    assert first.endswith(_ik_configuration(path_csv).krl)
    assert not re.search(r"^P_PATH\[2\]=.*S '", dat, re.M)
    assert "PTP P_PATH[1]" in (tmp_path / "isf.src").read_text()


def test_rapid_writes_each_points_robconf(path_csv: Path, tmp_path: Path) -> None:
    path, files, _ = export_path(path_csv, "rapid", tmp_path / "isf.mod", cell=default_cell())
    text = files[0].read_text()
    confs = re.findall(r"\],\[(-?\d+,-?\d+,-?\d+,\d)\],\[9E9", text)
    assert len(confs) == len(path.points_mm) == len(path.configurations)
    assert confs[0] == ",".join(map(str, _ik_configuration(path_csv).rapid))
    assert "ConfJ \\On;" in text and "ConfL \\Off;" in text
    assert path.cell.configuration == path.configurations[0]


def test_a_tool_not_held_down_is_refused(path_csv: Path, tmp_path: Path) -> None:
    cell = replace(default_cell(), R_sheet_tool=np.eye(3))
    with pytest.raises(InputError, match=r"turned 180° from the twin's tool-down"):
        export_path(path_csv, "val3", tmp_path / "isf", cell=cell)


def test_run_gives_the_tool_length(path_csv: Path, tmp_path: Path) -> None:
    """A run whose meta.json says a 300 mm tool: the program's tool is 300 mm, the configuration solved for it."""
    run_dir = _tx200_run(path_csv, tmp_path / "run", tool_length_m=0.3)
    out = tmp_path / "isf"
    assert main(["export", str(path_csv), "--run", str(run_dir), "--out", str(out),
                 "--json", str(tmp_path / "s.json")]) == 0
    summary = json.loads((tmp_path / "s.json").read_text())
    assert summary["tool_length_mm"] == pytest.approx(300.0)
    axes = summary["configuration"]["axes_deg"]  # the flange 25 mm higher than with the robot's own tool
    assert axes == pytest.approx(_ik_configuration(path_csv, 0.3).axes_deg, abs=1e-5)
    assert np.max(np.abs(np.subtract(axes, _ik_configuration(path_csv).axes_deg))) > 0.5
    tool = next(v for d in ET.parse(out / "isf.dtx").getroot().iter() if d.get("name") == "tIsf" for v in d)
    assert float(tool.get("z", "nan")) == pytest.approx(300.0)
    first = next(v for d in ET.parse(out / "isf.dtx").getroot().iter() if d.get("name") == "pPath" for v in d)
    assert (first.get("shoulder"), first.get("elbow"), first.get("wrist")) == _ik_configuration(path_csv, 0.3).val3


@pytest.fixture(scope="module")
def kuka_like(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A synthetic robot description: the TX200's arm and files, but a KRL controller."""
    shipped = load_robot()
    text = shipped.source.read_text(encoding="utf-8")
    text = re.sub(r'^name = ".*"$', 'name = "tx200_krl"', text, flags=re.M)
    text = re.sub(r'^language = ".*"$', 'language = "KRL"', text, flags=re.M)
    text = re.sub(r'^mjcf = ".*"$', f'mjcf = "{shipped.mjcf}"', text, flags=re.M)
    text = re.sub(r'^scene = ".*"$', f'scene = "{shipped.scene}"', text, flags=re.M)
    out = tmp_path_factory.mktemp("robot") / "tx200_krl.toml"
    out.write_text(text, encoding="utf-8")
    return out


def test_a_krl_robot_gets_krl_by_default_and_a_run_of_another_robot_is_refused(
    path_csv: Path, kuka_like: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", str(path_csv), "--robot", str(kuka_like), "--out", str(tmp_path / "isf.src")]) == 0
    assert "note:" not in capsys.readouterr().err
    dat = (tmp_path / "isf.dat").read_text()
    assert re.search(r"^P_PATH\[1\]=\{.*,S 'B010',T 'B\d{6}'\}$", dat, re.M)
    run_dir = _tx200_run(path_csv, tmp_path / "run", tool_length_m=0.3)
    code = main(["export", str(path_csv), "--robot", str(kuka_like), "--run", str(run_dir),
                 "--out", str(tmp_path / "other.src")])
    assert code == 2
    assert "--robot gives robot 'tx200_krl', but the run" in capsys.readouterr().err
