"""The discrepancy search on the held-out set (`tests/discrepancy_heldout.py`): forms the library lacks come out
`unexplained`, the library's own forms (written in the test) are named, clean runs `none`.

The fast tests run three development cases and the consistency check on synthetic remainders; the slow tests
rerun both sets: docs/discrepancy.md shows both confusion matrices as they come out, the frozen threshold is the
one the development set gives, and on the TEST set issue #28's goals for inside forms and clean runs hold. Its
goal for outside forms (>= 90 % `unexplained`) is not met (10 / 14): a strict xfail says so, and turns red when
it is met, so that the docs and this file are updated.
"""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from discrepancy_heldout import (
    BEGIN,
    END,
    OUTSIDE,
    cases,
    chosen_threshold,
    evaluate,
    markdown,
    meets_goals,
)

from twin.analysis.discrepancy import consistency

ROOT = Path(__file__).resolve().parents[1]
DEVELOPMENT_RULE_SINCE_47 = 0.05  # what `chosen_threshold` gives on the development set since #47's families
OUTSIDE_REACHED = 10 / 14  # the test set's outside forms `unexplained` when first run (issue #28 asks for 0.9)


def test_heldout_module_imports_neither_the_effects_nor_the_families_nor_the_catalogue() -> None:
    tree = ast.parse((ROOT / "tests" / "discrepancy_heldout.py").read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)} | {
        a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert not any(m and (m.startswith("twin.sim.effects") or "families" in m or "catalogue" in m) for m in imported)
    assert len(OUTSIDE["development"]) + len(OUTSIDE["test"]) >= 10
    assert not set(OUTSIDE["development"]) & set(OUTSIDE["test"])
    dev, test = cases("development"), cases("test")
    assert not {c.base_seed for c in dev} & {c.base_seed for c in test}


def test_a_few_development_cases() -> None:
    """A drift is named; a jump (a drift would take 85 %) and a saturated F/T (a force scale would take 95 %, with
    no tool-tip gap) are `unexplained`, with why."""
    by_kind = {c.kind: c.index for c in cases("development")}
    doc = evaluate("development", [by_kind["tracker_drift"], by_kind["tracker_jump"], by_kind["force_saturation"]])
    verdicts = {r["kind"]: r for r in doc["rows"]}
    assert verdicts["tracker_drift"]["verdict"] == "tracker_drift"
    jump, saturated = verdicts["tracker_jump"], verdicts["force_saturation"]
    assert jump["verdict"] == "unexplained" and "position stream's slow structure" in jump["remainder"], jump
    assert saturated["verdict"] == "unexplained" and "shows no gap" in saturated["remainder"], saturated


def test_consistency_flags_a_step_left_and_passes_white_noise() -> None:
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 20.0, 1000)
    step = np.column_stack([0.2 * (t > 9.0), 0 * t, 0 * t])
    before = {"position": step + rng.normal(0, 0.02, (1000, 3))}
    fitted_drift = 0.2 * 11.0 / 20.0 + 0.2 * (t - 10.0) * 0.075
    left = {"position": before["position"] - np.column_stack([fitted_drift, 0 * t, 0 * t])}
    white = {"position": rng.normal(0, 0.02, (1000, 3))}
    sigma = {"position": 0.02}
    assert not consistency.check(before, left, sigma, ("position",)).consistent
    assert consistency.check(before, white, sigma, ("position",)).consistent
    assert consistency.check(white, white, sigma, ("position",)).no_gap == ("position",)


@pytest.fixture(scope="module")
def both_sets() -> tuple[dict[str, Any], dict[str, Any]]:
    return evaluate("development"), evaluate("test")


@pytest.mark.slow
def test_heldout_sets_are_as_the_docs_show_and_the_threshold_is_the_development_sets(
    both_sets: tuple[dict[str, Any], dict[str, Any]],
) -> None:
    development, test = both_sets
    # the development set's rule gave 0.07 when STRUCTURE_SHARE was frozen, before the test set was first run; with
    # the families #47 added it gives 0.05 (a one-sided wrist stiffness now taken by `tracker_clock` leaves 0.046).
    # The threshold stays frozen: chosen again after the test set was seen, it would no longer be held out.
    assert consistency.STRUCTURE_SHARE == 0.07 and chosen_threshold(development) == DEVELOPMENT_RULE_SINCE_47
    text = (ROOT / "docs" / "discrepancy.md").read_text()
    block = text[text.index(BEGIN):text.index(END)]
    assert markdown(development) in block and markdown(test) in block


@pytest.mark.slow
def test_heldout_test_set_names_inside_forms_and_keeps_clean_runs_clean(
    both_sets: tuple[dict[str, Any], dict[str, Any]],
) -> None:
    _, test = both_sets
    (named, inside), (none, clean) = test["inside_named_first"], test["clean_none"]
    assert named >= 0.95 * inside and none == clean, markdown(test)
    # not the goal (below): what the frozen search reached when the test set was first run, 10 / 14
    assert test["outside_unexplained"][0] >= OUTSIDE_REACHED * test["outside_unexplained"][1], markdown(test)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason="issue #28's goal, outside forms `unexplained` in >= 90 % of the test set, "
                   "is not met: 10 / 14 (a tracker scale error taken as a registration, a tracker lag as a tracker clock)")
def test_heldout_test_set_meets_the_issue_goals(both_sets: tuple[dict[str, Any], dict[str, Any]]) -> None:
    assert meets_goals(both_sets[1]), markdown(both_sets[1])
