"""The clamping frame that gives (`twin.sim.giving_frame`): a spring in series with the sheet, in Python and in the
compiled loop (`tests/test_compiled_replay.py` holds the two equal), carried by a model file and found by
`discrepancy` (`tests/test_plant_changes.py`, on the plant with a frame of the test's own)."""

from __future__ import annotations

import numpy as np
import pytest

from twin.process.force.base import ForceField
from twin.process.toolpath.groove import groove_path
from twin.sim.effects import Effects
from twin.sim.giving_frame import GivingFrame, with_frame
from twin.sim.spec import TwinSpec


class _Wedge(ForceField):
    """The test's own sheet: a flat surface at z = 0 pushing k (1 + b x) per metre pressed, and mu of that along x."""

    radius, k_unload = 7.5e-3, 1e7

    def __init__(self, k: float = 2e6, b: float = 3.0, mu: float = 0.2) -> None:
        self.k, self.b, self.mu = k, b, mu
        self.committed: list[np.ndarray] = []

    def reset(self) -> None:
        self.committed = []

    def force_and_stiffness(self, p: np.ndarray, pass_index: int, direction: int) -> tuple[np.ndarray, np.ndarray]:
        x, z = float(p[0]), float(p[2])
        if z >= 0.0:
            return np.zeros(3), np.zeros((3, 3))
        fz = -self.k * (1.0 + self.b * x) * z
        s = np.zeros((3, 3))
        s[2, 0], s[2, 2] = -self.k * self.b * z, -self.k * (1.0 + self.b * x)
        s[0] = self.mu * s[2]
        return np.array([self.mu * fz, 0.0, fz]), s

    def force(self, p: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        return self.force_and_stiffness(p, pass_index, direction)[0]

    def advance(self, p: np.ndarray, pass_index: int | None = None) -> None:
        self.committed.append(np.array(p, dtype=float))

    @property
    def x_grid_m(self) -> np.ndarray:
        return np.zeros(1)

    @property
    def formed_z_m(self) -> np.ndarray:
        return np.zeros(1)


def test_the_frame_is_a_spring_in_series_with_the_sheet() -> None:
    """A tip pressed d = 1 mm into a sheet of k = 2 kN/mm on a frame of c = 0.3 mm/kN: the force k d / (1 + k c)
    and the axial stiffness k / (1 + k c), as two springs in series."""
    k, c, d = 2e6, 0.3e-6, 1e-3
    frame = GivingFrame(_Wedge(k=k, b=0.0, mu=0.0), c)
    f, s = frame.force_and_stiffness(np.array([0.0, 0.0, -d]), 1, 1)
    assert f[2] == pytest.approx(k * d / (1.0 + k * c), rel=1e-9)
    assert s[2, 2] == pytest.approx(-k / (1.0 + k * c), rel=1e-9)


def test_the_frames_gradient_is_its_forces_and_the_sheet_is_formed_where_the_frame_let_the_tip_go() -> None:
    frame = GivingFrame(_Wedge(), 0.4e-6)
    p = np.array([0.05, 0.01, -8e-4])
    _, s = frame.force_and_stiffness(p, 1, 1)
    h = 1e-8
    numeric = np.column_stack([(frame.force(p + h * e, 1, 1) - frame.force(p - h * e, 1, 1)) / (2 * h)
                               for e in np.eye(3)])
    np.testing.assert_allclose(s, numeric, rtol=1e-5, atol=1e-3)
    f = frame.force(p, 1, 1)
    frame.advance(p, 1)
    assert frame.inner.committed[-1][2] == pytest.approx(p[2] + 0.4e-6 * f[2], abs=1e-12)


def test_no_frame_is_the_sheet_itself_and_a_bad_compliance_is_refused() -> None:
    sheet = _Wedge()
    assert with_frame(sheet, Effects()) is sheet
    assert isinstance(with_frame(sheet, Effects({"frame_compliance": 0.2})), GivingFrame)
    with pytest.raises(ValueError, match="frame compliance"):
        GivingFrame(sheet, -1.0)


def test_a_frame_that_gives_lowers_the_groove_and_its_forces_in_the_twin() -> None:
    """The twin's groove on a frame of 0.5 mm/kN: the force drops and the formed groove is shallower (the frame gave
    under the tool), while the tool tip goes deeper (the robot deflects less under the smaller force)."""
    path = groove_path()
    keep = path.pass_index <= 3
    t_s, p_cmd = path.t_s[keep], path.p_sheet_m[keep]
    bare = TwinSpec().build().simulate(t_s, p_cmd)
    framed = TwinSpec(effects=Effects({"frame_compliance": 0.5})).build().simulate(t_s, p_cmd)
    loaded = bare.f_sheet_n[:, 2] > 200.0
    assert np.median(framed.f_sheet_n[loaded, 2] / bare.f_sheet_n[loaded, 2]) < 0.98
    assert framed.formed_z_m.min() > bare.formed_z_m.min() + 1e-4
    assert np.mean(framed.p_sheet_m[loaded, 2] - bare.p_sheet_m[loaded, 2]) < 0.0


def test_the_twins_compensation_forms_the_part_not_the_tip_on_a_frame_that_gives() -> None:
    """On a frame of 0.5 mm/kN the compensated command puts the tip where the yielded sheet meets it on the ideal
    path (the part's depth), and the tip the tracker sees lies c f_z deeper."""
    from twin.analysis.compensate import compensate_twin

    path = groove_path()
    keep = path.pass_index <= 2
    t_s, p_id = path.t_s[keep], path.p_sheet_m[keep]
    twin = TwinSpec(effects=Effects({"frame_compliance": 0.5})).build()
    comp = compensate_twin(t_s, p_id, twin, tol_m=2e-5)
    sim = twin.simulate(t_s, comp.p_cmd_sheet_m)
    give = 0.5e-6 * sim.f_sheet_n[:, 2]
    loaded = sim.f_sheet_n[:, 2] > 200.0
    part = sim.p_sheet_m[:, 2] + give
    assert np.sqrt(np.mean((part[loaded] - p_id[loaded, 2]) ** 2)) < 5e-5
    assert np.mean(sim.p_sheet_m[loaded, 2] - p_id[loaded, 2]) < -1e-4
