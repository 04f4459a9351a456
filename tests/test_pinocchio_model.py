"""Pinocchio built from the same MJCF agrees with MuJoCo on the tool tip and its Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import InputError, ModelError
from twin.robot.kinematics import Kinematics
from twin.robot.model import load_model
from twin.robot.pinocchio_model import PinKinematics


@pytest.fixture(scope="module")
def pair() -> tuple[PinKinematics, Kinematics]:
    return PinKinematics(), Kinematics(load_model(scene=False))


@pytest.fixture(scope="module")
def q_random(pair: tuple[PinKinematics, Kinematics]) -> np.ndarray:
    kin = pair[1]
    return np.random.default_rng(99).uniform(kin.q_min, kin.q_max, size=(1000, 6))


def test_tcp_pose_and_jacobian_agree_with_mujoco(pair: tuple[PinKinematics, Kinematics], q_random) -> None:
    pk, mk = pair
    err_p = err_R = err_J = 0.0
    for q in q_random:
        p_pin, R_pin = pk.fk(q)
        p_mj, R_mj = mk.fk(q)
        err_p = max(err_p, float(np.max(np.abs(p_pin - p_mj))))
        err_R = max(err_R, float(np.max(np.abs(R_pin - R_mj))))
        err_J = max(err_J, float(np.max(np.abs(pk.jacobian(q) - mk.jacobian(q)))))
    assert err_p < 1e-9
    assert err_R < 1e-9
    assert err_J < 1e-9


def test_sites_pin_places_correctly_agree_with_mujoco(
    pair: tuple[PinKinematics, Kinematics], q_random
) -> None:
    # attachment_site sits directly on link6 and is not affected by the pin 4.1.0 nested-site bug
    pk, mk = pair
    for q in q_random[:50]:
        mk.fk(q)
        np.testing.assert_allclose(
            pk.site_position(q, "attachment_site"), mk.data.site("attachment_site").xpos, atol=1e-9
        )


def test_bad_inputs(tmp_path) -> None:
    with pytest.raises(ModelError, match="not found"):
        PinKinematics(tmp_path / "missing.xml")
    with pytest.raises(InputError, match="6 finite"):
        PinKinematics().fk(np.zeros(5))
