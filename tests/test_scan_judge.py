"""The part scan as the judge of a round's ambiguity (`twin.analysis.discrepancy.scan`), and the floor's scan bias.

The judge's rule is tested on misses this test writes (the replays are stood in for): which part a candidate
forms is the replay's business, tested on the plant in `tests/test_plant_changes.py` (`held-out-6`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from twin.analysis.discrepancy import scan
from twin.analysis.discrepancy.floor import Floor, mean_floor
from twin.analysis.discrepancy.selection import Candidate, Step
from twin.errors import InputError
from twin.sim.effects import Effects

SPREAD_M = 0.08e-3
BIAS_M = -0.5e-3
SOFTER, FRAME = "force_scale", "frame_compliance"


def _step() -> Step:
    fit: Any = None
    won = Candidate(SOFTER, 1.0, 0.6, 0.6, 10.0, False, fit)
    close = Candidate(FRAME, 0.9, 0.55, 0.55, 9.0, False, fit)
    return Step((won, close), SOFTER, (FRAME,))


def _judge(monkeypatch: pytest.MonkeyPatch, softer_mm: float, frame_mm: float) -> scan.ScanVerdict:
    """The scan missed by the floor's bias plus `softer_mm` where the twin forms the softer sheet's part, by the bias
    plus `frame_mm` where it forms the frame's (a Gaussian scatter of the floor's spread about each)."""
    rng = np.random.default_rng(7)
    scatter = rng.normal(0.0, 0.5 * SPREAD_M, 4000)
    scatter -= scatter.mean()

    def increment(fit: Any, families: Any, name: str, ctx: Any, lenient: bool = False) -> dict[str, float]:
        return {"force_scale": 0.85} if name == SOFTER else {"frame_compliance": 0.4}

    def miss(model: Any, effects: Effects) -> np.ndarray:
        extra = frame_mm if effects.get("frame_compliance") > 0 else softer_mm
        return BIAS_M + 1e-3 * extra + scatter

    monkeypatch.setattr(scan, "effect_increment", increment)
    monkeypatch.setattr(scan, "scan_miss", miss)
    return scan.judge(None, Effects(), _step(), {}, None, BIAS_M, SPREAD_M)  # type: ignore[arg-type]


def test_the_scan_prefers_the_candidate_whose_part_it_shows(monkeypatch: pytest.MonkeyPatch) -> None:
    verdict = _judge(monkeypatch, softer_mm=0.25, frame_mm=0.02)
    assert verdict.chosen == FRAME, verdict
    assert verdict.miss_mm[SOFTER] == pytest.approx(0.25, abs=0.01)
    assert verdict.miss_mm[FRAME] < scan.SCAN_LEAD * verdict.miss_mm[SOFTER]


def test_the_scan_keeps_the_winner_where_it_shows_no_change(monkeypatch: pytest.MonkeyPatch) -> None:
    """The winner's part within the floor's spread of the scan: nothing to judge, however the other fares."""
    assert _judge(monkeypatch, softer_mm=0.5 * scan.SCAN_SEEN * 1e3 * SPREAD_M, frame_mm=0.0).chosen is None


def test_the_scan_keeps_the_winner_where_the_other_is_not_clearly_better(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _judge(monkeypatch, softer_mm=0.25, frame_mm=0.23).chosen is None
    assert _judge(monkeypatch, softer_mm=0.02, frame_mm=0.25).chosen is None


def test_the_floor_carries_its_scan_bias_through_the_model_file() -> None:
    floor = Floor({"position": 1.0}, {"position": 0.5}, ("a",), {}, BIAS_M, SPREAD_M)
    again = Floor.from_json(floor.to_json(), "cell.json")
    assert again.scan_bias_m == pytest.approx(BIAS_M) and again.scan_spread_m == pytest.approx(SPREAD_M)
    plain = Floor.from_json(Floor({"position": 1.0}, {"position": 0.5}).to_json(), "cell.json")
    assert plain.scan_bias_m is None and plain.scan_spread_m is None
    both = mean_floor([floor, Floor({"position": 3.0}, {"position": 0.5}, ("b",), {}, 2 * BIAS_M, 3 * SPREAD_M)])
    assert both.scan_bias_m == pytest.approx(1.5 * BIAS_M) and both.scan_spread_m == pytest.approx(2 * SPREAD_M)


@pytest.mark.parametrize(("entry", "words"), [
    ({"scan_bias_mm": -0.5}, "expected both or neither"),
    ({"scan_bias_mm": -0.5, "scan_spread_mm": -0.1}, "floor.scan_spread_mm = -0.1"),
    ({"scan_bias_mm": "deep", "scan_spread_mm": 0.1}, "floor.scan_bias_mm = 'deep'"),
    ({"scan_bias_mm": float("nan"), "scan_spread_mm": 0.1}, "floor.scan_bias_mm = nan"),
])
def test_a_bad_scan_bias_is_refused_naming_the_file_and_key(entry: dict[str, Any], words: str) -> None:
    good = Floor({"position": 1.0}, {"position": 0.5}).to_json()
    with pytest.raises(InputError, match=r"cell\.json") as caught:
        Floor.from_json({**good, **entry}, "cell.json")
    assert words in str(caught.value)


def test_the_judges_constants_are_as_the_docs_say() -> None:
    flat = " ".join((Path(__file__).resolve().parents[1] / "docs" / "discrepancy.md").read_text().split())
    for name, value in (("SCAN_LEAD", scan.SCAN_LEAD), ("SCAN_SEEN", scan.SCAN_SEEN)):
        said = re.search(rf"`{name}` = ([0-9.]+)", flat)
        assert said is not None and float(said.group(1)) == pytest.approx(value), name
