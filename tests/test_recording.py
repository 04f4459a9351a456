"""Tests of twin.viz.recording and recording_layers: .rrd files of replays, read back with rerun's own reader."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import mujoco
import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from twin.analysis.replay import ReplayResult
from twin.errors import InputError
from twin.runs.format import Run, Stream
from twin.sim.result import SimResult
from twin.viz import recording
from twin.viz.recording_layers import POSE_RATE_HZ, decimate
from twin.viz.recording_robot import geom_mesh

COMPLIANCE_M_PER_N = np.array([[1.54, 0.19], [0.79, 1.02]]) * 1e-6  # thesis Eq. 4.27, C_R(1)


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    try:
        from twin.robot.model import build_model

        return build_model()
    except Exception as exc:  # pragma: no cover - only while the MJCF model is unfinished
        pytest.skip(f"the scene model does not load yet: {exc}")


def _synthetic(model: mujoco.MjModel, n_pass: int, rate_hz: float = 50.0) -> tuple[Run, ReplayResult]:
    """A zig-zag groove run (passes 1 mm deeper, 1 mm shorter), forces, deflection = C_R(1)·F."""
    t_list, p_list, pass_list, dir_list = [], [], [], []
    t = 0.0
    for k in range(1, n_pass + 1):
        half = 0.035 - 0.0005 * (k - 1)
        d = 1 if k % 2 else -1
        n = int(2 * half / 0.0333 * rate_hz)
        s = np.arange(n) / n
        for i in range(n):
            t_list.append(t)
            p_list.append([d * (-half + 2 * half * s[i]), 0.0, -0.001 * (k - 1 + s[i])])
            pass_list.append(k)
            dir_list.append(d)
            t += 1.0 / rate_hz
    t_s, p_cmd = np.array(t_list), np.array(p_list)
    direction = np.array(dir_list)
    depth = -p_cmd[:, 2]
    f = np.column_stack([-direction * (200 + 2e4 * depth), np.zeros_like(depth), 800 + 1.2e5 * depth])
    deflection = np.zeros_like(p_cmd)
    deflection[:, [0, 2]] = f[:, [0, 2]] @ COMPLIANCE_M_PER_N.T
    qpos = np.tile(model.key_qpos[0] if model.nkey else np.zeros(model.nq), (len(t_s), 1))
    qpos[:, 1] += 0.05 * np.sin(t_s)
    formed_x = np.linspace(-0.045, 0.045, 181)
    formed_z = -0.01 * (np.abs(formed_x) < 0.03)
    fields = dict(
        t_s=t_s,
        p_cmd_sheet_m=p_cmd,
        p_unloaded_sheet_m=p_cmd,
        p_sheet_m=p_cmd + deflection,
        f_sheet_n=f,
        qpos=qpos,
        q_ik=qpos[:, :6],
        pass_index=np.array(pass_list),
        direction=direction,
        formed_x_m=formed_x,
        formed_z_m=formed_z,
        iterations=np.full(len(t_s), 2),
        tip_gain=np.tile(np.eye(3), (len(t_s), 1, 1)),
    )
    # SimResult may gain fields the recorder does not read: pass only those it has
    names = {field.name for field in dataclasses.fields(SimResult)}
    sim = SimResult(**{k: v for k, v in fields.items() if k in names})
    t_f = t_s[::2]
    run = Run(
        directory=None,
        meta={
            "scenario": "synthetic",
            "tool_length_m": 0.27494,
            "tracker_rate_hz": rate_hz,
            "sensor_rate_hz": rate_hz / 2,
        },
        commanded=Stream(t_s, p_cmd),
        tracker=Stream(t_s, p_cmd + 1.1 * deflection),
        forces=Stream(t_f, 1.05 * f[::2]),
        part_profile=(formed_x, 0.9 * formed_z),
    )
    replay = ReplayResult(sim, p_cmd + deflection, f[::2], {"position_rms_mm": 0.1})
    return run, replay


def _chunks(path: Path) -> dict[str, list]:
    out: dict[str, list] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        out.setdefault(chunk.entity_path, []).append(chunk)
    return out


def test_record_replay_writes_robot_paths_arrows_and_plots_on_sim_time(model: mujoco.MjModel, tmp_path: Path):
    run, replay = _synthetic(model, n_pass=2)
    ideal = replay.sim.p_cmd_sheet_m
    out = recording.record_replay(tmp_path / "replay.rrd", run, replay, ideal_sheet_m=ideal, twin_model=model)
    assert out.is_file() and out.stat().st_size > 10_000
    chunks = _chunks(out)
    expected_static = [
        "/world/robot/link2/link2_visual",
        "/world/robot/tool/tool_tip_visual",
        "/world/robot/sheet/sheet",
        "/world/paths/ideal",
        "/world/paths/commanded",
        "/world/paths/measured",
        "/world/paths/simulated",
        "/README",
    ]
    expected_timed = [
        "/world/robot/link2",
        "/world/robot/tool",
        "/world/deflection_x20/simulated",
        "/world/deflection_x20/measured",
        "/world/force_1mm_per_20N/simulated",
        "/world/force_1mm_per_20N/measured",
        "/world/groove/formed_loaded",
        "/world/groove/part_profile",
        "/world/tool_tip/measured",
        "/plots/deflection_z_mm/measured",
        "/plots/deflection_z_mm/predicted",
        "/plots/force_z_n/measured",
        "/plots/force_x_n/predicted",
    ]
    for entity in expected_static:
        assert entity in chunks, f"{entity} missing; have {sorted(chunks)}"
        assert all(c.is_static for c in chunks[entity])
    for entity in expected_timed:
        assert entity in chunks, f"{entity} missing; have {sorted(chunks)}"
        assert any("sim_time" in c.timeline_names for c in chunks[entity])
    assert "/world/robot/link2/link2_collision" not in chunks  # collision geoms (group 3) are left out
    assert not any(e.startswith("/world/robot/world/") for e in chunks)  # the floor plane is not tessellated
    rows = sum(c.num_rows for c in chunks["/plots/force_z_n/measured"] if not c.is_static)
    assert rows == len(run.forces.t_s)


def test_record_replay_logs_body_poses_from_mj_kinematics_as_xyzw(model: mujoco.MjModel, tmp_path: Path):
    run, replay = _synthetic(model, n_pass=1)
    out = recording.record_replay(tmp_path / "poses.rrd", run, replay, twin_model=model)
    batches = [c.to_record_batch() for c in _chunks(out)["/world/robot/link3"] if not c.is_static]
    times = 1e-9 * np.concatenate([b.column("sim_time").cast(pa.int64()).to_numpy() for b in batches])
    trans = np.concatenate([np.array(b.column("Transform3D:translation").to_pylist())[:, 0] for b in batches])
    quat = np.concatenate([np.array(b.column("Transform3D:quaternion").to_pylist())[:, 0] for b in batches])
    t_sim = replay.sim.t_s
    keep = decimate(t_sim)
    np.testing.assert_allclose(times, t_sim[keep], atol=1e-8)  # stored in whole ns
    assert 1.0 / np.median(np.diff(times)) == pytest.approx(POSE_RATE_HZ, rel=0.25)
    data = mujoco.MjData(model)
    i = keep[len(keep) // 2]
    data.qpos[:] = replay.sim.qpos[i]
    mujoco.mj_kinematics(model, data)
    body = model.body("link3").id
    j = len(keep) // 2
    np.testing.assert_allclose(trans[j], data.xpos[body], atol=1e-6)
    w, x, y, z = data.xquat[body]
    np.testing.assert_allclose(quat[j], [x, y, z, w], atol=1e-6)


def test_record_runs_puts_each_run_under_its_prefix(model: mujoco.MjModel, tmp_path: Path):
    run, replay = _synthetic(model, n_pass=1)
    out = recording.record_runs(
        tmp_path / "two.rrd", [("nominal", run, replay), ("compensated", run, replay)], twin_model=model
    )
    chunks = _chunks(out)
    for prefix in ("nominal", "compensated"):
        assert f"/{prefix}/world/robot/link2" in chunks
        assert f"/{prefix}/plots/deflection_z_mm/measured" in chunks
    assert "/world/robot/link2" not in chunks


def test_record_replay_raises_if_qpos_does_not_match_model_and_writes_nothing(
    model: mujoco.MjModel, tmp_path: Path
):
    run, replay = _synthetic(model, n_pass=1)
    wide = np.hstack([replay.sim.qpos, np.zeros((len(replay.sim.t_s), 2))])
    bad_sim = dataclasses.replace(replay.sim, qpos=wide)
    bad = type(replay)(bad_sim, replay.tracker_pred_m, replay.forces_pred_n, replay.metrics)
    with pytest.raises(InputError, match=r"Twin\.model"):
        recording.record_replay(tmp_path / "bad.rrd", run, bad, twin_model=model)
    assert list(tmp_path.iterdir()) == []


def test_record_replay_raises_if_tracker_prediction_has_wrong_length(model: mujoco.MjModel, tmp_path: Path):
    run, replay = _synthetic(model, n_pass=1)
    bad = type(replay)(replay.sim, replay.tracker_pred_m[:-3], replay.forces_pred_n, replay.metrics)
    with pytest.raises(InputError, match="tracker_pred_m"):
        recording.record_replay(tmp_path / "bad.rrd", run, bad, twin_model=model)


def test_record_runs_raises_on_duplicate_names(model: mujoco.MjModel, tmp_path: Path):
    run, replay = _synthetic(model, n_pass=1)
    with pytest.raises(InputError, match="unique"):
        recording.record_runs(
            tmp_path / "dup.rrd", [("a", run, replay), ("a", run, replay)], twin_model=model
        )


def test_full_size_recording_is_fast_and_small(model: mujoco.MjModel, tmp_path: Path):
    run, replay = _synthetic(model, n_pass=10)
    assert len(run.tracker.t_s) > 900
    start = time.perf_counter()
    out = recording.record_replay(
        tmp_path / "full.rrd", run, replay, ideal_sheet_m=replay.sim.p_cmd_sheet_m, twin_model=model
    )
    elapsed = time.perf_counter() - start
    assert elapsed < 5.0
    assert out.stat().st_size < 5_000_000


def test_geom_mesh_places_primitives_by_geom_pose():
    xml = """<mujoco><worldbody><body name="b">
      <geom name="box" type="box" size="0.1 0.2 0.3" pos="1 0 0"/>
      <geom name="cyl" type="cylinder" size="0.05 0.2" pos="0 1 0" euler="90 0 0"/>
      <geom name="cap" type="capsule" size="0.05 0.2" pos="0 0 1"/>
      <geom name="ball" type="sphere" size="0.1" pos="0 0 -1"/>
      <geom name="floor" type="plane" size="1 1 0.1"/>
    </body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    bounds = {m.geom(g).name: geom_mesh(m, g) for g in range(m.ngeom)}
    assert bounds["floor"] is None
    np.testing.assert_allclose(bounds["box"].bounds, [[0.9, -0.2, -0.3], [1.1, 0.2, 0.3]], atol=1e-9)
    np.testing.assert_allclose(bounds["cyl"].bounds, [[-0.05, 0.8, -0.05], [0.05, 1.2, 0.05]], atol=1e-6)
    np.testing.assert_allclose(bounds["cap"].bounds, [[-0.05, -0.05, 0.75], [0.05, 0.05, 1.25]], atol=1e-6)
    np.testing.assert_allclose(bounds["ball"].bounds[:, 2], [-1.1, -0.9], atol=1e-3)


def test_decimate_keeps_first_and_last_sample_at_the_target_rate():
    t_s = np.arange(0.0, 2.0, 0.02)
    idx = decimate(t_s, 10.0)
    assert idx[0] == 0 and idx[-1] == len(t_s) - 1
    np.testing.assert_allclose(np.diff(t_s[idx[:-1]]), 0.1, atol=1e-9)
    with pytest.raises(InputError):
        decimate(t_s, 0.0)
