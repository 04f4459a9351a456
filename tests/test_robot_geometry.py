"""A robot file chooses its geometry: the TX200's thesis DH table (the default) or the public community
description's, on the same MJCF (`[dh] geometry = true`, `twin.robot.model.dh_geometry`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

from twin.errors import ModelError
from twin.robot.description import load_robot
from twin.robot.dh import dh_transforms
from twin.robot.kinematics import Kinematics
from twin.robot.model import build_model

MODELS = Path(__file__).resolve().parents[1] / "models"
# the community description's dimensions (ROS-Industrial staubli_experimental, staubli_tx200_support/urdf/
# tx200_macro.xacro; its forks disagree: burtasun's 69824305 has a1 0.25 m, jediofgever's c6e56fa6 d1 0.642 m and
# d6 0.194 m; models/README.md): a1 0.25 m, d1 0.642 m, d6 0.194 m, a2 and d4 as the thesis's Table 3.3
COMMUNITY = {"d_m": [0.642, 0.0, 0.0, 0.8, 0.0, 0.194], "a_m": [0.25, 0.95, 0.0, 0.0, 0.0, 0.0]}


def _robot_file(tmp_path: Path, geometry: object = "true", name: str = "tx200-community") -> Path:
    text = (MODELS / "tx200.toml").read_text()
    text = text.replace('name = "tx200"', f'name = "{name}"')
    text = text.replace('mjcf = "tx200.xml"', f'mjcf = "{MODELS / "tx200.xml"}"')
    text = text.replace('scene = "cell/scene.xml"', f'scene = "{MODELS / "cell" / "scene.xml"}"')
    text = text.replace('source = "thesis Table 3.3"', f'source = "community description"\ngeometry = {geometry}')
    text = re.sub(r"d_m = \[[^\]]*\]", f"d_m = {COMMUNITY['d_m']}", text, count=1)
    text = re.sub(r"a_m = \[[^\]]*\]", f"a_m = {COMMUNITY['a_m']}", text, count=1)
    path = tmp_path / "robot.toml"
    path.write_text(text)
    return path


def _reach_m(flange_of_q) -> float:
    """The flange's largest distance from axis 1 over joints 2, 3 and 5 [m]."""
    def minus_reach(x: np.ndarray) -> float:
        p = flange_of_q(np.array([0.0, x[0], x[1], 0.0, x[2], 0.0]))
        return -float(np.hypot(p[0], p[1]))
    best = min((minimize(minus_reach, x0, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-12})
                for x0 in ([1.6, 1.6, 0.0], [1.4, 1.7, 0.1])), key=lambda r: r.fun)
    return -float(best.fun)


def test_the_community_table_moves_the_mjcf_and_gives_the_datasheet_reach(tmp_path: Path) -> None:
    thesis, community = load_robot("tx200"), load_robot(_robot_file(tmp_path))
    assert community.dh is not None and community.dh.geometry and not thesis.dh.geometry  # type: ignore[union-attr]
    kin = Kinematics(robot=community)
    flange = kin.model.site(community.flange_site).id
    rng = np.random.default_rng(7)
    for q in rng.uniform(-1.5, 1.5, size=(50, 6)):
        kin._set(q)
        p_dh = dh_transforms(q, dh=community.dh)[-2, :3, 3]
        np.testing.assert_allclose(kin.data.site_xpos[flange], p_dh, atol=1e-12)  # MuJoCo FK = the table's
    # the thesis's table reaches 2.200 m (its Table 3.3), the community's the datasheet's 2194 mm (thesis Table 3.1)
    assert _reach_m(lambda q: dh_transforms(q, dh=thesis.dh)[-2, :3, 3]) == pytest.approx(2.200, abs=2e-4)
    assert _reach_m(lambda q: dh_transforms(q, dh=community.dh)[-2, :3, 3]) == pytest.approx(2.194, abs=2e-4)
    # the tool hangs at the moved flange: the tip is still 274.94 mm along it
    assert community.tool_length_m == pytest.approx(thesis.tool_length_m, abs=1e-9)


def test_the_twin_of_a_community_tx200_differs_at_the_flange_by_about_a_centimetre(tmp_path: Path) -> None:
    community = load_robot(_robot_file(tmp_path))
    q = np.array(community.q_home_rad)
    moved, default = build_model(community, scene=False), build_model("tx200", scene=False)
    import mujoco

    tips = []
    for model in (moved, default):
        data = mujoco.MjData(model)
        data.qpos[:6] = q
        mujoco.mj_kinematics(model, data)
        tips.append(data.site("tcp").xpos.copy())
    gap_mm = 1e3 * np.linalg.norm(tips[0] - tips[1])
    assert 8.0 < gap_mm < 14.0  # a1 -10 mm, d1 +2 mm, d6 +4 mm, at home


def test_a_geometry_that_is_not_a_boolean_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match=r"\[dh\] geometry = 'yes'"):
        load_robot(_robot_file(tmp_path, geometry='"yes"'))
