"""Compensation on the dynamic twin (`twin.analysis.compensate_dynamic`, `compensate --dynamic`).

The servo here is written in the test (a slow loop, β 0.3, ζ 0.9, 8 ms delay: the tip lags its reference at the
square's corner stops by a few tenths of a millimetre); the quasi-static compensation cannot see that lag, the
dynamic iteration must take most of it out. With a rigid servo the dynamic twin's rest is the quasi-static one and
the iteration has nearly nothing to do.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from tests.test_dynamic_twin import square
from twin.analysis.compensate import compensate_twin
from twin.analysis.compensate_dynamic import compensate_dynamic
from twin.cli import main
from twin.errors import InputError
from twin.process.description import Process
from twin.sim.dynamic import ServoModel, simulate_dynamic
from twin.sim.model_file import write_model_file
from twin.sim.spec import TwinSpec

SLOW = ServoModel(0.3, 0.9, 0.008)
RIGID = ServoModel(math.inf, 1.0, 0.0)
#: The dynamic iteration's rms at most this share of the quasi-static command's on the dynamic twin [-].
LAG_LEFT = 0.3
#: A rigid servo's iteration moves the quasi-static command by less than this, rms [m] (a third of what the slow
#: servo's moves it by).
RIGID_MOVE_M = 0.1e-3


@pytest.fixture(scope="module")
def isf_twin():  # type: ignore[no-untyped-def]
    return TwinSpec(process=Process(force_model="isf")).build()


@pytest.fixture(scope="module")
def path() -> tuple[np.ndarray, np.ndarray]:
    return square(0.02, -5e-4, 0.0333, 0.5, 0.004)  # 20 mm square, 0.5 mm into the sheet, stops at the corners


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))


def test_the_dynamic_iteration_takes_out_a_slow_servos_lag(isf_twin, path) -> None:  # type: ignore[no-untyped-def]
    t, p = path
    start = compensate_twin(t, p, isf_twin)
    result = compensate_dynamic(t, p, isf_twin, SLOW, start=start)
    history = result.compensation.history_m
    assert history[0] > 5 * start.history_m[-1]  # the lag is there: the quasi-static command does not see it
    assert min(history) <= LAG_LEFT * history[0], [round(1e3 * h, 4) for h in history]
    # the command returned is the best one, and its residual is the dynamic twin's on it (nothing else scored)
    again = simulate_dynamic(isf_twin, t, result.compensation.p_cmd_sheet_m, SLOW)
    assert _rms(again.p_sheet_m - p) == pytest.approx(min(history), rel=1e-6)
    assert result.quasi_static is start and result.servo is SLOW and result.smoothing_s > 0


def test_a_rigid_servo_leaves_the_iteration_little_to_do(isf_twin, path) -> None:  # type: ignore[no-untyped-def]
    t, p = path
    result = compensate_dynamic(t, p, isf_twin, RIGID, max_iter=3)
    assert result.compensation.history_m[0] < 0.05e-3  # its rest is the quasi-static tip the start was made for
    moved = result.compensation.p_cmd_sheet_m - result.quasi_static.p_cmd_sheet_m
    assert _rms(moved) < RIGID_MOVE_M  # the command hardly moves (the slow servo's moves it by ~0.3 mm rms)
    assert result.smoothing_s == 0.0  # a rigid servo has no bandwidth to filter at


def test_bad_arguments_are_named(isf_twin, path) -> None:  # type: ignore[no-untyped-def]
    t, p = path
    with pytest.raises(InputError, match="max_iter = 0"):
        compensate_dynamic(t, p, isf_twin, SLOW, max_iter=0)
    with pytest.raises(InputError, match="the start command has shape"):
        compensate_dynamic(t, p, isf_twin, SLOW, start=compensate_twin(t[:50], p[:50], isf_twin))


def test_compensate_dynamic_on_the_command_line(tmp_path: Path, path, capsys: pytest.CaptureFixture[str]) -> None:  # type: ignore[no-untyped-def]
    t, p = path
    ideal = tmp_path / "square.csv"
    np.savetxt(ideal, np.column_stack([t, 1e3 * p]), delimiter=",", header="t_s,x_mm,y_mm,z_mm", comments="",
               fmt="%.6f")
    with_servo = write_model_file(tmp_path / "m.json", TwinSpec(process=Process(force_model="isf"),
                                                               dynamic_servo=SLOW))
    out = tmp_path / "cmd.csv"
    assert main(["compensate", "--method", "twin", "--model", str(with_servo), "--ideal", str(ideal), "--dynamic",
                 "--out", str(out), "--json", "-"]) == 0
    report = json.loads(capsys.readouterr().out)
    dynamic = report["dynamic"]
    assert main(["compensate", "--method", "twin", "--model", str(with_servo), "--ideal", str(ideal), "--dynamic",
                 "--out", str(tmp_path / "again.csv")]) == 0
    words = capsys.readouterr().out
    assert "dynamic twin: rms" in words and "predicted" in words
    assert dynamic["servo"] == SLOW.to_json() and dynamic["learning_filter_ms"] > 0
    assert report["predicted_residual_rms_mm"] <= LAG_LEFT * report["residual_rms_per_iteration_mm"][0]
    assert out.exists()
    # refused, named, and nothing written: a model without a servo, a method that is not the twin's
    without = write_model_file(tmp_path / "plain.json", TwinSpec(process=Process(force_model="isf")))
    for argv, words in ((["--method", "twin", "--model", str(without)], "plain.json carries no dynamic_servo"),
                        (["--method", "formula"], "--dynamic .* needs --method twin")):
        refused = tmp_path / "refused.csv"
        assert main(["compensate", *argv, "--ideal", str(ideal), "--dynamic", "--out", str(refused)]) == 2
        err = capsys.readouterr().err
        assert words.split(" .* ")[0] in err and words.split(" .* ")[-1] in err and "Traceback" not in err
        assert not refused.exists()


def test_the_pages_words_on_compensation_with_the_dynamic_twin_are_its_tables() -> None:
    page = (Path(__file__).resolve().parents[1] / "docs" / "dynamic-twin.md").read_text(encoding="utf-8")
    begin = page.index("<!-- dynamic-compensation:begin (generated by experiments/dynamic_compensation_study.py")
    block = page[begin:page.index("<!-- dynamic-compensation:end -->")]
    rows = [[c.strip() for c in line.split("|")[1:-1]] for line in block.splitlines() if line.startswith("| TX200")]
    named = ("quasi-static", "dynamic")
    comp = {(r[0], r[1]): r for r in rows if r[1] in named}
    both = {(r[0], r[1].removesuffix(", online on top")): r for r in rows if r[1].endswith(", online on top")}
    depth = [r for r in rows if r[1] not in named and not r[1].endswith(", online on top")]
    pair = lambda cell: [float(v) for v in cell.split("/")]  # noqa: E731
    first = lambda cell: pair(cell)[0]  # noqa: E731
    neutral, default = "TX200 groove, neutral knobs", "TX200 groove, plant's default knobs"
    said = quoted("dynamic-twin.md", "the quasi-static command with it\nreaches", 1)
    said += quoted("dynamic-twin.md", "and the dynamic command", 1) + quoted("dynamic-twin.md", "on the default-knob groove", 2)
    for quote, value in zip(said, (first(both[(neutral, "quasi-static")][3]), first(both[(neutral, "dynamic")][3]),
                                   first(both[(default, "quasi-static")][3]), first(both[(default, "dynamic")][3])),
                            strict=True):
        quote.check(value)
    said = quoted("dynamic-twin.md", "worse, the true tip from", 4)
    for quote, value in zip(said, (first(comp[(neutral, "quasi-static")][6]), first(comp[(neutral, "dynamic")][6]),
                                   first(comp[(default, "quasi-static")][6]), first(comp[(default, "dynamic")][6])),
                            strict=True):
        quote.check(value)
    assert first(both[(neutral, "quasi-static")][3]) <= 0.10  # "under issue #50's 0.10 mm"
    assert len(both) == 4
    cells = {key[0] for key in comp}
    grooves = {"TX200 groove, neutral knobs", "TX200 groove, plant's default knobs"}
    assert len(cells) == 4 and grooves < cells and len(comp) == 8 and len(depth) == 2
    for cell in cells:
        qs, dyn = comp[(cell, "quasi-static")], comp[(cell, "dynamic")]
        before, after = (float(v) for v in dyn[2].split("->"))
        if cell in grooves:  # "more than half off ... on both grooves"
            assert after < 0.5 * before, cell
        else:  # "a tenth to a sixth on the pyramids"
            assert 0.83 * before <= after <= 0.92 * before, cell
        assert 2 * float(qs[4]) <= float(dyn[4]) <= 30 * float(qs[4])  # "at two to twenty-odd times its wall"
        if cell in grooves:  # "worse"; "most of it at the reversals on the second"
            assert pair(dyn[6])[0] > pair(qs[6])[0] and pair(dyn[5])[0] > pair(qs[5])[0], cell
            if cell == default:
                assert pair(dyn[6])[1] - pair(qs[6])[1] > pair(dyn[6])[0] - pair(qs[6])[0]
            continue
        for col in (5, 6):  # "within a few hundredths of a millimetre" (pyramids)
            assert np.allclose(pair(dyn[col]), pair(qs[col]), atol=0.03, rtol=0), (cell, col)
        for r in (qs, dyn):  # "the true tip's mean height within 0.04 mm of the path above and below half depth"
            assert max(abs(v) for v in pair(r[7])) <= 0.04, r
            assert pair(r[6])[1] > pair(r[6])[0], r  # "largest within 5 mm of the corners"
    for r in depth:  # "the learned sheet's force follows the plant's by depth within 60 N"
        measured, twin = np.array([pair(c) for c in r[1:] if c != "-"]).T
        assert np.abs(twin - measured).max() <= 60.0, r
