"""The tool's sliding friction on the sheet: the tangential force follows the tool's real travel."""

from __future__ import annotations

import numpy as np
import pytest

from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe.load import default_force_history
from twin.process.force.table import SheetForceField
from twin.process.force.tool_friction import REVERSAL_M, SlidingFriction
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec


@pytest.fixture(scope="module")
def field() -> SheetForceField:
    return SheetForceField(default_force_history())


def test_tangential_force_reverses_over_the_reversal_travel_of_the_tip(field):
    wrapped = SlidingFriction(field)
    wrapped.reset()
    p = np.array([0.02, 0.0, -0.5e-3])
    plain = field.force(p, 1, 1)
    assert wrapped.force(p, 1, 1) == pytest.approx(plain)  # the first sample takes the commanded direction
    wrapped.advance(p, 1)
    # the program reverses but the tip has not moved: the force is still that of +x travel
    assert wrapped.force(p, 1, -1)[0] == pytest.approx(plain[0])
    # a quarter of the reversal travel back: the slip state went from +1 to 0
    back = p - np.array([REVERSAL_M / 2.0, 0.0, 0.0])
    assert abs(wrapped.force(back, 1, -1)[0]) < 0.02 * abs(plain[0])
    far = p - np.array([2.0 * REVERSAL_M, 0.0, 0.0])
    assert wrapped.force(far, 1, -1)[0] == pytest.approx(field.force(far, 1, -1)[0])


def test_stiffness_matches_finite_differences_inside_the_slip_band(field):
    wrapped = SlidingFriction(field)
    wrapped.reset()
    p0 = np.array([0.01, 0.0, -0.4e-3])
    wrapped.force(p0, 1, 1)
    wrapped.advance(p0, 1)
    p = p0 - np.array([0.3 * REVERSAL_M, 0.0, 0.0])  # in the band: s = 1 - 0.6
    _, k = wrapped.force_and_stiffness(p, 1, -1)
    step = 1e-8
    fd = np.zeros((3, 3))
    for j in (0, 2):
        e = np.zeros(3)
        e[j] = step
        fd[:, j] = (wrapped.force(p + e, 1, -1) - wrapped.force(p - e, 1, -1)) / (2 * step)
    np.testing.assert_allclose(k, fd, rtol=1e-5, atol=1.0)
    fx_plus = field.force(p, 1, 1)[0]
    # a restoring stiffness along x while sticking: 2 Fx(+1) / w on top of the field's own
    slip = 1.0 - 0.6
    assert k[0, 0] == pytest.approx(2.0 * fx_plus / REVERSAL_M + slip * field.stiffness(p, 1, 1)[0, 0], rel=1e-9)
    assert abs(k[0, 0]) > 1e6


def test_reversal_travel_must_be_positive(field):
    with pytest.raises(InputError, match="reversal_m"):
        SlidingFriction(field, 0.0)


def test_twin_tip_holds_at_a_reversal_instead_of_being_pushed_forward():
    """At a reversal the twin's tip holds while the command travels back; the flipping law pushes it forward."""
    x = np.concatenate([np.linspace(-0.03, 0.03, 121), np.linspace(0.0295, -0.03, 120)])
    p_cmd = np.column_stack([x, np.zeros_like(x), np.full_like(x, -1.5e-3)])
    t_s = np.arange(len(x)) * 0.015
    sticky = Twin(TwinSpec()).simulate(t_s, p_cmd)
    flipping = TwinSpec(process=Process(friction_reversal_m=None)).build().simulate(t_s, p_cmd)
    k = 121  # the first sample after the reversal: the command moved back 0.5 mm
    back_sticky = sticky.p_sheet_m[k - 1, 0] - sticky.p_sheet_m[k, 0]
    assert 0.0 < back_sticky < 0.1e-3  # measured 0.04 mm: held by the sheet's friction
    assert flipping.p_sheet_m[k, 0] - flipping.p_sheet_m[k - 1, 0] > 0.01e-3  # measured +0.03 mm: forward
    # the force reverses only partly while the tool sticks
    assert 0.0 < sticky.f_sheet_n[k, 0] < sticky.f_sheet_n[k + 1, 0]
    # away from the reversal the two are the same model
    np.testing.assert_allclose(sticky.p_sheet_m[40:100], flipping.p_sheet_m[40:100], atol=1e-9)
