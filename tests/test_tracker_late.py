"""`learn --tracker-late` on the dynamic plant: a tracker that reads late, written here at the data level.

A cone's travel turns joint 1 back and forth, and a reading late by dt leaves the tip -v dt behind along that travel:
on a cone the same sign as joint 1's motion, which is what a friction of joint 1 makes. The plant's code is used only
to form one neutral cone (`lab --neutral`: its tracker reads on time); the lateness is this test's own (the run's
tracker read 6 ms late by interpolation of its own samples), a form the learner does not have.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from cli_refusal import cli_out, refused

import twin.apps.tasks.learn as learn_task_module
from twin.analysis.learn import TrackerErrors, learn
from twin.cli import main
from twin.errors import InputError
from twin.runs.format import Stream
from twin.runs.read import read_run
from twin.runs.write import write_run

#: How late this test makes the tracker read [s].
LATE_S = 0.006


@pytest.mark.slow
def test_a_late_tracker_is_carried_as_its_clock_not_as_joint_1s_friction(tmp_path: Path) -> None:
    cli_out(["path", "--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10", "--robot", "irb6640",
             "--out", str(tmp_path / "cone.csv")])
    cli_out(["lab", "--plant", "dynamic", "--neutral", "--scenario", "nominal", "--commanded",
             str(tmp_path / "cone.csv"), "--seed", "1", "--robot", "irb6640", "--out", str(tmp_path / "run")])
    run = read_run(tmp_path / "run")
    t = run.tracker.t_s
    late = np.stack([np.interp(t - LATE_S, t, run.tracker.values[:, a]) for a in range(3)], axis=1)
    edited = read_run(write_run(tmp_path / "late", replace(run, tracker=Stream(t, late))))
    on_time, plain, alone = learn([run]), learn([edited]), learn([edited], tracker=TrackerErrors.LATE)
    # the default learner reads the lateness as joint 1's friction (and bends a spring); the lateness alone
    # is carried as the tracker's clock, the robot as it was learned from the run on time
    assert on_time.robot.friction_nm[0] < 20.0, on_time.robot.friction_nm
    assert plain.robot.friction_nm[0] > 100.0, plain.robot.friction_nm
    assert alone.robot.friction_nm[0] < 20.0, alone.robot.friction_nm
    seen = on_time.robot.observable
    assert np.array_equal(alone.robot.observable, seen)
    k0, k1 = on_time.robot.k_q_nm_per_rad[seen], alone.robot.k_q_nm_per_rad[seen]
    assert np.all(np.abs(k1 / k0 - 1.0) <= 0.05), (k0, k1)
    assert np.max(np.abs(plain.robot.k_q_nm_per_rad[seen] / k0 - 1.0)) > 0.2
    assert 0.5 * LATE_S <= alone.spec.effects.instruments.tracker_time_offset_s[0] <= 1.5 * LATE_S


def test_the_option_asks_for_the_lateness_alone_and_not_with_tracker_errors(tmp_path: Path, capsys,
                                                                             monkeypatch) -> None:
    with pytest.raises(SystemExit) as exited:  # argparse's own refusal
        main(["learn", str(tmp_path), "--tracker-errors", "--tracker-late"])
    assert exited.value.code == 2
    assert "--tracker-late: not allowed with argument --tracker-errors" in capsys.readouterr().err
    asked = []

    def task(request: learn_task_module.LearnRequest) -> None:
        asked.append(request)
        raise InputError("asked")

    monkeypatch.setattr(learn_task_module, "learn_task", task)
    refused(["learn", str(tmp_path), "--tracker-late"], capsys, "asked")
    refused(["learn", str(tmp_path), "--tracker-errors"], capsys, "asked")
    refused(["learn", str(tmp_path)], capsys, "asked")
    assert [r.tracker for r in asked] == [TrackerErrors.LATE, TrackerErrors.TURNED, TrackerErrors.OFFSET]
    with pytest.raises(InputError, match="tracker 'late': expected one of OFFSET, LATE, TURNED"):
        learn_task_module.LearnRequest((tmp_path,), tracker="late")  # type: ignore[arg-type]
