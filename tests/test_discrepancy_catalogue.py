"""The discrepancy search on the catalogue of hidden effects in forms the library does not make.

`tests/discrepancy_catalogue.py` builds the cases (data edits written there, never through the effect
vocabulary or the search's families). The normal suite runs a handful of them; the slow test runs the whole
catalogue (64 cases over 11 families, combinations and made-up effects, 20 clean runs and 3 dynamic-plant
runs) and prints the confusion matrix (`make test-slow`; `python -m tests.discrepancy_catalogue --out
confusion.json` writes it).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from discrepancy_catalogue import (
    DYNAMIC_CASES,
    SINGLE,
    describes,
    evaluate,
    make_case,
    make_dynamic_case,
    right_first,
)

from twin.analysis.discrepancy.search import find_discrepancy

NAMED_RATE = 0.95  # the right family named first
EXPLAINED = 0.70  # share of the excess over noise the named families explain, where named
# Share of the named runs that must reach EXPLAINED: all of them (min 0.89). From commit 770d28d (joint friction,
# field) until the twin's tool stuck on the sheet at reversals (twin.process.force.tool_friction), two clamp-force
# rises stayed at 0.59: their remainder was at the reversals, where the twin's force flipped in one sample.
EXPLAINED_RATE = 1.0
FAST_SEEDS = (1, 2, 44, 57, 64)  # direction-dependent compliance, lost motion, a combination, made-up, clean


def test_catalogue_cases_are_reproducible_and_hide_what_they_say() -> None:
    run_a, truth_a = make_case(2)
    run_b, truth_b = make_case(2)
    assert truth_a == truth_b and truth_a.families == ["lost_motion"]
    assert (run_a.tracker.values == run_b.tracker.values).all()
    clean, truth = make_case(64)
    assert truth.expected == "none"
    assert truth_a.expected == "lost_motion" and 3.0 <= truth_a.multiples[0] <= 30.0
    assert clean.forces is not None


@pytest.fixture(scope="module")
def fast() -> dict[str, Any]:
    return evaluate(list(FAST_SEEDS))


def test_fast_catalogue_names_the_right_family_first_and_explains_it(fast: dict[str, Any]) -> None:
    for row in fast["rows"]:
        assert right_first(row), row
        if row["kind"] in ("single", "combo"):
            assert row["explained_fraction"] >= EXPLAINED, row


def test_fast_catalogue_describes_the_made_up_effect(fast: dict[str, Any]) -> None:
    made_up = [row for row in fast["rows"] if row["kind"] == "made_up"]
    assert made_up and all(row["signature_describes"] for row in made_up), made_up


@pytest.mark.slow
def test_whole_catalogue_meets_the_issue_targets(tmp_path: Path) -> None:
    doc = evaluate(list(range(64)) + list(range(64, 84)), len(DYNAMIC_CASES))
    (tmp_path / "confusion.json").write_text(json.dumps(doc, indent=1, default=float))
    print(json.dumps(doc["confusion"], indent=1))
    rows = doc["rows"]
    families = {f for row in rows for f in row["truth"]}
    assert len([r for r in rows if r["kind"] in ("single", "combo")]) >= 56 and families >= set(SINGLE)
    assert doc["named_first_rate"] >= NAMED_RATE, doc["confusion"]
    assert doc["named_explained_at_least_70"] >= EXPLAINED_RATE * doc["named_runs"], doc["min_named_explained_fraction"]
    assert doc["clean_runs"] >= 20 and doc["clean_none"] == doc["clean_runs"], doc["confusion"]
    assert doc["made_up_unexplained"] == doc["made_up_runs"] == doc["made_up_described"]
    # dynamic-plant runs are reported, not scored: their dynamics are outside every family
    dynamic = [r for r in rows if r["kind"] == "dynamic"]
    assert len(dynamic) == len(DYNAMIC_CASES)
    # the neutral run of the independent plant (its own sheet): unexplained, and the remainder is its force model's,
    # an offset flipping with the travel in the x force (the fast test below keeps the old reversal transient
    # as a strict xfail)
    assert dynamic[0]["verdict"] == "unexplained", dynamic[0]
    assert "force x:" in dynamic[0]["remainder"] and "flips with the travel" in dynamic[0]["remainder"], dynamic[0]


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="measured on the dependent plant; on the independent plant (its own sheet) the "
                   "verdict is still unexplained, but the remainder is the force model's (0.8 mm, a 0.24 Hz x "
                   "oscillation and a +/-279 N x offset flipping with the travel), not a transient at the reversals")
def test_neutral_dynamic_run_is_unexplained_with_a_transient_at_the_reversals() -> None:
    """The plant's arm dynamics at the reversals are in no family: said as such, and placed in time."""
    run, truth = make_dynamic_case(0)
    result = find_discrepancy(run)
    assert result.verdict == "unexplained", result.remainder["words"]
    assert describes(result.remainder, truth.made_up), result.remainder["words"]
    # 0.052 mm: within twice the tracker noise's 3-D rms, but above what noise alone leaves
    assert result.gap_before["position_rms_mm"] <= 2.0 * 3**0.5 * 0.02
