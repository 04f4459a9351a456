"""The same input twice is refused by name (issue #46): a single-valued option typed twice (argparse would keep the
last in silence), a run learned twice, a run held out from itself, an effect given twice; options meant to repeat
still do."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_refusal import refused

from twin.cli import main


def test_a_single_valued_option_twice_is_refused_with_both_values(
        tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "c.csv"
    refused(["compensate", "--method", "twin", "--ideal", str(tiny), "--tol-mm", "0.01", "--tol-mm=0.5",
             "--out", str(out)], capsys, "--tol-mm given twice", "'--tol-mm 0.01'", "'--tol-mm=0.5'", never=(out,))
    # an abbreviation is the same option (argparse takes unambiguous prefixes)
    refused(["compensate", "--method", "twin", "--ideal", str(tiny), "--max-iter", "3", "--max-it", "4",
             "--out", str(out)], capsys, "--max-iter given twice", never=(out,))
    refused(["path", "--yaw-deg", "0", "--yaw-deg", "30", "--out", str(out)], capsys, "--yaw-deg given twice",
            never=(out,))


def test_repeatable_options_and_negative_values_still_pass(tmp_path: Path) -> None:
    # two different effects (an append option) and a negative number after a three-valued option
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--effect", "force_scale=1.1", "--effect",
                 "tracker_drift=0.001", "--out", str(tmp_path / "run")]) == 0
    assert main(["path", "--origin-mm", "1700", "-5", "500", "--yaw-deg=-5", "--no-reach-check",
                 "--out", str(tmp_path / "p.csv")]) == 0


def test_the_same_effect_twice_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    refused(["lab", "--scenario", "nominal", "--seed", "1", "--effect", "force_scale=1.1", "--effect",
             "force_scale=1.2", "--out", str(out)], capsys, "--effect force_scale given twice", never=(out,))


def test_a_run_twice_is_refused_by_learn_and_discrepancy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "run"
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--out", str(run)]) == 0
    model = tmp_path / "m.json"
    refused(["learn", str(run), str(tmp_path / "." / "run"), "--write-model", str(model)], capsys,
            "given twice", never=(model,))
    refused(["discrepancy", str(run), "--held-out", str(run) + "/", "--model-out", str(model)], capsys,
            "--held-out", "is the run", never=(model,))
