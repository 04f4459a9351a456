"""The shipped models and data are found from the package, whatever the working directory."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from twin.base.resources import data_file, models_dir
from twin.errors import ModelError
from twin.robot.description import load_robot


def test_models_and_data_are_found_from_any_working_directory(tmp_path: Path) -> None:
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        robot = load_robot()
        assert robot.source.is_file() and robot.source.parent == models_dir()
        assert robot.mjcf.is_file() and robot.mjcf.parent == models_dir()
        assert robot.scene is not None and robot.scene.is_file() and robot.scene.parent.name == "cell"
        assert data_file("fe_force_history.csv").is_file()
    finally:
        os.chdir(cwd)


def test_missing_data_file_raises_model_error_naming_it() -> None:
    with pytest.raises(ModelError, match=r"no_such\.csv"):
        data_file("no_such.csv")
