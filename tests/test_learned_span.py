"""The span a learned sheet was learned over (`twin.process.force.span`): read off paths written here, carried in
the model file, and named by `compensate` where an ideal path leaves it (a deeper part, a corner)."""

from __future__ import annotations

import itertools
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from twin.cli import main
from twin.errors import ExtrapolationWarning
from twin.process.description import Process
from twin.process.force.learned import WEIGHT_KEYS
from twin.process.force.registry import build_force_field
from twin.process.force.span import Span, path_span, span_of, span_warnings
from twin.process.toolpath.groove import ToolPath
from twin.runs.read import read_run
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.spec import TwinSpec

R = 0.0075  # tool radius [m]
#: The learned model's weights at its prior mean (the published formula): only the span differs between models here.
PRIOR_WEIGHTS = tuple((k, 1.0 if k == "prior_weight" else 0.0) for k in WEIGHT_KEYS)


def learned_process(depth_mm: float, turn_deg: float) -> Process:
    """A learned sheet at its prior mean, carrying the span (depth_mm, turn_deg)."""
    return Process(force_model="learned",
                   force_fit=(*PRIOR_WEIGHTS, ("span_depth_mm", depth_mm), ("span_turn_deg", turn_deg)))


def circle(radius_m: float, depth_m: float, n: int = 2000) -> np.ndarray:
    """One turn of a circle at a depth, with a plunge from the sheet's plane [m]."""
    a = np.linspace(0.0, 2.0 * math.pi, n)
    p = np.column_stack([radius_m * np.cos(a), radius_m * np.sin(a), np.full(n, -depth_m)])
    return np.vstack([[radius_m, 0.0, 0.0], p])


def square(half_m: float, depth_m: float, n_side: int = 500) -> np.ndarray:
    """A square's four sides at a depth (sharp corners) [m]."""
    corners = np.array([[half_m, -half_m], [half_m, half_m], [-half_m, half_m], [-half_m, -half_m], [half_m, -half_m]])
    xy = np.vstack([np.linspace(a, b, n_side, endpoint=False) for a, b in itertools.pairwise(corners)])
    return np.column_stack([xy, np.full(len(xy), -depth_m)])


def test_the_span_of_a_circle_and_of_a_square() -> None:
    # a circle of radius r turns by R / r rad over one tool radius of travel
    span = path_span(circle(0.025, 0.004), R)
    assert span.depth_mm == pytest.approx(4.0)
    assert span.turn_deg == pytest.approx(math.degrees(R / 0.025), rel=0.02)
    # docs/learning.md: a cone at radii of 20-30 mm turns by 14-22 deg
    assert [path_span(circle(r, 0.004), R).turn_deg for r in (0.03, 0.02)] == pytest.approx([14.3, 21.5], abs=0.5)
    # a square's sharp corners: the whole 90 deg within one tool radius, at its 99th percentile (4 corners in 2000
    # samples are 0.2 %: the turn is read over the tool radius either side of a corner, 7.5 mm of its 20 mm sides)
    assert path_span(square(0.02, 0.006), R).turn_deg == pytest.approx(90.0, abs=1.0)
    assert path_span(square(0.02, 0.006), R).depth_mm == pytest.approx(6.0)
    above = circle(0.025, 0.0)  # above the sheet: no contact, no span
    above[:, 2] = 0.001
    assert path_span(above, R) == Span(0.0, 0.0)


def test_span_warnings_name_a_deeper_part_and_a_corner_and_nothing_inside() -> None:
    learned = Span(depth_mm=9.0, turn_deg=20.0)
    assert span_warnings(learned, circle(0.025, 0.0088), R, "it") == []  # 17 deg, 8.8 mm: inside (with the margins)
    deeper = span_warnings(learned, circle(0.025, 0.010), R, "the cone")
    assert deeper == ["the cone goes 10.00 mm deep, past the 9.00 mm the learned sheet was learned to (its runs' "
                      "deepest measured tip): its force there is extrapolated"]
    corner = span_warnings(learned, square(0.02, 0.006), R, "the pyramid")
    assert len(corner) == 1 and corner[0].startswith("the pyramid turns by up to 90 deg over one tool radius, past the "
                                                     "20 deg")
    assert span_warnings(None, square(0.02, 0.006), R, "x") == []  # a model without a span: nothing to say


def test_the_span_travels_in_the_model_file_and_leaves_the_force_alone(tmp_path: Path) -> None:
    back = read_model_file(write_model_file(tmp_path / "m.json", TwinSpec(process=learned_process(9.0, 20.0)),
                                            note="test"))
    assert span_of(dict(back.process.force_fit)) == Span(9.0, 20.0)
    assert span_of(dict(PRIOR_WEIGHTS)) is None
    p = circle(0.025, 0.004)
    t = np.arange(len(p)) * 0.01
    path = ToolPath(t_s=t, p_sheet_m=p, pass_index=np.ones(len(p), dtype=int), direction=np.ones(len(p), dtype=int))
    plain = Process(force_model="learned", force_fit=PRIOR_WEIGHTS)
    np.testing.assert_array_equal(build_force_field(back.process).rigid_forces(path),
                                  build_force_field(plain).rigid_forces(path))


def test_compensate_names_a_corner_the_learned_sheet_never_saw(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    model = write_model_file(tmp_path / "m.json", TwinSpec(process=learned_process(9.0, 20.0)), note="test")
    assert main(["path", "--shape", "pyramid", "--top-width-mm", "30", "--depth-mm", "1", "--out",
                 str(tmp_path / "pyramid.csv")]) == 0
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("error", ExtrapolationWarning)  # the CLI prints it; it must not raise out of main
        code = main(["compensate", "--method", "twin", "--model", str(model), "--ideal", str(tmp_path / "pyramid.csv"),
                     "--out", str(tmp_path / "cmd.csv")])
    assert code == 0
    err = capsys.readouterr().err
    assert f"the ideal path {tmp_path / 'pyramid.csv'} turns by up to 90 deg over one tool radius, past the 20 deg" in err


def test_replay_names_a_run_deeper_than_the_learned_sheet_went(lab_cone_run: Path, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    """A replay reads the depth its run's tip reached (the tracker), not its command's (a nominal run's tip lags:
    replayed on the sheet learned from it, it stays inside)."""
    run = read_run(lab_cone_run)
    reached, command = path_span(run.tracker.values, R), run.commanded.values
    assert 1.0 < reached.depth_mm < 1.5  # the tip lagged the command
    # learned 0.2 mm above the tip's deepest: inside its margin for the tip, outside it for the command
    inside = Span(reached.depth_mm - 0.2, 90.0)
    assert span_warnings(inside, command, R, "the command")  # read off the command, this span would be left
    for depth_mm, named in ((inside.depth_mm, False), (0.5, True)):
        model = write_model_file(tmp_path / "m.json", TwinSpec(process=learned_process(depth_mm, 90.0)), note="test")
        capsys.readouterr()
        assert main(["replay", str(lab_cone_run), "--model", str(model)]) == 0
        err = capsys.readouterr().err
        assert (f"the run {lab_cone_run} goes {reached.depth_mm:.2f} mm deep, past the" in err) == named, err
