"""A user's URDF that points its tool forward at zero and carries no tool mass (ROS-Industrial's tool0 convention;
tests/data/arm_tool_forward.urdf) is completed with a tool-down home, plans and checks a path, and exports once its
tool mass is declared; without it the export names what to declare (issue #46: the tool axis not down at home
made IK fail on NaN, the massless tool a refusal of a `--tool-mass-kg 0.0` nobody typed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_refusal import refused

from twin.cli import main
from twin.robot.description import load_robot
from twin.robot.kinematics import Kinematics

URDF = Path(__file__).parent / "data" / "arm_tool_forward.urdf"

pytestmark = pytest.mark.filterwarnings("ignore::twin.errors.AssumptionWarning")


def test_the_completed_home_points_the_tool_down_by_the_wrist() -> None:
    kin = Kinematics(robot=load_robot(str(URDF)))
    _, R_home = kin.fk(kin.q_home)
    assert R_home[:, 2] == pytest.approx([0.0, 0.0, -1.0], abs=1e-4)
    assert np.degrees(kin.q_home) == pytest.approx([0.0, 0.0, 0.0, 0.0, 90.0, 0.0], abs=0.5)  # the wrist only
    assert np.all(np.isfinite(kin.R_tool_down))


def test_a_path_is_checked_and_exported_once_the_tool_mass_is_declared(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "40", "--depth-mm", "4", "--robot", str(URDF),
                 "--out", str(path)]) == 0
    assert "turned 90 deg by the wrist so the tool points down" in capsys.readouterr().err
    out = tmp_path / "cone.ngc"
    refused(["export", str(path), "--robot", str(URDF), "--format", "gcode", "--out", str(out)], capsys,
            "carries no mass at its tool", "--tool-mass-kg", never=(out,))
    assert main(["export", str(path), "--robot", str(URDF), "--format", "gcode", "--tool-mass-kg", "3",
                 "--out", str(out)]) == 0
    assert "3 kg [from --tool-mass-kg]" in out.read_text()
