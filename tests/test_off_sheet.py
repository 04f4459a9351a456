"""`compensate` warns where its twin leaves the tool off the sheet the ideal path is in (`twin.analysis.off_sheet`).

The counts the CHANGELOG gives (the KR 210's and the IRB 6640's law-2 groove commands learned from a cone) are what
`compensate` printed for those commands (`experiments/online_other_part.py OUT --plant-set sheet_law=2` makes them);
here the rule itself, on paths written in the test, and the task's wiring.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.analysis.off_sheet import IN_SHEET_M, OFF_SHARE, off_sheet_warning
from twin.cli import main
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.runs.write import write_path_csv


def _pass(n: int = 200, depth_m: float = 3e-3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A straight pass `depth_m` into the sheet, 1 mm apart, pressed with 800 N: (t [s], p [m], f [N])."""
    t = 0.03 * np.arange(n)
    p = np.column_stack([1e-3 * np.arange(n), np.zeros(n), np.full(n, -depth_m)])
    f = np.tile([-80.0, 0.0, 800.0], (n, 1))
    return t, p, f


def test_samples_without_force_in_the_sheet_are_named_with_the_first() -> None:
    quoted("learning.md", "where the ideal path is more than", 1)[0].check(1e3 * IN_SHEET_M)  # the page's is the rule's
    t, p, f = _pass()
    f[120:127] = 0.0  # a hump: the twin's tool off the sheet for seven samples
    f[150, 2] = 0.9 * OFF_SHARE * 800.0  # and one all but off
    sentence = off_sheet_warning(t, p, f)
    assert sentence is not None
    assert "at 8 of the 200 samples" in sentence and f"first at {t[120]:.2f} s" in sentence
    assert "(120.0, 0.0, -3.0) mm" in sentence


def test_a_path_pressed_all_along_or_out_of_the_sheet_is_not_named() -> None:
    t, p, f = _pass()
    f[:, 2] *= np.linspace(0.5, 1.5, len(t))  # the force varies, never nil
    assert off_sheet_warning(t, p, f) is None
    t, p, f = _pass(depth_m=0.5 * IN_SHEET_M)  # barely in the sheet: first contact, not a miss
    f[50:60] = 0.0
    assert off_sheet_warning(t, p, f) is None
    f[:] = 0.0
    assert off_sheet_warning(t, _pass()[1] * np.array([1.0, 1.0, -1.0]), f) is None  # above the sheet


def test_compensate_prints_the_warning_and_writes_the_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """The task passes its twin's forces to the rule and prints its sentence as a warning; the command is written
    (the sheet may be right). Without the rule's sentence, none: the default twin keeps the groove's first passes
    pressed."""
    path = groove_path()
    keep = path.pass_index <= 2
    ideal = write_path_csv(ToolPath(path.t_s[keep], path.p_sheet_m[keep], path.pass_index[keep],
                                    path.direction[keep]), tmp_path / "ideal.csv")
    argv = ["compensate", "--method", "twin", "--ideal", str(ideal)]
    assert main([*argv, "--out", str(tmp_path / "plain.csv")]) == 0
    assert "off the sheet" not in capsys.readouterr().err
    seen = []

    def rule(t_s: np.ndarray, p_ideal_sheet_m: np.ndarray, f_sheet_n: np.ndarray) -> str:
        seen.append((len(t_s), p_ideal_sheet_m.shape, f_sheet_n.shape))
        return "the test's sentence: off the sheet"

    monkeypatch.setattr("twin.apps.tasks.compensate.off_sheet_warning", rule)
    assert main([*argv, "--out", str(tmp_path / "warned.csv")]) == 0
    assert "warning: the test's sentence: off the sheet" in capsys.readouterr().err
    assert seen == [(int(keep.sum()), (int(keep.sum()), 3), (int(keep.sum()), 3))]
    assert (tmp_path / "warned.csv").is_file()
