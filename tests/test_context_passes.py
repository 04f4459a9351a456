"""The linearised replay (`Context`): its sheet answers against the pass that formed the same place (`below`), and
its part profile moves where the twin's own profile is formed (`profile_change`).

`label_passes` splits a path at the reversals of x: a groove's strokes, but a cone's or a pyramid's half laps. The
surface a cone's sample meets was left a lap before (two passes back, on the same side), not by the half lap on
the other side of the part that shares its x. Paths are written here.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from twin.analysis.discrepancy.context import SAME_PLACE_M, Context
from twin.process.toolpath.groove import label_passes


def _below(p_cmd_sheet_m: np.ndarray) -> np.ndarray:
    passes, _ = label_passes(p_cmd_sheet_m[:, 0], deadband_m=0.002)
    fake = SimpleNamespace(sim=SimpleNamespace(pass_index=passes, p_cmd_sheet_m=p_cmd_sheet_m))
    return np.asarray(Context.below.func(fake))  # type: ignore[attr-defined]


def test_a_cone_meets_the_lap_before_on_the_same_side() -> None:
    turns = np.linspace(0.0, 6.0, 6 * 400, endpoint=False)  # six laps, 0.5 mm down and 0.3 mm in each
    radius = 0.03 - 3e-4 * turns
    p = np.column_stack([radius * np.cos(2 * np.pi * turns), radius * np.sin(2 * np.pi * turns), -5e-4 * turns])
    below = _below(p)
    later = turns >= 1.05
    assert np.all(below[turns < 0.95] == -1)  # the first lap meets the flat sheet
    assert np.all(below[later] >= 0)
    gap = np.linalg.norm(p[later, :2] - p[below[later], :2], axis=1)
    assert np.max(gap) < 1e-3  # the lap before, a step-over away, not the other side of the cone (~50 mm)
    lap_before = turns[below[later]]
    assert np.all(np.abs(turns[later] - lap_before - 1.0) < 0.05)


def test_a_groove_meets_the_stroke_before() -> None:
    x = np.concatenate([np.linspace(-0.05, 0.05, 300), np.linspace(0.05, -0.05, 300), np.linspace(-0.05, 0.05, 300)])
    p = np.column_stack([x, np.zeros_like(x), -1e-3 * np.repeat([1.0, 2.0, 3.0], 300)])
    below = _below(p)
    assert np.all(below[:290] == -1)
    inner = np.r_[310:590, 610:890]
    assert np.all(np.abs(x[below[inner]] - x[inner]) < 5e-4)
    assert np.all(below[610:890] >= 300) and np.all(below[610:890] < 600)  # the stroke just before


def test_passes_apart_do_not_meet() -> None:
    x = np.concatenate([np.linspace(-0.05, 0.05, 300), np.linspace(0.05, -0.05, 300)])
    y = np.r_[np.zeros(300), np.full(300, 3 * SAME_PLACE_M)]  # the second stroke on another line
    below = _below(np.column_stack([x, y, np.zeros_like(x)]))
    assert np.all(below == -1)


def test_the_profile_moves_only_where_the_twins_own_profile_is_formed() -> None:
    """`predict_part_profile` clamps the recovered sheet at its plane: where the twin's profile is there (a cone's
    section, all recovered), a tip change does not move it; elsewhere it moves by the tip's z change, scaled as the
    twin scales its profile (its depth ratio, the springback effect)."""
    x = np.linspace(-0.05, 0.05, 201)
    sim = SimpleNamespace(pass_index=np.ones(201, dtype=int), p_sheet_m=np.column_stack([x, 0 * x, 0 * x]))
    profile_x = np.linspace(-0.04, 0.04, 81)
    formed = np.where(profile_x < 0.0, -1e-3, 0.0)  # formed on the left half only
    twin = SimpleNamespace(sheet_field=SimpleNamespace(params=SimpleNamespace(depth_ratio=0.9)))
    fake = SimpleNamespace(sim=sim, profile_x_m=profile_x, pred={"profile": formed}, twin=twin,
                           effects=SimpleNamespace(springback_ratio=0.1))
    dp = np.column_stack([0 * x, 0 * x, np.full(201, -2e-4)])
    change = Context.profile_change(fake, dp)  # type: ignore[arg-type]
    np.testing.assert_allclose(change[profile_x < 0.0], -2e-4 * 0.9 * 0.9, rtol=1e-12)
    assert np.all(change[profile_x >= 0.0] == 0.0)
