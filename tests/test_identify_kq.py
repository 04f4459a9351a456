"""Joint stiffness K_q: from K_R through the Jacobian, and from a run by rollouts; written into the twin."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N, fit_kr_load_cases
from twin.analysis.identify.rollouts import kq_from_run, kq_from_stiffness, write_joint_stiffness
from twin.cli import main
from twin.errors import InputError
from twin.lab.virtual import LabSettings, load_test
from twin.runs.format import Run
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec


def test_rollouts_recover_the_run_observable_joint_stiffness(clean_run: Run, twin_nominal: Twin) -> None:
    fit = kq_from_run(clean_run)
    truth = twin_nominal.joint_stiffness
    relative = np.abs(fit.k_q_nm_per_rad / truth - 1.0)
    print(f"rollout K_q relative error per joint: {relative}, 1-sigma {fit.relative_std}, {fit.evaluations} replays")
    assert list(np.flatnonzero(fit.fitted)) == [1, 2, 4]
    assert np.all(relative[[1, 2]] < 0.01)  # joints 2 and 3 carry the x-z deflection
    assert relative[4] < 0.05  # joint 5: weaker lever, sigma ~2 %
    assert np.all(relative[[0, 3, 5]] == 0.0)  # not fitted: the model's value
    assert fit.residual_rms_mm < 0.04  # at the tracker noise (0.02 mm per axis, x-z norm ~0.028)


def test_jacobian_route_recovers_joints_two_three_five_from_noise_free_load_test(twin_nominal: Twin) -> None:
    loads, deflections = load_test(  # the elastic robot: the maths of the route, without joint friction
        THESIS_TABLE_4_2_LOADS_N, seed=0, spec=TwinSpec(joint_friction_nm=np.zeros(6)),
        settings=LabSettings(tracker_noise_m=0.0),
    )
    fit = kq_from_stiffness(twin_nominal, fit_kr_load_cases(loads, deflections).k_r_n_per_m)
    truth = twin_nominal.joint_stiffness
    assert list(fit.observable) == [True, True, True, False, True, False]
    relative = np.abs(fit.k_q_nm_per_rad[[1, 2, 4]] / truth[[1, 2, 4]] - 1.0)
    print(f"Jacobian route, joints 2, 3, 5 relative error: {relative}; joint 1: {fit.k_q_nm_per_rad[0] / truth[0]:.3f}")
    assert np.all(relative < 0.03)
    # joint 1 absorbs the compliance of the unobservable joint 4 (both move the tip along y at home)
    assert fit.k_q_nm_per_rad[0] < truth[0]


def test_write_model_as_json_and_mjcf(tmp_path: Path) -> None:
    k = np.array([2.0e6, 2.1e6, 1.2e6, 4.0e5, 1.9e6, 3.0e5])
    xml = write_joint_stiffness(tmp_path / "sub" / "tx200_identified.xml", k)
    model = mujoco.MjModel.from_xml_path(str(xml))
    np.testing.assert_allclose(model.actuator_gainprm[:, 0], k)
    np.testing.assert_allclose(model.actuator_biasprm[:, 1], -k)
    payload = json.loads(write_joint_stiffness(tmp_path / "kq.json", k).read_text())
    np.testing.assert_allclose(payload["joint_stiffness_nm_per_rad"], k)
    with pytest.raises(InputError, match="6 finite values > 0"):
        write_joint_stiffness(tmp_path / "bad.json", np.array([1.0, 2.0]))


def test_identify_method2_cli_writes_a_model_that_replay_accepts(clean_run_dir: Path, tmp_path: Path) -> None:
    out, model = tmp_path / "m2.json", tmp_path / "kq_model.json"
    assert main(["identify", "--method", "2", str(clean_run_dir), "--json", str(out), "--write-model", str(model)]) == 0
    payload = json.loads(out.read_text())
    assert payload["joint_relative_std"][0] is None  # strict JSON: NaN written as null
    assert main(["replay", str(clean_run_dir), "--model", str(model), "--json", str(tmp_path / "r.json")]) == 0
    assert json.loads((tmp_path / "r.json").read_text())["position_rms_mm"] < 0.05
