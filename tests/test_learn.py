"""`learn` on the dynamic plant, a cell the twin did not build (its own servo, gears, friction and sheet).

The plant's code is never used here beyond making runs with `tx200-twin lab`, and `learn` reads only the runs'
streams. Learned from seed 1's nominal groove, the twin is judged on seed 2's (another run, never learned from);
the thresholds are the issue's targets (#37), set before any run was learned.
"""

from __future__ import annotations

import ast
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.analysis.learn import TrackerErrors, learn
from twin.analysis.replay import replay
from twin.cli import main
from twin.runs.read import read_run

LEARN_DIR = Path(__file__).resolve().parent.parent / "twin" / "analysis" / "learn"


@pytest.fixture(scope="module")
def plant_runs(neutral_groove_runs) -> dict[int, Path]:
    """Nominal groove runs of the dynamic plant (neutral knobs), seeds 1 and 2 (conftest's, shared: read-only)."""
    return {seed: neutral_groove_runs(seed) for seed in (1, 2)}


@pytest.fixture(scope="module")
def learned(plant_runs: dict[int, Path]):
    return learn([read_run(plant_runs[1])])


def test_the_learned_twin_replays_a_run_it_never_saw(plant_runs: dict[int, Path], learned) -> None:
    before = replay(read_run(plant_runs[2])).metrics
    after = replay(read_run(plant_runs[2]), learned.spec).metrics
    assert before["position_rms_mm"] > 0.5  # the untaught twin's gap (0.80 mm in #37)
    assert after["position_rms_mm"] <= 0.15
    # docs/learning.md quotes them; a machine's floating point moves them in the third digit at most
    after_mm, after_n, before_mm, before_n = quoted("learning.md", "replays seed 2's run with a gap of", 4)
    after_mm.check(after["position_rms_mm"], slack=3)
    after_n.check(after["force_rms_n"], slack=15)
    before_mm.check(before["position_rms_mm"], slack=3)
    before_n.check(before["force_rms_n"], slack=15)
    assert after["force_rms_n"] <= 0.25 * before["force_rms_n"]
    assert learned.spec.process.force_model == "learned"
    assert learned.robot.observable[1] and learned.robot.observable[2]  # the groove loads joints 2 and 3
    # the robot's fit never leaves its own part of the gap larger than the prior did (its bounds are refitted:
    # unobserved joints held at the prior, friction >= 0; before, clipping after the solve grew it, issue #46)
    assert all(b <= a for a, b in zip(learned.robot.rms_prior_mm, learned.robot.rms_after_mm, strict=True))


def test_the_grooves_force_is_learned_from_its_walls(learned) -> None:
    """docs/learning.md: the walls' rise around the tool takes about two thirds off the tip terms' look-ahead error
    on the TX200's groove, over the 40 % at which it is taken."""
    quoted("learning.md", "whose force is its walls',", 1)[0].check(100.0 * learned.sheet.shape_share, slack=3)
    assert learned.sheet.shape_share > 0.4 and any("rise" in term for term in learned.sheet.terms), learned.sheet


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="#37's 80 N force target: the learned sheet leaves the force spikes at "
                   "the groove's reversals (the plant's stops) and the passes' start")
def test_the_learned_force_gap_meets_the_issue_target(plant_runs: dict[int, Path], learned) -> None:
    assert replay(read_run(plant_runs[2]), learned.spec).metrics["force_rms_n"] <= 80.0


def test_learn_never_reads_the_plants_truth(plant_runs: dict[int, Path], learned, tmp_path: Path) -> None:
    copy = tmp_path / "run"
    shutil.copytree(plant_runs[1], copy)
    # the plant's true tip beside the run (neutral knobs: the tracker reads it and its noise, no registration)
    tip = np.loadtxt(copy / "truth_tip.csv", delimiter=",", skiprows=1)
    tracker = np.loadtxt(copy / "tracker.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(tip[:, 0], tracker[:, 0])
    assert 1e-4 < np.sqrt(np.mean((tip[:, 1:] - tracker[:, 1:]) ** 2)) < 0.05  # [mm]: the tracker's noise
    (copy / "truth.json").write_text("not json: learn must not open this file")
    (copy / "truth_tip.csv").write_text("not a path: learn must not open this file")
    again = learn([read_run(copy)])
    assert again.spec == learned.spec
    (copy / "truth.json").unlink()
    (copy / "truth_tip.csv").unlink()
    assert learn([read_run(copy)]).spec == learned.spec
    for path in LEARN_DIR.glob("*.py"):
        tree = ast.parse(path.read_text())
        imported = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module]
        assert not [m for m in imported if m.startswith("twin.lab")], path
        assert "truth" not in path.read_text().replace("`truth.json`", ""), path


def test_cli_learn_writes_a_model_replay_takes(plant_runs: dict[int, Path], tmp_path: Path,
                                              neutral_groove_cell: tuple[Path, str]) -> None:
    """`learn RUN1 RUN2 --write-model cell.json --json learn.json` (conftest's `neutral_groove_cell`, the cell
    test_learning_stacks.py judges a change against: run once for both)."""
    cell, out = neutral_groove_cell
    model, report = cell / "cell.json", cell / "learn.json"
    assert "left out" in out and "(fitted" in out and "(predicted" in out
    assert "fitted for robot tx200 (" in out and "(the runs' placement), tool " in out  # #46: which robot it fitted
    data = json.loads(report.read_text())
    assert data["fitted_for"]["robot"] == "tx200" and data["fitted_for"]["tool_length_mm"] > 0
    assert len(data["held_out_predicted"]) == 2
    assert all(g["position_rms_mm"] <= 0.15 for g in data["held_out_predicted"])
    replayed = tmp_path / "replay.json"
    assert main(["replay", str(plant_runs[2]), "--model", str(model), "--forces", "measured",
                 "--json", str(replayed)]) == 0
    metrics = json.loads(replayed.read_text())
    assert metrics["process"]["force_model"] == "learned"
    assert metrics["robot_gap_rms_mm"] < 0.2 and metrics["sheet_gap_rms_mm"] < 0.2


def test_the_untaught_gap_is_the_sheets(plant_runs: dict[int, Path], tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.json"
    assert main(["replay", str(plant_runs[2]), "--forces", "measured", "--json", str(out)]) == 0
    metrics = json.loads(out.read_text())
    assert metrics["sheet_gap_rms_mm"] > 3 * metrics["robot_gap_rms_mm"]
    # where the robot's part lies (twin.analysis.learn.split): the groove's reversals are the controller's stops
    fast, share, samples = (metrics[k] for k in ("robot_gap_fast_mm", "robot_gap_near_stop_share",
                                                 "samples_near_stop_share"))
    assert 0.0 < samples < 1.0 and 0.0 <= share <= 1.0 and 0.0 < fast <= metrics["robot_gap_rms_mm"]
    printed = capsys.readouterr().out
    assert (f"the robot's part: {fast:.3f} mm rms above 0.5 Hz" in printed
            and f"{100 * share:.0f} % of its mean square within 0.3 s of the controller's stops, where "
                f"{100 * samples:.0f} % of the samples are" in printed), printed


def test_learn_refuses_a_run_without_forces(plant_runs: dict[int, Path], tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    copy = tmp_path / "run"
    shutil.copytree(plant_runs[1], copy)
    (copy / "forces.csv").unlink()
    assert main(["learn", str(copy), "--write-model", str(tmp_path / "m.json")]) == 2
    assert "forces.csv" in capsys.readouterr().err
    assert not (tmp_path / "m.json").exists()


def test_the_springback_learned_from_the_profile_predicts_another_runs_part(plant_runs: dict[int, Path],
                                                                             learned) -> None:
    from twin.analysis.learn.cell import replay_gap
    from twin.sim.spec import TwinSpec

    assert learned.springback is not None  # the plant's runs carry the groove's profile
    run = read_run(plant_runs[2])
    untaught = replay_gap(run, TwinSpec())
    taught = replay_gap(run, learned.spec)
    assert taught.profile_rms_mm < 0.5 * untaught.profile_rms_mm
    assert dict(learned.spec.process.force_fit)["recovery_scale"] == learned.springback.recovery_scale


def test_discrepancy_learns_what_no_family_explains_and_shows_it_on_another_run(
        plant_runs: dict[int, Path], tmp_path: Path) -> None:
    model, report = tmp_path / "cell.json", tmp_path / "d.json"
    assert main(["discrepancy", str(plant_runs[1]), "--held-out", str(plant_runs[2]), "--model-out", str(model),
                 "--json", str(report)]) == 0
    data = json.loads(report.read_text())
    assert data["effect"] == "unexplained"
    learned = data["learned"]
    assert any(s.startswith("the sheet pushes") and "less" in s for s in learned["named"])  # the plant's is softer
    assert any("against the travel" in s for s in learned["named"])
    held = learned["held_out"]
    assert held["after_mm"] < 0.25 * held["before_mm"] and held["after_n"] < 0.25 * held["before_n"]
    assert json.loads(model.read_text())["process"]["force_model"] == "learned"


def test_learn_refuses_runs_that_cannot_teach_it(plant_runs: dict[int, Path], tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    silent = tmp_path / "silent"
    shutil.copytree(plant_runs[1], silent)
    lines = (silent / "forces.csv").read_text().splitlines()
    (silent / "forces.csv").write_text("\n".join([lines[0], *(f"{line.split(',')[0]},0,0,0" for line in lines[1:])])
                                       + "\n")
    assert main(["learn", str(silent)]) == 2
    assert "no forming contact" in capsys.readouterr().err
    moved = tmp_path / "moved"
    shutil.copytree(plant_runs[2], moved)
    meta = json.loads((moved / "meta.json").read_text())
    meta["placement"] = {"origin_base_mm": [1700.0, 50.0, 500.0], "yaw_deg": 10.0}
    (moved / "meta.json").write_text(json.dumps(meta))
    assert main(["learn", str(plant_runs[1]), str(moved)]) == 2
    assert "another placement" in capsys.readouterr().err


def test_discrepancy_stands_when_the_run_cannot_teach_the_twin(plant_runs: dict[int, Path], tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    import twin.analysis.learn as learning
    from twin.errors import InputError

    def refuse(*_args: object, **_kwargs: object) -> None:
        raise InputError("a silent F/T stream")

    monkeypatch.setattr(learning, "learn", refuse)
    report = tmp_path / "d.json"
    assert main(["discrepancy", str(plant_runs[1]), "--json", str(report)]) == 0
    assert json.loads(report.read_text())["learned"] == {"refused": "a silent F/T stream"}


def test_a_plant_with_twice_its_link_friction_teaches_more_friction(learned, tmp_path: Path) -> None:
    """The hidden change is the plant's own (its link friction doubled, `--set link_friction_scale=2`), not a
    form the twin has: joint 3, the one the groove drives hardest, must come out with clearly more friction."""
    out = tmp_path / "friction"
    assert main(["lab", "--plant", "dynamic", "--neutral", "--set", "link_friction_scale=2", "--scenario", "nominal",
                 "--seed", "1", "--out", str(out)]) == 0
    rougher = learn([read_run(out)])
    assert rougher.robot.observable[2]
    assert rougher.robot.friction_nm[2] > 1.3 * learned.robot.friction_nm[2]


def test_learn_keeps_the_declared_sheet_where_the_learned_one_forces_no_nearer(clean_run_dir: Path) -> None:
    """The lab's clean run is the declared twin's own (its force model a table of FE forces): the learned sheet's
    terms cannot take that form, so the declared one is kept (before: the learned sheet replaced it, and the
    replay of the run it learned from went from 0.034 to 0.164 mm)."""
    from twin.analysis.learn.cell import declared_process, sheet_kept

    run = read_run(clean_run_dir)
    result = learn([run])
    assert sheet_kept(result.sheet)
    assert result.spec.process.force_model == declared_process(run).force_model != "learned"
    assert result.after[0].position_rms_mm < 1.25 * result.before[0].position_rms_mm


def test_learn_with_tracker_errors_carries_a_late_tracker_as_its_clock(plant_runs: dict[int, Path],
                                                                     tmp_path: Path) -> None:
    """A change written here, at the data level (the tracker's samples read 6 ms late, by interpolation of the
    neutral run's own reading): `learn --tracker-errors` carries more lateness than it finds on the run as it came
    (the robot's own lag along the path is in both), at least half the 6 ms (a groove's steady travel makes a
    lateness and a friction read almost alike: 4.1 ms carried, the rest in joints 2 and 3's friction), and joints 2
    and 3 (which a groove loads) keep their K_q within 5 %; the default learner carries no lateness."""
    from dataclasses import replace

    import numpy as np

    from twin.runs.format import Stream
    from twin.runs.write import write_run

    run = read_run(plant_runs[1])
    t = run.tracker.t_s
    late = np.stack([np.interp(t - 0.006, t, run.tracker.values[:, a]) for a in range(3)], axis=1)
    edited = read_run(write_run(tmp_path / "late6ms", replace(run, tracker=Stream(t, late))))
    as_came, with_late = learn([run], tracker=TrackerErrors.TURNED), learn([edited], tracker=TrackerErrors.TURNED)
    found = [r.spec.effects.instruments.tracker_time_offset_s[0] for r in (as_came, with_late)]
    assert 0.003 <= found[1] - found[0] <= 0.0066, found
    k0, k1 = as_came.robot.k_q_nm_per_rad, with_late.robot.k_q_nm_per_rad
    assert np.all(np.abs(k1[1:3] / k0[1:3] - 1.0) <= 0.05), (k0, k1)
    assert learn([edited]).spec.effects.instruments.tracker_time_offset_s[0] == 0.0
