"""A user's own robot file, as a user types it: `--robot myrobot.xml` in the current folder, a name with quotes, and a
run made with it that replays after the twin's generated description is gone."""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import pytest

from twin.cli import main
from twin.robot.description import load_robot

MODELS = Path(__file__).resolve().parents[1] / "models"


def _mjcf(folder: Path, name: str) -> Path:
    """A user's MJCF of their own: the KR 210's, copied under the user's name (the twin completes it as any)."""
    path = folder / name
    shutil.copyfile(MODELS / "kr210" / "kr210.xml", path)
    return path


def test_a_robot_file_in_the_current_folder_is_a_file_not_a_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    _mjcf(tmp_path, "myrobot.xml")
    monkeypatch.chdir(tmp_path)
    assert main(["path", "--shape", "cone", "--top-width-mm", "20", "--depth-mm", "3", "--robot", "myrobot.xml",
                 "--out", "cone.csv"]) == 0
    assert "unknown robot" not in capsys.readouterr().err
    assert main(["path", "--shape", "cone", "--robot", "nosuch.xml", "--out", "x.csv"]) == 2
    assert "nosuch.xml" in capsys.readouterr().err and not (tmp_path / "x.csv").exists()


def test_a_robot_file_whose_name_holds_quotes_is_read(tmp_path: Path) -> None:
    path = _mjcf(tmp_path, 'arm "v2".xml')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(path)
    assert robot.name == 'arm "v2"' and robot.dof == 6


def test_a_run_made_with_a_user_robot_carries_its_copy_and_replays_without_the_generated_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = _mjcf(tmp_path, "arm.xml")
    cone, run = tmp_path / "cone.csv", tmp_path / "run"
    assert main(["path", "--shape", "cone", "--top-width-mm", "20", "--depth-mm", "3", "--robot", str(urdf),
                 "--out", str(cone)]) == 0
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--commanded", str(cone), "--robot", str(urdf),
                 "--out", str(run)]) == 0
    meta = json.loads((run / "meta.json").read_text())
    assert meta["robot"] == "robot/robot.toml" and (run / "robot" / "robot.xml").is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        generated = load_robot(urdf).source.parent
    moved = tmp_path / "elsewhere" / "run"
    shutil.move(run, moved)
    shutil.rmtree(generated)  # the twin's temporary folder, cleaned
    capsys.readouterr()
    assert main(["replay", str(moved)]) == 0
    assert "Traceback" not in capsys.readouterr().err
