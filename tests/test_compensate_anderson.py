"""The twin compensation in few simulations: Anderson acceleration (twin/analysis/anderson.py) on a linear map
written here, and on a cone on the ISF model, where the plain iteration needs more simulations to the tolerance."""

from __future__ import annotations

import numpy as np
import pytest

import twin.analysis.compensate as compensate
from twin.analysis.anderson import Anderson
from twin.analysis.compensate import TWIN_TOL_M, compensate_twin
from twin.errors import CompensationError, InputError
from twin.process.description import Process
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.spec import TwinSpec


def _iterations_to(tolerance: float, memory: int) -> int:
    """Iterations of x <- x + (b - A x) on a coupled linear system (a chain, each unknown pulled by the one
    before it, as a level's command moves the next level's tip) until |b - A x| < tolerance."""
    n = 40
    a = np.eye(n) * 1.6 - np.eye(n, k=-1) * 0.55  # contraction of the plain step: |I - A| ~ 0.6 + 0.55
    b = np.linspace(1.0, 2.0, n)
    x, accelerate = np.zeros(n), Anderson(memory)
    for k in range(1, 200):
        f = b - a @ x
        if np.linalg.norm(f) < tolerance:
            return k
        x = accelerate.next(x, f)
    return 200


def test_anderson_solves_a_coupled_linear_fixed_point_in_far_fewer_iterations() -> None:
    plain, mixed = _iterations_to(1e-10, 0), _iterations_to(1e-10, 5)
    assert mixed < plain / 2, (plain, mixed)


def test_anderson_refuses_a_negative_memory() -> None:
    with pytest.raises(InputError, match="memory = -1"):
        Anderson(-1)


@pytest.fixture(scope="module")
def cone_and_twin():
    cone = part_path(PartSpec(depth_m=5e-3, top_half_width_m=20e-3))  # Ø 40 mm, 45°, 10 levels of 0.5 mm
    return cone, TwinSpec(process=Process(force_model="isf")).build()


def test_cone_compensation_reaches_the_tolerance_in_four_simulations(cone_and_twin) -> None:
    cone, twin = cone_and_twin
    comp = compensate_twin(cone.t_s, cone.p_sheet_m, twin)
    assert comp.converged and comp.iterations <= 4, comp.history_m
    assert comp.predicted_residual_m is not None
    rms = float(np.sqrt(np.mean(np.sum(comp.predicted_residual_m**2, axis=1))))
    assert rms <= TWIN_TOL_M and rms == pytest.approx(comp.history_m[-1])
    # the command does what the prediction says: the twin driven by it stays within the tolerance (rms)
    sim = twin.simulate(cone.t_s, comp.p_cmd_sheet_m)
    assert float(np.sqrt(np.mean(np.sum((sim.p_sheet_m - cone.p_sheet_m) ** 2, axis=1)))) <= TWIN_TOL_M


def test_the_plain_iteration_does_not_reach_it_in_four(cone_and_twin) -> None:
    """Out of iterations still falling, under the tracker's noise (twice the tolerance): the best command, said not
    converged; in three, above it: an error."""
    cone, twin = cone_and_twin
    comp = compensate_twin(cone.t_s, cone.p_sheet_m, twin, max_iter=4, memory=0)
    assert not comp.converged and TWIN_TOL_M < min(comp.history_m) <= compensate.NOISE_TOL_RATIO * TWIN_TOL_M
    assert comp.history_m[-1] == min(comp.history_m), comp.history_m  # still falling
    with pytest.raises(CompensationError, match=r"did not reach 0\.01 mm rms in 3 iterations"):
        compensate_twin(cone.t_s, cone.p_sheet_m, twin, max_iter=3, memory=0)


def test_an_iteration_that_runs_away_is_refused_in_millimetres(cone_and_twin, monkeypatch) -> None:
    """A step the wrong way (written here: the residual added to the command, not taken off) grows the residual; the
    error gives each iteration's rms in mm and the lowest it reached, not a list of metres."""
    monkeypatch.setattr(compensate, "trust_region_step", lambda gain, residual: -residual)
    cone, twin = cone_and_twin
    with pytest.raises(CompensationError, match=r"diverges: its rms residual after each iteration \[[\d., ]+\] mm "
                                                r"rose from its lowest, \d+\.\d{3} mm"):
        compensate_twin(cone.t_s, cone.p_sheet_m, twin, memory=0)
