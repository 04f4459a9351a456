"""The shipped models and data are found from the package, whatever the working directory."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from twin.base.resources import data_file, models_dir, robot_xml, scene_xml
from twin.errors import ModelError


def test_models_and_data_are_found_from_any_working_directory(tmp_path: Path) -> None:
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        assert robot_xml().is_file() and robot_xml().parent == models_dir()
        assert scene_xml().is_file() and scene_xml().parent.name == "cell"
        assert data_file("fe_force_history.csv").is_file()
    finally:
        os.chdir(cwd)


def test_missing_data_file_raises_model_error_naming_it() -> None:
    with pytest.raises(ModelError, match=r"no_such\.csv"):
        data_file("no_such.csv")
