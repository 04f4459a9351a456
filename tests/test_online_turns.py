"""At a turn of the planned travel (a pyramid's corner, a groove's reversal) the sheet's friction turns with the tool
at once, and the filtered force shows it only later: the online compensator turns it ahead (`OnlineSettings.
feed_turns`, `twin.sim.compiled.online._turned_force`). Written against the twin's own kinematics, with a
measured force that shows the turn a fixed number of cycles late (a sensor's sample, latency and filter)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.errors import InputError
from twin.robot.kinematics import Kinematics
from twin.sim.compiled.online import TURN_SETTLE_S, WALL_BUILD_M
from twin.sim.online import AssumedForces, OnlineCompensator, OnlineSettings
from twin.sim.spec import TwinSpec

CYCLE_S = 0.004
LEG = 150  # cycles per leg
STEP_M = 1.2e-4  # 30 mm/s in a 4 ms cycle
LATE = 20  # cycles the measured force shows the turn late (80 ms)
FZ_N, MU = 1500.0, 0.15


def _joints(tips_m: np.ndarray | list[np.ndarray]) -> tuple[TwinSpec, np.ndarray]:
    """The twin and the planned joints (its IK from home) of tool tips given from its home tip, sheet frame [m]."""
    spec = TwinSpec()
    twin = spec.build()
    kin = Kinematics(robot=twin.robot)
    q0 = np.asarray(twin.robot.q_home_rad, dtype=float)
    return spec, kin.ik_path(np.array([kin.fk(q0)[0] + twin.R_base_sheet @ x for x in tips_m]), q0)


def _path(turn_deg: float, accel_mps2: float = 0.0) -> tuple[TwinSpec, np.ndarray, np.ndarray, np.ndarray]:
    """The twin, the planned joints of two straight legs that meet at a turn of `turn_deg` (the twin's IK), and the
    legs' directions in the sheet frame; the second leg at `STEP_M` a cycle, or out of a stop at `accel_mps2`."""
    d1 = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    a = 0.5 + math.radians(turn_deg)
    d2 = np.array([math.cos(a), math.sin(a), 0.0])
    tips = [STEP_M * k * d1 for k in range(LEG)]
    out = [STEP_M * k if accel_mps2 == 0.0 else min(0.5 * accel_mps2 * (CYCLE_S * k) ** 2, STEP_M * k)
           for k in range(1, LEG + 1)]
    tips += [tips[-1] + x * d2 for x in out]
    return (*_joints(tips), d1, d2)


def _run(spec: TwinSpec, Q: np.ndarray, forces: np.ndarray, feed_turns: bool, planned: bool = True) -> np.ndarray:
    """The correction after each cycle [m], shape (n, 3), the sensor sampled every cycle; the joints given as the
    planned ones too, or (`planned` False) as the measured ones only."""
    comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0, feed_turns=feed_turns))
    out = np.empty((len(Q), 3))
    for k, q in enumerate(Q):
        comp.step(CYCLE_S * k, CYCLE_S * k, forces[k], q, q if planned else None)
        out[k] = comp.correction_m
    return out


def _friction(d: np.ndarray) -> np.ndarray:
    """The sheet's force on a tool travelling along `d`: Fz and its friction against the travel [N]."""
    return -MU * FZ_N * d + np.array([0.0, 0.0, FZ_N])


@pytest.mark.parametrize("turn_deg", [180.0, 90.0])
def test_the_friction_turns_at_the_planned_turn_not_when_the_force_shows_it(turn_deg: float) -> None:
    """Just before the measured force shows the turn, the correction without the turn fed forward misses that of a
    force that showed it at once by the sheet's friction's part (the joints' friction turns with the planned joints
    either way); fed forward, by less than a tenth of that. While the force comes round nothing is counted twice,
    and at the leg's end the correction is the timely one's."""
    spec, Q, d1, d2 = _path(turn_deg)
    forces = np.array([_friction(d1)] * (LEG + LATE) + [_friction(d2)] * (len(Q) - LEG - LATE))
    fed, plain = _run(spec, Q, forces, True), _run(spec, Q, forces, False)
    timely = _run(spec, Q, np.array([_friction(d1)] * LEG + [_friction(d2)] * LEG), False)
    before, after = plain[LEG - 1], plain[-1]
    change = after - before
    k = LEG + LATE - 1  # the last cycle before the force shows it
    missed = np.linalg.norm(plain[k] - timely[k])
    assert missed > 1e-4 and missed > 0.3 * np.linalg.norm(change)  # 0.1 mm at least, a fair part of the turn
    assert np.linalg.norm(fed[k] - timely[k]) < 0.1 * missed
    share = (fed[LEG:] - before) @ change / (change @ change)
    assert share.min() > -0.1 and share.max() < 1.1  # no overshoot while the force comes round
    # at the leg's end, as if the force had shown the turn at once (the plain run's differs at a 90 deg turn by
    # the side force's slowly filtered share, which it read from the friction the force had not yet turned)
    assert np.linalg.norm(fed[-1] - timely[-1]) < 0.05 * missed


def _walled(d: np.ndarray, wall_n: np.ndarray) -> np.ndarray:
    """`_friction` with a wall's push in the sheet plane [N] on top."""
    return _friction(d) + wall_n


def _fed_against_timely(turn_deg: float, wall: Callable[[np.ndarray], np.ndarray],
                        ploughed_n: float = 0.0) -> tuple[float, float]:
    """At a turn of `turn_deg` with a wall pushing the tool (`wall(d)`: its push on a tool travelling along d [N]),
    the measured force showing the turn `LATE` cycles late: how far the correction misses that of a force that showed
    it at once, without the turn fed forward and with it, the last cycle before the force shows it [m].
    `ploughed_n`: a push against the travel the first leg builds over its last fifth, on top of the friction (a
    plough toward a corner), gone on the second."""
    spec, Q, d1, d2 = _path(turn_deg)
    first = [_walled(d1, wall(d1) - ploughed_n * max(0.0, 5.0 * k / LEG - 4.0) * d1) for k in range(LEG)]
    late = first + [first[-1]] * LATE + [_walled(d2, wall(d2))] * (len(Q) - LEG - LATE)
    timely = _run(spec, Q, np.array(first + [_walled(d2, wall(d2))] * LEG), False)
    fed, plain = _run(spec, Q, np.array(late), True), _run(spec, Q, np.array(late), False)
    k = LEG + LATE - 1
    return float(np.linalg.norm(plain[k] - timely[k])), float(np.linalg.norm(fed[k] - timely[k]))


@pytest.mark.parametrize("turn_deg", [90.0, 60.0, -90.0])
def test_at_a_corner_the_walls_push_across_the_travel_turns_with_it(turn_deg: float) -> None:
    """A pyramid's wall pushes the tool across its travel (here a third of Fz, to its left); at the corner the next
    side's wall pushes it across the new travel as the last one did across the old: fed forward, the correction
    misses the timely one by less than a tenth of what it misses without."""
    missed, fed = _fed_against_timely(turn_deg, lambda d: FZ_N / 3.0 * np.array([-d[1], d[0], 0.0]))
    assert missed > 1e-4 and fed < 0.1 * missed, (missed, fed)


def test_after_a_corner_the_side_pushes_as_a_side_does_not_as_the_plough_before_it() -> None:
    """Toward a corner the force against the travel builds up (here by 0.2 Fz over the leg's last fifth, a plough, on
    top of the friction) and is gone on the next side: the force fed at the corner is the next side's steady one
    (its friction along the new travel, the wall's push across it), not the plough turned with the travel."""
    missed, fed = _fed_against_timely(90.0, lambda d: FZ_N / 3.0 * np.array([-d[1], d[0], 0.0]), 0.2 * FZ_N)
    assert missed > 1e-4 and fed < 0.1 * missed, (missed, fed)


def test_past_a_corner_the_new_walls_push_is_fed_as_the_tool_moves_into_it() -> None:
    """The friction turns at once with the travel, the old side's wall lets go; the next side's wall pushes only as
    the tool moves into it: the part of the fed force a wall adds grows over the first `WALL_BUILD_M` of the new
    travel, by the new wall's push, and then stays (the measured force here never shows the turn)."""
    said = quoted("online.md", "whole after", 5)  # its length, then the lengths it was chosen among [mm]
    assert said[0].value == pytest.approx(1e3 * WALL_BUILD_M) and said[0].value in [q.value for q in said[1:]]
    spec, Q, d1, _ = _path(90.0)
    left = np.array([-d1[1], d1[0], 0.0])  # the new travel, at a left turn of 90 deg
    wall = FZ_N / 3.0

    def fed(wall_n: float) -> np.ndarray:
        forces = np.array([_friction(d1) + wall_n * left] * len(Q))  # the old side's, throughout
        return _run(spec, Q, forces, True) - _run(spec, Q, forces, False)

    built = fed(wall) - fed(0.0)  # what the walls add to the fed correction [m]
    whole = LEG + math.ceil(WALL_BUILD_M / STEP_M)  # the turn is seen at LEG; then STEP_M of travel a cycle
    grown = built[whole] - built[LEG]
    # the new wall's push alone, s a_new (a_new = -d1 here), in the correction: its steady answer at the corner
    comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0, feed_turns=False))
    answer = []
    for push in (0.0, wall):
        comp.reset()
        for k in range(200):
            comp.step(CYCLE_S * k, CYCLE_S * k, np.array([0.0, 0.0, FZ_N]) - push * d1, Q[LEG])
        answer.append(comp.correction_m.copy())
    expected = answer[1] - answer[0]
    assert np.linalg.norm(expected) > 5e-5
    assert np.linalg.norm(grown - expected) < 0.15 * np.linalg.norm(expected), (grown, expected)
    first = built[LEG + 1] - built[LEG]  # one cycle's travel in: a share of it
    assert 0.1 * np.linalg.norm(expected) < np.linalg.norm(first) < 0.4 * np.linalg.norm(expected)
    assert np.linalg.norm(built[whole + 5] - built[whole]) < 0.05 * np.linalg.norm(expected)  # then it stays


def test_on_top_of_an_offline_command_a_corner_turns_the_friction_only() -> None:
    """On top of an offline command, whose assumed force turns at the corner by position, the compensator does not
    turn the wall again: what a wall adds to the force fed at a corner is nothing there, where on a nominal command
    it is the new wall's push (`_fed_against_timely`'s wall, the measured force never showing the turn)."""
    spec, Q, d1, _ = _path(90.0)
    twin = spec.build()
    kin = Kinematics(robot=twin.robot)
    tips = np.array([twin.R_base_sheet.T @ (kin.fk(q)[0] - twin.p_base_sheet_origin) for q in Q])
    left = np.array([-d1[1], d1[0], 0.0])

    def fed(wall_n: float, assumed: AssumedForces | None) -> np.ndarray:
        forces = np.array([_friction(d1) + wall_n * left] * len(Q))

        def run(feed: bool) -> np.ndarray:
            # the side force's share (`side_share`) off: the wall's push then changes nothing but the force fed
            comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0, feed_turns=feed, side_share=0.0),
                                     assumed=assumed)
            out = np.empty((len(Q), 3))
            for k, q in enumerate(Q):
                comp.step(CYCLE_S * k, CYCLE_S * k, forces[k], q, q)
                out[k] = comp.correction_m
            return out

        return run(True) - run(False)

    k = LEG + 10  # 1.2 mm into the new side: its wall whole, were it fed
    nothing = AssumedForces(tips, np.zeros_like(tips))  # a command that assumed no force: all of it is corrected
    walls = {name: fed(FZ_N / 3.0, a)[k] - fed(0.0, a)[k] for name, a in (("nominal", None), ("offline", nothing))}
    assert np.linalg.norm(walls["nominal"]) > 5e-5
    assert np.linalg.norm(walls["offline"]) < 0.02 * np.linalg.norm(walls["nominal"]), walls


def test_at_a_reversal_the_walls_stay_where_they_are() -> None:
    """A groove's walls do not turn with the tool that reverses between them: a push across the groove, fixed in the
    sheet, is not turned with the travel; only the friction is."""
    side = FZ_N / 3.0 * np.array([-math.sin(0.5), math.cos(0.5), 0.0])  # across the first leg, fixed in the sheet
    missed, fed = _fed_against_timely(180.0, lambda d: side)
    assert missed > 1e-4 and fed < 0.1 * missed, (missed, fed)


def test_the_planned_joints_show_a_turn_out_of_a_stop_first() -> None:
    """Out of a stop at 0.5 m/s^2 a reversal's first cycles move micrometres: the planned joints (no vibration in
    them) show the turn in the first step of 10 um; the measured ones only after 0.1 mm of travel, cycles later."""
    spec, Q, d1, _ = _path(180.0, accel_mps2=0.5)
    forces = np.array([_friction(d1)] * len(Q))
    plain = _run(spec, Q, forces, False)
    fed = {planned: _run(spec, Q, forces, True, planned) for planned in (True, False)}
    first = {planned: LEG + int(np.argmax(np.linalg.norm(c[LEG:] - plain[LEG:], axis=1) > 1e-5))
             for planned, c in fed.items()}
    assert first[True] <= LEG + 3  # two steps of 8 and 16 um
    assert first[False] >= first[True] + 2


def test_a_turn_the_force_never_shows_is_dropped() -> None:
    """A tool that left the sheet at the turn: the force keeps its old friction; after `TURN_SETTLE_S` the
    correction is the measured force's again."""
    spec, Q, d1, _ = _path(180.0)
    forces = np.array([_friction(d1)] * len(Q))
    fed, plain = _run(spec, Q, forces, True), _run(spec, Q, forces, False)
    assert np.linalg.norm(fed[LEG + 5] - plain[LEG + 5]) > 1e-5  # fed forward at first
    gone = LEG + 2 + math.ceil(TURN_SETTLE_S / CYCLE_S)
    np.testing.assert_allclose(fed[gone:], plain[gone:], atol=1e-9)


def test_a_gentle_curve_is_no_turn() -> None:
    """A spiral's travel turns by a fraction of a degree per step: nothing fed forward."""
    radius = 0.02
    angles = STEP_M / radius * np.arange(2 * LEG)
    tips = radius * np.column_stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)])
    spec, Q = _joints(tips - tips[0])
    tangents = np.column_stack([-np.sin(angles), np.cos(angles), np.zeros_like(angles)])
    forces = np.array([_friction(t) for t in np.roll(tangents, LATE, axis=0)])  # the force shows it late too
    np.testing.assert_allclose(_run(spec, Q, forces, True), _run(spec, Q, forces, False), atol=1e-12)


@pytest.mark.parametrize("value", [1, 0.0, "yes"])
def test_a_bad_feed_turns_is_named(value: object) -> None:
    with pytest.raises(InputError, match="feed_turns"):
        OnlineSettings(feed_turns=value)  # type: ignore[arg-type]


def test_how_much_of_the_friction_a_turn_turns_is_learned_from_the_turns() -> None:
    """A cell whose along-travel force turns by half of mu u at each reversal, the rest only later (a groove's end
    wall that pushed before it): the first turn is fed forward whole; by the last of seven, fed forward by what the
    turns showed, the correction before the force shows the turn is within a sixth of a timely force's of where the
    plain one is."""
    d = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    legs, settle = 8, math.ceil(1.2 * TURN_SETTLE_S / CYCLE_S)
    x = [0.0]
    for leg in range(legs):
        x += [x[-1] + (STEP_M if leg % 2 == 0 else -STEP_M) * k for k in range(1, LEG + 1)]
    spec, Q = _joints([v * d for v in x[1:]])

    def forces(late: int) -> np.ndarray:
        out = np.empty((len(Q), 3))
        for k in range(len(Q)):
            leg, into = divmod(max(k - late, 0), LEG)
            sign = 1.0 if leg % 2 == 0 else -1.0  # the leg's travel along d
            # the friction against the travel; after a turn at first only half of it: from +sign mu Fz to nothing
            along = 0.0 if leg > 0 and into < settle else -sign * MU * FZ_N
            out[k] = along * d + np.array([0.0, 0.0, FZ_N])
        return out

    fed, plain = _run(spec, Q, forces(LATE), True), _run(spec, Q, forces(LATE), False)
    timely = _run(spec, Q, forces(0), False)
    first, last = LEG + LATE - 1, (legs - 1) * LEG + LATE - 1
    assert np.linalg.norm(fed[first] - timely[first]) > 0.3 * np.linalg.norm(plain[first] - timely[first])
    assert np.linalg.norm(fed[last] - timely[last]) < np.linalg.norm(plain[last] - timely[last]) / 6.0


@pytest.mark.slow
def test_on_the_plant_the_turns_fed_forward_lower_the_groove_learned_from_a_cone(tmp_path, monkeypatch) -> None:
    """The dynamic plant (a cell the twin does not control): a model learned from one nominal cone compensates the
    groove online; with the turns fed forward the true tip's rms falls by a fifth at least (docs/online.md has the
    table; the plant's truth is read here, on the test's side, never by the twin)."""
    import functools
    from dataclasses import replace

    import twin.apps.tasks.lab_dynamic as lab_dynamic
    from twin.analysis.check import check_run
    from twin.cli import main
    from twin.runs.read import read_commanded_csv, read_run

    def lab(out: str, commanded: str, seed: int, *extra: str) -> None:
        assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--commanded", str(tmp_path / commanded),
                     "--seed", str(seed), "--out", str(tmp_path / out), *extra]) == 0

    assert main(["path", "--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10",
                 "--out", str(tmp_path / "cone.csv")]) == 0
    assert main(["path", "--shape", "groove", "--out", str(tmp_path / "groove.csv")]) == 0
    lab("cone1", "cone.csv", 1)
    assert main(["learn", str(tmp_path / "cone1"), "--write-model", str(tmp_path / "m.json")]) == 0
    rms = {}
    for feed in (False, True):
        monkeypatch.setattr(lab_dynamic, "OnlineSettings", functools.partial(OnlineSettings, feed_turns=feed))
        lab(f"groove{feed}", "groove.csv", 3, "--online", "--model", str(tmp_path / "m.json"))
        run, cmd = read_run(tmp_path / f"groove{feed}"), read_commanded_csv(tmp_path / "groove.csv")
        tip = read_commanded_csv(tmp_path / f"groove{feed}" / "truth_tip.csv")
        e = check_run(replace(run, tracker=tip), cmd.t_s, cmd.values).residual_m
        rms[feed] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    assert rms[True] < 0.8 * rms[False], rms


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["tx200", "kr210"])
def test_on_the_plant_the_pyramids_online_row_is_what_a_fresh_run_gives(tmp_path: Path, robot: str) -> None:
    """docs/online.md's other-part table, a development robot's pyramid formed online with the model learned from
    its nominal cone (`experiments/online_other_part.py`, seed 3), rerun: the true tip's rms within 0.005 mm of the
    table's (a machine's floating point moves the plant's third digit; the table's are the corner's wall fed as
    the tool moves into it, `WALL_BUILD_M`)."""
    import sys

    from online_doc_tables import ON_L, other_part

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    from online_other_part import learn_cone, learned_online_miss, target_ideal
    from online_study import rms_mm

    said = other_part("online-other-part")["true"][(robot, "pyramid")][ON_L]
    model, _ = learn_cone(tmp_path, robot)
    ideal = target_ideal(tmp_path, robot, "pyramid")
    measured = rms_mm(learned_online_miss(robot, model, ideal, ideal, tmp_path / "pyramid_online"))
    assert said is not None and abs(measured - said) <= 0.005, (measured, said)
