"""The servo's transient compliance (`twin.sim.servo`): a force step's deflection decays over the loop's time
constant; the twin adds it to its tool tip; the model file keeps it."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import InputError
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.servo import ServoTransient
from twin.sim.spec import TwinSpec


def test_a_force_step_gives_way_then_recovers_over_the_time_constant() -> None:
    t = np.arange(0.0, 1.0, 1e-3)
    f = np.zeros((len(t), 3))
    f[t >= 0.2, 2] = 1000.0
    J = np.zeros((len(t), 3, 2))
    J[:, 2, 0] = 1.0  # joint 1 moves the tip along z by 1 m/rad
    servo = ServoTransient((2e-7, 5e-7), 0.05)
    dz = servo.deflection_m(t, f, J)[:, 2]
    step = np.searchsorted(t, 0.2)
    assert dz[step + 1] == pytest.approx(2e-7 * 1000.0, rel=0.05)  # just after the step: c_s·ΔF
    assert dz[step + 50] == pytest.approx(2e-7 * 1000.0 * np.exp(-1.0), rel=0.05)  # one τ later: 1/e of it
    assert abs(dz[-1]) < 1e-9 and np.all(dz[:step] == 0.0)


def test_the_twin_adds_it_and_the_model_file_keeps_it(tmp_path) -> None:
    path = groove_path(GrooveSpec(passes=2, depth_m=0.002, bottom_length_m=0.068))
    servo = ServoTransient((0.0, -3e-7, -5e-7, 0.0, 2e-6, 0.0), 0.05)
    plain = TwinSpec().build().simulate(path.t_s, path.p_sheet_m)
    spec = TwinSpec(servo=servo)
    with_servo = spec.build().simulate(path.t_s, path.p_sheet_m)
    moved = np.linalg.norm(with_servo.p_sheet_m - plain.p_sheet_m, axis=1)
    reversal = int(np.flatnonzero(np.diff(plain.pass_index))[0])
    assert moved[reversal + 1] > 3 * np.median(moved)  # at the reversal the force steps: the transient shows
    np.testing.assert_array_equal(with_servo.f_sheet_n, plain.f_sheet_n)  # the sheet does not see it
    back = read_model_file(write_model_file(tmp_path / "m.json", spec))
    assert back.servo == servo


def test_a_bad_servo_is_refused() -> None:
    with pytest.raises(InputError, match="time_constant_s"):
        ServoTransient((1e-7,) * 6, 0.0)
    with pytest.raises(InputError, match="servo"):
        TwinSpec(servo=ServoTransient((1e-7,) * 3, 0.05))
