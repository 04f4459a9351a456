"""The online compensator: its correction is the twin's -C(q) F, and it behaves with a real signal (filter,
spikes, a sensor that freezes or drops out, size and rate limits), written against MuJoCo's own Jacobian."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.errors import InputError
from twin.robot.kinematics import Kinematics
from twin.sim.compiled.online import OFFSET_TAU_S
from twin.sim.compiled.progress import LOST_M, MAX_ADVANCE, OFFSET, SEGMENT, TRACK_SIZE, progress
from twin.sim.online import (
    HOLDING,
    NO_SENSOR,
    RAMPING,
    SPIKE,
    TRACKING,
    AssumedForces,
    OnlineCompensator,
    OnlineSettings,
)
from twin.sim.spec import TwinSpec

F_N = np.array([300.0, -100.0, 1800.0])  # a forming force of the groove's size, sheet on tool, sheet frame


@pytest.fixture(scope="module")
def setup():
    spec = TwinSpec()
    twin = spec.build()
    kin = Kinematics(robot=twin.robot)
    q = kin.q_home.copy()
    R = twin.R_base_sheet
    C_sheet = R.T @ kin.compliance(q, twin.joint_stiffness) @ R  # MuJoCo's Jacobian, base -> sheet frame
    return spec, q, C_sheet


def _run(comp: OnlineCompensator, q: np.ndarray, forces: np.ndarray, stamps: np.ndarray, cycle: float):
    out, status = np.zeros((len(forces), 3)), []
    for k, (f, s) in enumerate(zip(forces, stamps, strict=True)):
        status.append(comp.step(k * cycle, s, f, q))
        out[k] = comp.correction_m
    return out, status


def test_a_steady_force_is_corrected_by_the_twins_compliance(setup) -> None:
    spec, q, C = setup
    comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0))
    n = 500
    out, status = _run(comp, q, np.tile(F_N, (n, 1)), 0.004 * np.arange(n), 0.004)
    np.testing.assert_allclose(out[-1], -C @ F_N, atol=1e-9)  # to a nanometre of -C F
    assert status[-1] == TRACKING and 1.0 < 1e3 * np.linalg.norm(out[-1]) < 5.0


def test_on_a_frame_that_gives_the_correction_takes_the_frames_give_too(setup) -> None:
    """A model with a clamping frame of 0.5 mm/kN (`twin.sim.giving_frame`): the frame is a spring in series along
    the sheet's normal, so the steady correction is -(C + c e_z e_z^T) F: 0.9 mm deeper at the 1.8 kN here."""
    spec, q, C = setup
    from twin.sim.effects import Effects

    comp = OnlineCompensator(spec.replace(effects=Effects({"frame_compliance": 0.5})), OnlineSettings(max_rate_mm_s=1000.0))
    n = 500
    out, _ = _run(comp, q, np.tile(F_N, (n, 1)), 0.004 * np.arange(n), 0.004)
    np.testing.assert_allclose(out[-1], -C @ F_N - np.array([0.0, 0.0, 0.5e-6 * F_N[2]]), atol=1e-9)


def test_no_sensor_no_correction(setup) -> None:
    spec, q, _ = setup
    comp = OnlineCompensator(spec)
    assert comp.step(0.0, float("nan"), F_N, q) == NO_SENSOR
    assert not np.any(comp.correction_m)


def test_a_force_step_is_followed_within_the_rate_limit_and_the_size_limit(setup) -> None:
    spec, q, _ = setup
    settings = OnlineSettings(max_rate_mm_s=20.0, max_correction_mm=1.0)
    comp = OnlineCompensator(spec, settings)
    n = 300
    forces = np.zeros((n, 3))
    forces[50:] = 5.0 * F_N  # a 9 kN step: two samples rejected as spikes, then a new level; over the 1 mm limit
    out, _ = _run(comp, q, forces, 0.004 * np.arange(n), 0.004)
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert steps.max() <= 1e-3 * 20.0 * 0.004 * (1 + 1e-12)
    assert np.linalg.norm(out, axis=1).max() <= 1e-3 + 1e-15
    assert np.linalg.norm(out[-1]) == pytest.approx(1e-3, rel=1e-9)


def test_a_burst_of_calls_moves_the_correction_by_the_rate_times_the_time_it_spans(setup) -> None:
    """50 calls in 5 ms of the controller's time (a burst, or a second sender) move the correction by at most the
    rate limit times 5 ms (before, 50 cycles' worth: 40 x more); calls that carry no new time move it not at all."""
    spec, q, _ = setup
    settings = OnlineSettings(max_rate_mm_s=20.0)
    comp = OnlineCompensator(spec, settings)
    comp.step(0.0, 0.0, 5.0 * F_N, q)  # the filter starts at a force whose correction is the size limit
    start = comp.correction_m.copy()
    for k in range(1, 51):
        comp.step(1e-4 * k, 1e-4 * k, 5.0 * F_N, q)
    moved = float(np.linalg.norm(comp.correction_m - start))
    assert 0.0 < moved <= 1e-3 * settings.max_rate_mm_s * 5e-3 * (1 + 1e-9)
    frozen = comp.correction_m.copy()
    for _ in range(20):
        comp.step(5e-3, 5e-3, 5.0 * F_N, q)  # the same controller time again
    np.testing.assert_array_equal(comp.correction_m, frozen)


def test_a_spike_is_rejected_and_changes_nothing(setup) -> None:
    spec, q, _ = setup
    n = 200
    forces, stamps = np.tile(F_N, (n, 1)), 0.004 * np.arange(n)
    clean, _ = _run(OnlineCompensator(spec), q, forces, stamps, 0.004)
    spiked = forces.copy()
    spiked[120] += [0.0, 0.0, 6000.0]
    comp = OnlineCompensator(spec)
    out, status = _run(comp, q, spiked, stamps, 0.004)
    assert status[120] == SPIKE and comp.spikes_rejected == 1
    # the spike's sample is skipped: the next ones are older by one sample, so the prediction differs by a hair
    np.testing.assert_allclose(out, clean, atol=1e-7)


@pytest.mark.parametrize("fault", ["freezes", "drops out"])
def test_a_sensor_that_freezes_or_drops_out_holds_then_ramps_out_without_a_jump(setup, fault: str) -> None:
    spec, q, _ = setup
    settings = OnlineSettings(stale_s=0.1, hold_s=0.1, max_rate_mm_s=20.0)
    comp = OnlineCompensator(spec, settings)
    n, cycle = 1000, 0.004
    stamps = cycle * np.arange(n)
    forces = np.tile(F_N, (n, 1))
    stamps[400:] = stamps[399]  # no new sample after 1.6 s: the stamp stops
    if fault == "freezes":
        forces[400:] = forces[399]  # a frozen sensor repeats its last value
    else:
        forces[400:] = 0.0  # a dropped-out one sends nothing new (its last stamp stays)
    out, status = _run(comp, q, forces, stamps, cycle)
    held = out[399].copy()
    assert status[400 + 20] == TRACKING and status[400 + 40] == HOLDING and status[-1] == RAMPING
    np.testing.assert_allclose(out[400 + 40], held, atol=1e-15)  # held, not dropped
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert steps.max() <= 1e-3 * 20.0 * cycle * (1 + 1e-12)  # never a jump
    assert not np.any(out[-1])  # ramped out to zero


def test_bad_settings_name_the_setting() -> None:
    with pytest.raises(InputError, match="max_rate_mm_s = -1"):
        OnlineSettings(max_rate_mm_s=-1.0)
    with pytest.raises(InputError, match="gain = 3"):
        OnlineSettings(gain=3.0)


def _residual_rms_mm(run_dir) -> float:
    from twin.base.signals import interp_rows
    from twin.runs.read import read_run

    run = read_run(run_dir)
    gap = run.tracker.values - interp_rows(run.tracker.t_s, run.commanded.t_s, run.commanded.values)
    return 1e3 * float(np.sqrt(np.mean(np.sum(gap**2, axis=1))))


def test_the_dynamic_plants_controller_compensates_online(tmp_path) -> None:
    """The twin's compensator in the plant's 4 ms cycle, on the plant's own F/T stream (its noise, latency and
    bias): the groove's tool tip follows its command far closer than without it (docs/online.md's table)."""
    import json

    from twin.base.csvio import read_table
    from twin.cli import main

    for name, extra in (("nominal", []), ("online", ["--online"])):
        assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", *extra,
                     "--out", str(tmp_path / name)]) == 0
    nominal, online = _residual_rms_mm(tmp_path / "nominal"), _residual_rms_mm(tmp_path / "online")
    from test_online_side import side_share_median

    groove_share = side_share_median(tmp_path / "nominal")  # docs/online.md: the groove's walls push it nowhere
    documented = quoted("online.md", "| nominal, no compensation |", 1) + quoted("online.md", "default model |", 1)
    documented[0].check(nominal, slack=2.0)  # docs/online.md's table, within 0.02 mm
    documented[1].check(online, slack=2.0)
    quoted("online.md", "default knobs, seed 1: TX200 cone 40 x 6", 3)[2].check(groove_share, slack=2.0)
    assert online < 0.35 * nominal
    assert groove_share < 0.3 * OnlineSettings().side_share  # the correction across nearly all left out
    meta = json.loads((tmp_path / "online" / "meta.json").read_text())
    assert meta["online"]["settings"]["max_correction_mm"] == 5.0 and meta["online"]["model"] is None
    log = read_table(tmp_path / "online" / "online.csv", ("t_s", "dx_mm", "dy_mm", "dz_mm", "compute_us", "status"))
    steps = np.linalg.norm(np.diff(np.column_stack([log["dx_mm"], log["dy_mm"], log["dz_mm"]]), axis=0), axis=1)
    settings = OnlineSettings()
    assert steps.max() <= settings.max_rate_mm_s * settings.cycle_s + 1e-4  # the rate limit, at the log's precision
    assert np.median(np.diff(log["t_s"])) == pytest.approx(settings.cycle_s)


@pytest.mark.parametrize("argv, message", [
    (["--online"], "need --plant dynamic"),
    (["--plant", "dynamic", "--model", "m.json"], "give --online with it"),
])
def test_online_options_are_checked(tmp_path, capsys, argv, message) -> None:
    from twin.cli import main

    assert main(["lab", "--scenario", "nominal", "--seed", "1", *argv, "--out", str(tmp_path / "r")]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_the_study_table_is_what_the_study_gives(tmp_path) -> None:
    """docs/online.md's groove row, rerun (`experiments/online_study.py`), each number within 0.02 mm."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    from online_study import variant_study

    row = variant_study(tmp_path / "groove-default", "groove-default")
    numbers = quoted("online.md", "| groove-default |", 28)
    cells = ("nominal", "offline_default", "offline_learned", "online_default", "online_learned", "both_default",
             "both_learned")
    measured = [row[c][k] for c in cells for k in ("rms_mm", "max_mm", "less_offset_rms_mm", "away_rms_mm")]
    for doc, value in zip(numbers, measured, strict=True):
        doc.check(value, slack=2.0)


def _tip(spec: TwinSpec, q: np.ndarray) -> np.ndarray:
    """The twin's tool tip at q, sheet frame [m] (what the compensator matches to the command)."""
    twin = spec.build()
    kin = Kinematics(robot=twin.robot)
    return twin.R_base_sheet.T @ (kin.fk(q)[0] - twin.p_base_sheet_origin)


def test_on_top_of_an_offline_command_only_the_unassumed_force_is_corrected(setup) -> None:
    spec, q, C = setup
    tip = _tip(spec, q)
    path = tip + np.outer(np.linspace(-1.0, 1.0, 5), [0.01, 0.0, 0.0])  # a straight command through the robot's tip
    comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0),
                             assumed=AssumedForces(path, np.tile(0.8 * F_N, (5, 1))))  # it assumed 80 %
    n = 500
    out, _ = _run(comp, q, np.tile(F_N, (n, 1)), 0.004 * np.arange(n), 0.004)
    np.testing.assert_allclose(out[-1], -C @ (0.2 * F_N), atol=1e-9)
    with pytest.raises(InputError, match="assumed forces"):
        OnlineCompensator(spec, assumed=(np.zeros(2), np.zeros((2, 3))))  # times, as before: not positions
    with pytest.raises(InputError, match="assumed forces"):
        OnlineCompensator(spec, assumed=(np.full((2, 3), np.nan), np.zeros((2, 3))))


def test_the_assumed_force_is_looked_up_where_the_robot_is_not_when(setup) -> None:
    """A controller stops at corners by its own rules: the PC beside it knows where the joints are, not when the
    controller reaches a command sample. Whatever the clock says, the force assumed where the robot is (at the
    command's start here) is the one taken off."""
    spec, q, C = setup
    path = _tip(spec, q) + np.outer([0.0, 1.0, 2.0, 3.0], [0.01, 0.0, 0.0])  # the command starts at the robot
    assumed = np.array([0.5 * F_N, 0.5 * F_N, 0.0 * F_N, 0.0 * F_N])  # only there it assumed a force
    comp = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=1000.0), assumed=(path, assumed))
    n = 500
    out, _ = _run(comp, q, np.tile(F_N, (n, 1)), 1e3 + 0.004 * np.arange(n), 0.004)  # a clock far past the command
    np.testing.assert_allclose(out[-1], -C @ (0.5 * F_N), atol=1e-9)


@pytest.mark.parametrize("offset_mm", [0.0, 2.0])
def test_the_progress_along_a_command_goes_forward_over_its_return_and_its_dwells(offset_mm: float) -> None:
    """The progress index: a groove-like pass out and back 0.5 mm lower, a dwell at the turn; a robot that walks
    it is matched to the outbound pass until the turn, then to the return, and no cycle moves it more than
    `MAX_ADVANCE` segments; also when the twin's kinematics put the robot 2 mm off the command (more than the
    passes are apart)."""
    x = np.linspace(0.0, 0.05, 51)
    out_pass = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    back = np.column_stack([x[::-1], np.zeros_like(x), np.full_like(x, -5e-4)])
    path = np.vstack([out_pass, np.repeat(out_pass[-1:], 3, axis=0), back])  # a dwell (repeated samples) at the turn
    walked = np.vstack([out_pass, back]) + np.array([0.3, 0.0, 1.0]) * 1e-3 * offset_mm
    track = np.zeros(TRACK_SIZE)
    seen = []
    for point in walked:
        before = int(track[SEGMENT])
        s, lost = progress(path, track, *point, 1.0 - np.exp(-0.004 / OFFSET_TAU_S))
        assert 0.0 <= s <= 1.0 and 0 <= int(track[SEGMENT]) - before <= MAX_ADVANCE and not lost
        seen.append(int(track[SEGMENT]))
    assert seen == sorted(seen)  # only forward
    assert seen[40] < 51 and seen[-1] >= 54 + 40  # out: on the outbound segments; back: on the return's
    track[:] = 0.0
    progress(path, track, *path[0], 0.0)
    progress(path, track, *path[-1], 0.0)  # far along at once (after a dropout): a bounded walk
    assert int(track[SEGMENT]) <= MAX_ADVANCE


def test_the_progress_finds_its_place_again_past_a_detour_the_robot_cut_short() -> None:
    """A pass's reversal as a learned offline command made it (the KR 210's law-2 groove, learned from a cone: x, z
    [mm]): down and back, then up 1.4 mm over 1 mm of travel and down again. The controller's motion cuts that hump
    short, and the robot goes on along the return. The hump's top segment is never the nearer one, so the walk alone
    stopped at its foot for the rest of the run, its offset running off by millimetres (as `lab --online` on top of
    that command did); the progress ends at the command's end, its offset within 0.1 mm of where it started."""
    turn = 1e-3 * np.array([
        [31.471, -4.602], [31.965, -4.616], [32.459, -4.63], [32.954, -4.644], [33.448, -4.66], [31.508, -5.192],
        [30.849, -5.253], [30.266, -5.286], [29.726, -5.304], [29.208, -5.315], [28.7, -5.326], [28.321, -5.192],
        [28.052, -4.676], [27.797, -4.261], [27.723, -3.783], [28.763, -2.379], [28.069, -2.413], [27.654, -2.453],
        [27.246, -2.492], [26.356, -3.02], [25.384, -3.582], [24.489, -4.061], [23.947, -4.133]])
    turn = np.column_stack([turn[:, 0], np.zeros(len(turn)), turn[:, 1]])
    out_pass = np.column_stack([np.arange(0.020, 0.0314, 5e-4), np.zeros(23), np.full(23, -4.6e-3)])
    back = np.column_stack([np.arange(0.0234, 0.005, -5e-4), np.zeros(37), np.full(37, -4.15e-3)])
    path = np.vstack([out_pass, turn, back])
    walked = np.vstack([out_pass, turn[:15], turn[21:], back])  # from the hump's foot straight on along the return
    walked = np.vstack([np.linspace(a, b, 5, endpoint=False) for a, b in itertools.pairwise(walked)]
                       + [walked[-1:]])  # about every 0.1 mm
    quoted("online.md", "short and is left", 1)[0].check(1e3 * LOST_M)  # the page's threshold is the code's
    track = np.zeros(TRACK_SIZE)
    lost = [progress(path, track, *point, 1.0 - np.exp(-0.004 / OFFSET_TAU_S))[1] for point in walked]
    assert int(track[SEGMENT]) == len(path) - 2
    assert np.linalg.norm(track[OFFSET:OFFSET + 3]) < 1e-4
    assert 0 < sum(lost) <= 5 and not any(lost[-100:])  # lost for a few samples past the hump, then found


def test_the_compensator_counts_the_cycles_the_robot_was_lost_on_its_command(setup) -> None:
    """Joints that put the tip 15 mm off an offline command (a detour it cut short, or a command that is not the
    one running): counted, and the lab says so; joints on the command are not."""
    from dataclasses import replace

    from twin.apps.tasks.lab_dynamic import DynamicRunReport, online_summary
    from twin.lab.dynamic.online import OnlineLog

    spec, q, _ = setup
    path = _tip(spec, q) + np.outer([0.0, 1.0, 2.0, 3.0], [0.01, 0.0, 0.0])  # the command starts at the robot
    comp = OnlineCompensator(spec, assumed=(path, np.zeros_like(path)))
    off = q + np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0])  # joint 1 by 10 mrad: the tip ~15 mm sideways
    for k in range(10):
        comp.step(0.004 * k, 0.004 * k, F_N, q if k < 4 else off)
    assert comp.cycles_lost_on_command == 6
    log = OnlineLog(0.004 * np.arange(10), np.zeros((10, 3)), np.full(10, 1e-5), np.ones(10, int))
    summary = online_summary(log, 5.0, comp.cycles_lost_on_command)
    assert summary["lost_on_command_cycles"] == 6
    report = DynamicRunReport("compensated", Path("run"), 1, {}, 10, 10, 1.0, 100.0, 4, 0.1, summary)
    assert any("lost on the offline command" in line and " 6 cycles" in line for line in report.lines())
    calm = replace(report, online=online_summary(log, 5.0))
    assert not any("lost on the offline command" in line for line in calm.lines())


def test_the_lab_says_when_the_correction_sat_at_its_limit() -> None:
    """A cell whose deflection is more than `max_correction_mm` (the IRB 6640's deepest groove passes): the run's
    summary says in what share of the cycles the correction sat at its limit; a run that never reached it says
    nothing of it."""
    from dataclasses import replace

    from twin.apps.tasks.lab_dynamic import DynamicRunReport, online_summary
    from twin.lab.dynamic.online import OnlineLog

    limit_mm = OnlineSettings().max_correction_mm
    sizes_m = 1e-3 * np.array([1.0, limit_mm, 0.5 * limit_mm, limit_mm])
    log = OnlineLog(np.arange(4) * 0.004, np.outer(sizes_m, [0.6, 0.0, 0.8]), np.full(4, 1e-5), np.ones(4, int))
    summary = online_summary(log, limit_mm)
    assert summary["at_limit_share"] == pytest.approx(0.5) and summary["limit_mm"] == limit_mm
    report = DynamicRunReport("nominal", Path("run"), 1, {}, 10, 10, 1.0, 100.0, 4, 0.1, summary)
    assert any("sat at its limit" in line and "50.0 %" in line for line in report.lines())
    calm = online_summary(log._replace(correction_m=0.5 * log.correction_m), limit_mm)
    assert calm["at_limit_share"] == 0.0
    assert not any("limit" in line for line in replace(report, online=calm).lines())


def test_the_correction_limit_is_the_lab_s_and_the_server_s_option(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """`lab --online --max-correction-mm 1` holds the plant's groove correction to 1 mm and says for how much of the
    run it sat there; a limit that is not one is refused by `lab` and by `online` (exit 2), naming the option."""
    from twin.apps.tasks.online import OnlineRequest
    from twin.cli import main

    out = tmp_path / "run"
    assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", "--online",
                 "--max-correction-mm", "1", "--out", str(out)]) == 0
    said = capsys.readouterr()
    assert "sat at its limit (1.0 mm" in said.out + said.err
    log = np.loadtxt(out / "online.csv", delimiter=",", skiprows=1)
    assert np.max(np.linalg.norm(log[:, 1:4], axis=1)) <= 1.0 + 1e-4  # the log keeps 5 decimals of a mm
    for value in ("0", "60"):
        assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", "--online",
                     "--max-correction-mm", value, "--out", str(tmp_path / "bad")]) == 2
        assert "--max-correction-mm" in capsys.readouterr().err and not (tmp_path / "bad").exists()
    with pytest.raises(InputError, match="--max-correction-mm"):
        OnlineRequest("rsi", max_correction_mm=0.0)
    assert main(["online", "--serve", "rsi", "--cycles", "1", "--max-correction-mm", "nan"]) == 2  # the same check
    assert "--max-correction-mm nan: expected" in capsys.readouterr().err
    assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", "--max-correction-mm", "8",
                 "--out", str(tmp_path / "offline")]) == 2  # without --online it would do nothing: refused
    assert "without --online" in capsys.readouterr().err and not (tmp_path / "offline").exists()
