"""`TwinSpec`: one frozen, validated description of the cell that builds the twin, and its model file."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from twin.errors import DataFileError, InputError, ModelError
from twin.process.description import Process
from twin.process.fe.load import load_force_history
from twin.process.toolpath.groove import groove_path
from twin.process.toolpath.placement import Placement
from twin.robot.description import load_robot
from twin.sim.effects import Effects
from twin.sim.model_file import MODEL_FORMAT, read_model_file, write_model_file
from twin.sim.spec import TwinSpec


def test_the_default_spec_is_the_thesis_cell() -> None:
    spec = TwinSpec()
    assert spec.robot.name == "tx200" and spec.process.force_model == "table"
    assert spec.process.material == "AA5086-H111" and spec.process.thickness_m == 1e-3
    assert spec.placement.is_default and spec.effects == Effects()
    assert spec.joint_stiffness is None and spec.joint_friction is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.effects = Effects({"force_scale": 2.0})  # type: ignore[misc]


def test_a_spec_names_its_robot_by_name_or_path_and_refuses_an_unknown_one() -> None:
    robot = load_robot()
    assert TwinSpec(robot="tx200").robot is robot  # type: ignore[arg-type]
    assert TwinSpec(robot=robot.source).robot == robot  # type: ignore[arg-type]
    with pytest.raises(ModelError, match=r"unknown robot 'kr9000'; shipped robots: \['irb6640', 'kr210', 'tx200'\]"):
        TwinSpec(robot="kr9000")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"joint_stiffness_nm_per_rad": (1e6,) * 5}, r"joint stiffness must be 6 finite values > 0 \[N·m/rad\], one per "
         r"joint of tx200 \(joint1, joint2, joint3, joint4, joint5, joint6\)"),
        ({"joint_friction_nm": (0.0, -1.0, 0.0, 0.0, 0.0, 0.0)}, r"joint friction must be 6 finite values >= 0"),
        ({"process": Process(force_model="fem")}, r"unknown force model 'fem'; registered: \['isf', 'learned', 'table'\]"),
        ({"effects": {"force_scale": 2.0}}, r"TwinSpec.effects = .*expected a Effects"),
    ],
)
def test_a_bad_spec_names_the_value_and_what_was_valid(changes: dict[str, object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        TwinSpec().replace(**changes)


def test_process_values_are_checked() -> None:
    with pytest.raises(InputError, match=r"Process.thickness_m = -0.001: expected a finite number > 0"):
        Process(thickness_m=-1e-3)
    with pytest.raises(InputError, match=r"Process.friction_reversal_m = 0.0"):
        Process(friction_reversal_m=0.0)


def test_the_model_file_saves_the_spec_and_reads_it_back(tmp_path: Path) -> None:
    history_file = tmp_path / "history.csv"
    history_file.write_text(
        "x_mm,z_mm,s_mm,fx_half_n,fz_half_n\n0,0,0,10,100\n10,-1,10.05,12,150\n20,-2,20.1,14,200\n"
    )
    spec = TwinSpec(
        process=Process(history=load_force_history(history_file, symmetry="half"), friction_reversal_m=None),
        placement=Placement(origin_base_m=(1.5, -0.05, 0.4), yaw_rad=math.radians(30.0)),
        effects=Effects({"force_scale": 1.7, "lost_motion": 0.12, "tracker_drift": 0.003}, 0.003),
        joint_stiffness_nm_per_rad=(2.2e6, 1.9e6, 1.2e6, 5e5, 2.4e5, 5e5),
        joint_friction_nm=(0.0, 9.0, 280.0, 0.0, 76.0, 0.0),
    )
    path = write_model_file(tmp_path / "model.json", spec, note="a test")
    payload = json.loads(path.read_text())
    assert payload["format"] == MODEL_FORMAT and payload["robot"] == "tx200"
    assert payload["process"]["history"] == {"file": str(history_file), "symmetry": "half", "unchecked_symmetry": False}
    back = read_model_file(path)
    assert back.robot == spec.robot and back.placement == spec.placement and back.effects == spec.effects
    assert back.joint_stiffness_nm_per_rad == spec.joint_stiffness_nm_per_rad
    assert back.joint_friction_nm == spec.joint_friction_nm
    assert dataclasses.replace(back.process, history=None) == dataclasses.replace(spec.process, history=None)
    assert back.process.history is not None
    np.testing.assert_array_equal(back.process.history.f_sheet_n, spec.process.history.f_sheet_n)  # type: ignore[union-attr]


def test_a_twin_built_from_a_read_model_file_simulates_the_same(tmp_path: Path) -> None:
    spec = TwinSpec(effects=Effects({"force_scale": 1.3, "lost_motion": 0.1}),
                    joint_stiffness_nm_per_rad=(2.0e6, 1.8e6, 1.1e6, 5e5, 2.5e5, 5e5))
    back = read_model_file(write_model_file(tmp_path / "m.json", spec))
    path = groove_path()
    keep = path.pass_index <= 2
    a = spec.build().simulate(path.t_s[keep], path.p_sheet_m[keep])
    b = back.build().simulate(path.t_s[keep], path.p_sheet_m[keep])
    np.testing.assert_array_equal(a.p_sheet_m, b.p_sheet_m)
    np.testing.assert_array_equal(a.f_sheet_n, b.f_sheet_n)


def test_a_model_file_is_never_written_into_its_input(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    with pytest.raises(InputError, match="refusing to write the model file"):
        write_model_file(run / "model.json", TwinSpec(), protect=[run])


def test_a_model_file_with_a_bad_entry_names_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": MODEL_FORMAT, "effects": {"lost_motion": 50.0}}))
    with pytest.raises(DataFileError, match=r"bad.json: bad model: effect lost_motion = 50.0, expected within"):
        read_model_file(bad)
    bad.write_text(json.dumps({"format": "tx200-twin-model/9"}))
    with pytest.raises(DataFileError, match=r"format is 'tx200-twin-model/9', expected one of"):
        read_model_file(bad)
