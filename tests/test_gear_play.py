"""A gear's play under the forming load (`Effects.gear_play_rad`, `twin.sim.gear_play`): the vocabulary, the model
file, the twin's replay on the flank each joint's torque sets, and the discrepancy family that finds it."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from twin.analysis.discrepancy.families import FAMILIES
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.sim.effects import GEAR_PLAY, Effects
from twin.sim.gear_play import joint_motion, link_torque, load_flank
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec

B_RAD = 4e-4  # 0.4 mrad of half dead band


def _play(dof: int, joint: int, value: float = B_RAD) -> tuple[float, ...]:
    play = np.zeros(dof)
    play[joint] = value
    return tuple(play)


def test_the_play_is_validated_composed_and_kept_by_the_simulated_effects() -> None:
    dof = TwinSpec().robot.dof
    assert Effects().gear_play_rad == () and Effects(gear_play_rad=(0.0,) * dof).gear_play_rad == ()
    effects = Effects({"force_scale": 1.1}, gear_play_rad=_play(dof, 2))
    assert effects.simulated().gear_play_rad == effects.gear_play_rad
    assert hash(effects) != hash(effects.with_values({"force_scale": 1.1}).composed({GEAR_PLAY: _play(dof, 2)}))
    assert effects.composed({GEAR_PLAY: _play(dof, 2)}).gear_play_rad[2] == pytest.approx(2 * B_RAD)
    assert Effects().composed({GEAR_PLAY: _play(dof, 1)}).gear_play_rad == _play(dof, 1)
    assert effects.with_value("force_scale", 1.2).gear_play_rad == effects.gear_play_rad
    assert effects.named_parameters()["gear_play"]["gear_play_mrad"][2] == pytest.approx(0.4)
    for bad, words in ((_play(dof, 2, 0.025), "arm joint 3 = 25 mrad"), ((float("nan"),), "arm joint 1 = nan mrad"),
                       (("a",), "one number per arm joint")):
        with pytest.raises(InputError, match=words):
            Effects(gear_play_rad=bad)
    with pytest.raises(InputError, match="arm joints"):
        TwinSpec(effects=Effects(gear_play_rad=(B_RAD,)))


def test_the_model_file_writes_and_reads_the_play_back(tmp_path: Path) -> None:
    dof = TwinSpec().robot.dof
    spec = TwinSpec(effects=Effects({"lost_motion": 0.1}, gear_play_rad=_play(dof, 2)))
    path = write_model_file(tmp_path / "m.json", spec)
    payload = json.loads(path.read_text())
    assert payload["gear_play_mrad"] == pytest.approx(list(_play(dof, 2, 0.4)))
    back = read_model_file(path)
    assert back.effects.gear_play_rad == pytest.approx(spec.effects.gear_play_rad, rel=1e-12, abs=0.0)
    assert back.effects.get("lost_motion") == 0.1
    assert "gear_play_mrad" not in json.loads(write_model_file(tmp_path / "n.json", TwinSpec()).read_text())
    for value, words in (([0.0, 0.0, 25.0] + [0.0] * (dof - 3), "arm joint 3 = 25 mrad"),
                         ("0.4", "gear_play_mrad = '0.4'"), ([0.4, True] + [0.0] * (dof - 2), "gear_play_mrad"),
                         ([0.4], f"has {dof} arm joints")):
        bad = tmp_path / "bad.json"
        bad.write_text(json.dumps({**payload, "gear_play_mrad": value}))
        with pytest.raises(DataFileError, match=words) as err:
            read_model_file(bad)
        assert str(bad) in str(err.value)


@pytest.fixture(scope="module")
def plain(nominal_path: tuple[np.ndarray, np.ndarray]) -> tuple[Twin, SimResult]:
    twin = TwinSpec().build()
    return twin, twin.simulate(*nominal_path)


def test_a_play_moves_the_tip_where_the_torque_flips_and_not_where_gravity_holds_the_flank(
    nominal_path: tuple[np.ndarray, np.ndarray], plain: tuple[Twin, SimResult]
) -> None:
    """Joint 3 on the groove: gravity's torque holds its flank on part of the path (the tip stays put), the forming
    force's moment flips it on the rest (the tip moves by about b x |flank| x the joint's lever, first order)."""
    twin, sim = plain
    flank = load_flank(twin, sim.t_s, sim.q_ik, sim.qpos, sim.f_sheet_n)[:, 2]
    flipped, held = np.abs(flank) > 1.5, np.abs(flank) < 0.05
    assert flipped.mean() > 0.2 and held.mean() > 0.1, (flipped.mean(), held.mean())
    played = TwinSpec(effects=Effects(gear_play_rad=_play(twin.robot.dof, 2))).build()
    moved = np.linalg.norm(played.simulate(*nominal_path).p_sheet_m - sim.p_sheet_m, axis=1)
    lever = np.linalg.norm(twin.kinematics.jacobians(sim.q_ik)[:, :3, 2], axis=1)
    expected = B_RAD * np.abs(flank) * lever
    assert np.median(moved[flipped] / expected[flipped]) == pytest.approx(1.0, abs=0.3)
    assert np.median(moved[held]) < 0.05 * np.median(moved[flipped])
    # joint 2: gravity holds its flank along the whole groove, the same play hardly shows
    other = TwinSpec(effects=Effects(gear_play_rad=_play(twin.robot.dof, 1))).build()
    assert np.median(np.linalg.norm(other.simulate(*nominal_path).p_sheet_m - sim.p_sheet_m, axis=1)) \
        < 0.05 * np.median(moved[flipped])


def test_the_python_loop_applies_the_play_as_the_compiled_one(first_pass_path: tuple[np.ndarray, np.ndarray]) -> None:
    spec = TwinSpec(effects=Effects(gear_play_rad=_play(TwinSpec().robot.dof, 0, 1e-3)))  # joint 1: no gravity
    compiled, python = spec.build(), spec.build()
    python.use_compiled_loop = False
    a, b = compiled.simulate(*first_pass_path), python.simulate(*first_pass_path)
    assert compiled.last_loop_compiled and not python.last_loop_compiled
    assert np.max(np.abs(a.p_sheet_m - TwinSpec().build().simulate(*first_pass_path).p_sheet_m)) > 1e-4
    np.testing.assert_allclose(a.p_sheet_m, b.p_sheet_m, atol=1e-7)


def test_the_family_is_carried_as_the_twins_play() -> None:
    family = FAMILIES["lost_motion_under_load"]
    dof = TwinSpec().robot.dof
    ctx = SimpleNamespace(twin=SimpleNamespace(robot=SimpleNamespace(dof=dof)))
    got = family.to_increments(np.array([0.0, 0.0, 0.4, 0.7]), ctx)  # type: ignore[arg-type]
    assert got is not None and got[GEAR_PLAY] == pytest.approx(_play(dof, 2))


def test_replay_with_a_model_file_applies_the_play(clean_run_dir: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    gaps = []
    for name, effects in (("plain", Effects()), ("play", Effects(gear_play_rad=_play(TwinSpec().robot.dof, 2)))):
        model = write_model_file(tmp_path / f"{name}.json", replace(TwinSpec(), effects=effects))
        assert main(["replay", str(clean_run_dir), "--model", str(model), "--json", "-"]) == 0
        gaps.append(json.loads(capsys.readouterr().out))
    assert gaps[0] != gaps[1], gaps


def test_the_joints_motion_is_the_sign_of_their_own_speed_held_through_stops() -> None:
    t = np.linspace(0.0, 4.0, 401)
    q = np.column_stack([np.sin(np.pi * t / 2.0), np.clip(t - 1.0, 0.0, 1.0), np.zeros_like(t)])
    moving = joint_motion(t, q)
    assert np.all(moving[(t > 0.1) & (t < 0.9), 0] == 1) and np.all(moving[(t > 1.1) & (t < 2.9), 0] == -1)
    assert np.all(moving[t < 0.99, 1] == 1) and np.all(moving[t > 2.01, 1] == 1)  # held through its stops
    assert np.all(moving[:, 2] == 1)  # a joint the path never moves: the default flank


def test_the_links_torque_adds_what_accelerates_them(plain: tuple[Twin, SimResult]) -> None:
    """Inverse dynamics of the commanded motion: a joint accelerated at rest adds M(q) q'' to gravity's torque
    (checked against MuJoCo's own mass matrix, `mj_mulM`, less the motors' armature, which acts before the gear)."""
    twin, sim = plain
    n, dof = 200, twin.robot.dof
    t = np.linspace(0.0, 2.0, n)
    q_ik = np.repeat(sim.q_ik[:1], n, axis=0)
    q_ik[:, 0] += 0.5 * 0.2 * (t - 1.0) ** 2  # joint 1 at 0.2 rad/s², at rest at t = 1 s (no Coriolis there)
    qpos = np.repeat(sim.qpos[:1], n, axis=0)
    qpos[:, twin.robot.addresses(twin.model).qpos] = q_ik
    extra = link_torque(twin, t, qpos, q_ik) - link_torque(twin, t, qpos)
    data = mujoco.MjData(twin.model)
    data.qpos[:] = qpos[n // 2]
    mujoco.mj_forward(twin.model, data)
    dofs = twin.robot.addresses(twin.model).dof
    accel, product = np.zeros(twin.model.nv), np.zeros(twin.model.nv)
    accel[dofs[0]] = 0.2
    mujoco.mj_mulM(twin.model, data, product, accel)
    expected = product[dofs] - twin.model.dof_armature[dofs] * accel[dofs]  # the motor's rotor is not the gear's
    assert expected[0] > 1.0  # joint 1 carries the arm: a torque worth checking [N·m]
    np.testing.assert_allclose(extra[n // 2, :dof], expected, rtol=0.05, atol=0.05 * abs(expected[0]))
