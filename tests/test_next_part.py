"""`compensate --forces-from RUN`: the next part from the last part's measured forces (`twin.analysis.next_part`).

On the dynamic plant's groove (neutral knobs, a cell the twin did not build), the untaught twin's robot driven by
the nominal run's measured forces makes a command whose groove misses far less than the nominal one and than the
untaught twin's own compensation (its sheet model's forces); the thresholds were set before the run. A run that
cannot give a next command is refused with exit 2, naming it; a controller's log at its own rate gives the same
command as the program's samples; and the forces are taken as the sheet pushed, through the F/T calibration the
model carries.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.analysis.compensation_record import read_record
from twin.cli import main
from twin.runs.read import read_commanded_csv, read_run


def _true_miss_mm(run_dir: Path, ideal: Path) -> float:
    """The plant's true tip (truth_tip.csv, read on the test's side) against the ideal path, rms [mm]."""
    from twin.analysis.check import ideal_times
    from twin.base.signals import interp_rows

    run, cmd, tip = read_run(run_dir), read_commanded_csv(ideal), read_commanded_csv(run_dir / "truth_tip.csv")
    ideal_at = interp_rows(run.tracker.t_s, ideal_times(run.commanded.t_s, cmd.t_s), cmd.values)
    return 1e3 * float(np.sqrt(np.mean(np.sum((tip.values - ideal_at) ** 2, axis=1))))


@pytest.fixture(scope="module")
def groove(tmp_path_factory) -> Path:
    ideal = tmp_path_factory.mktemp("next-part") / "groove.csv"
    assert main(["path", "--shape", "groove", "--out", str(ideal)]) == 0
    return ideal


def _form(command: Path, out: Path) -> Path:
    assert main(["lab", "--plant", "dynamic", "--neutral", "--scenario", "compensated", "--commanded", str(command),
                 "--seed", "3", "--out", str(out)]) == 0
    return out


def test_the_next_groove_from_the_last_one_s_forces_misses_less_than_the_sheet_model_s(
        neutral_groove_runs, groove: Path, tmp_path: Path) -> None:
    nominal = neutral_groove_runs(1)
    following, untaught = tmp_path / "next.csv", tmp_path / "untaught.csv"
    assert main(["compensate", "--method", "twin", "--ideal", str(groove), "--forces-from", str(nominal),
                 "--out", str(following)]) == 0
    assert main(["compensate", "--method", "twin", "--ideal", str(groove), "--out", str(untaught)]) == 0
    record = read_record(following)
    assert record is not None and record.method == "twin"
    measured = read_run(nominal).forces
    assert measured is not None  # the record holds the forces the run measured, at the ideal's samples
    assert np.max(np.abs(record.f_used_n[:, 2])) == pytest.approx(np.max(np.abs(measured.values[:, 2])), rel=0.05)
    before = _true_miss_mm(nominal, groove)
    after = _true_miss_mm(_form(following, tmp_path / "next_run"), groove)
    model = _true_miss_mm(_form(untaught, tmp_path / "untaught_run"), groove)
    assert after <= 0.25 * before
    assert after <= 0.5 * model


def test_a_run_that_cannot_give_the_next_command_is_refused(neutral_groove_runs, groove: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    nominal = neutral_groove_runs(1)
    small, large = tmp_path / "small.csv", tmp_path / "large.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "30", "--depth-mm", "2", "--out", str(small)]) == 0
    assert main(["path", "--shape", "cone", "--top-width-mm", "80", "--depth-mm", "8", "--out", str(large)]) == 0
    capsys.readouterr()
    out = tmp_path / "next.csv"
    cases = [
        (["--method", "twin", "--ideal", str(large)], "expected a run of that part"),  # another program, longer
        (["--method", "twin", "--ideal", str(small)], "expected a run of that part"),  # another, shorter
        (["--method", "formula", "--ideal", str(groove)], "expected --method twin without --method formula"),
        (["--method", "twin", "--ideal", str(groove), "--yaw-deg", "30"], "without --yaw-deg 30.0"),
        (["--method", "twin", "--ideal", str(groove), "--force-model", "isf"], "without --force-model isf"),
        (["--method", "twin"], "needs --ideal PART.csv"),
    ]
    for extra, said in cases:
        argv = ["compensate", "--forces-from", str(nominal), "--out", str(out), *extra]
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert said in err and "Traceback" not in err, err
        assert not out.exists()
    # a program of the same length moved 10 mm: not a compensation of that path
    moved = tmp_path / "moved.csv"
    lines = groove.read_text(encoding="utf-8").splitlines()
    z = lines[0].split(",").index("z_mm")
    rows = [line.split(",") for line in lines[1:]]
    for r in rows:
        r[z] = f"{float(r[z]) - 10.0:.4f}"
    moved.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n", encoding="utf-8")
    assert main(["compensate", "--method", "twin", "--ideal", str(moved), "--forces-from", str(nominal),
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "mm (rms) from --ideal" in err and "expected a run of that part" in err
    assert main(["compensate", "--method", "twin", "--ideal", str(groove), "--forces-from", str(tmp_path / "none"),
                 "--out", str(out)]) == 2
    assert not out.exists()


def test_a_controller_s_log_at_its_own_rate_gives_the_same_next_command(neutral_groove_runs, groove: Path,
                                                                        tmp_path: Path) -> None:
    """The run's commanded stream as a controller logs it (every 12 ms, its stops included) instead of the program's
    samples: each ideal sample is placed by the share of the path travelled, and the command comes out the same."""
    from dataclasses import replace

    from twin.base.signals import interp_rows
    from twin.runs.format import Stream
    from twin.runs.write import write_run

    nominal = neutral_groove_runs(1)
    run = read_run(nominal)
    t_log = np.arange(run.commanded.t_s[0], run.commanded.t_s[-1], 0.012)
    logged = replace(run, commanded=Stream(t_log, interp_rows(t_log, run.commanded.t_s, run.commanded.values)))
    write_run(tmp_path / "logged", logged)
    commands = []
    for source, out in ((nominal, tmp_path / "a.csv"), (tmp_path / "logged", tmp_path / "b.csv")):
        assert main(["compensate", "--method", "twin", "--ideal", str(groove), "--forces-from", str(source),
                     "--out", str(out)]) == 0
        commands.append(read_commanded_csv(out).values)
    assert len(read_run(tmp_path / "logged").commanded.t_s) != len(commands[0])
    apart_mm = 1e3 * np.sqrt(np.mean(np.sum((commands[1] - commands[0]) ** 2, axis=1)))
    assert apart_mm < 0.05, apart_mm


def test_the_forces_are_taken_as_the_sheet_pushed_not_as_a_miscalibrated_sensor_read_them(
        neutral_groove_runs, groove: Path) -> None:
    """A run whose F/T sensor read with a bias, a gain and cross-talk, and a model file that carries them (as `learn`
    or `discrepancy` finds them): the next command is the one the true forces give."""
    from dataclasses import replace

    from twin.analysis.next_part import next_command
    from twin.analysis.resolve import spec_for_run
    from twin.runs.format import Stream
    from twin.sim.instruments import Instruments

    run = read_run(neutral_groove_runs(1))
    assert run.forces is not None
    sensor = Instruments(force_bias_n=(40.0, -25.0, 60.0), force_gain=(1.05, 0.97, 1.08),
                         force_crosstalk=(0.02, -0.01, 0.0, 0.03, 0.01, 0.0))
    reading = sensor.force_reading(run.forces.values)
    assert np.allclose(sensor.force_from_reading(reading), run.forces.values)
    read = replace(run, forces=Stream(run.forces.t_s, reading))
    ideal = read_commanded_csv(groove)
    plain = spec_for_run(run)
    calibrated = plain.replace(effects=plain.effects.with_instruments(sensor))
    truth = next_command(run, ideal.t_s, ideal.values, plain.build())
    carried = next_command(read, ideal.t_s, ideal.values, calibrated.build())
    ignored = next_command(read, ideal.t_s, ideal.values, plain.build())
    apart_mm = [1e3 * float(np.sqrt(np.mean(np.sum((c.p_cmd_sheet_m - truth.p_cmd_sheet_m) ** 2, axis=1))))
                for c in (carried, ignored)]
    assert apart_mm[0] < 1e-3 < 0.02 < apart_mm[1], apart_mm
    assert np.allclose(carried.f_measured_n, truth.f_measured_n)
