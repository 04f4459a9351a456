"""Find where the twin and a measured run disagree, name the effects, add them, say what is left.

1. Find: replay the run with the twin as given; residuals of tool tip, force and part profile, normalised by
   the noise estimated from the data (`residuals`). The gap is significant when the reduced chi-square of any
   stream exceeds 1 + CHI2_MARGIN plus five standard errors (`significance`).
2. Name: the effect families (`families.FAMILIES`, vector parameters) are fitted over the linearised replay
   (`context`) by least squares and chosen by forward selection on held-out error and BIC (`selection`).
   Every family that explains a significant held-out share of the gap is named, with its explained fraction,
   parameters and their standard errors. The verdict names the first one when some family explains at least
   MEANINGFUL_SHARE of the excess over noise; otherwise it is `unexplained`: then what the families could
   take is small against the unexplained rest, and naming it would be a guess. A family is named only when its
   evidence is consistent (`consistency`): its own stream shows a gap, and what the named families leave keeps
   no more than a small share of the tool-tip's or the forces' slow structure; otherwise `unexplained`, and the
   words say which family would have been named and why not. Against a learned cell's floor, a run whose excess
   does not rise above it (`Floor.observable`) is `none` before any family is fitted: a change below the floor
   is not observable on this run, and the words give the size that would be.
3. Add: families that map onto an effect of the vocabulary (`twin.sim.effects`) are written into the twin's
   effects, which a model file carries to `replay --model`; when all named families do, the twin is replayed
   with them and refitted once (the linearisation is then exact to second order) and the gap after is that
   replay's.
4. Say what is left: the remainder's signature in words (`signature`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from twin.analysis.discrepancy import consistency
from twin.analysis.discrepancy.carry import NamedEffect, into_effects, named_effects
from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.effect_model import context
from twin.analysis.discrepancy.families import FAMILIES, Family
from twin.analysis.discrepancy.fitting import Fitter
from twin.analysis.discrepancy.floor import Floor
from twin.analysis.discrepancy.residuals import ResidualModel, measured_streams
from twin.analysis.discrepancy.scan import ScanVerdict, judge
from twin.analysis.discrepancy.selection import Step, forward_select
from twin.analysis.discrepancy.signature import describe_remainder
from twin.analysis.discrepancy.significance import (
    excess_over_noise,
    is_significant,
    reduced_chi2,
)
from twin.runs.format import Run
from twin.sim.effects import Effects
from twin.sim.spec import TwinSpec

MEANINGFUL_SHARE = 0.25  # a family explaining less than a quarter of the excess does not make a verdict
FLOOR_SHARE_MIN = 0.1  # over a floor, shares are of the excess above it, taken as at least this share of the run's


@dataclass(frozen=True)
class DiscrepancyResult:
    """Outcome of the workflow.

    Attributes:
        effects: The twin's effects after the search (the effect vocabulary, for a model file).
        found: Families named, in order (empty for `none` and `unexplained`).
        verdict: The first named family, `none` or `unexplained`.
        named: The named families with parameters, uncertainties and explained fractions.
        partial: Families that explain a significant but not meaningful share (when `unexplained`).
        explained_fraction: Share of the excess over noise the named families explain together.
        model_complete: Whether `effects` carries every named family (then `gap_after` is its replay).
        remainder: Signature of what is left (`signature.describe_remainder`).
        rounds: The selection rounds.
        floor: The learned cell's floor the run was judged against (`Floor.to_json`), empty for none.
        scan: Family -> its rms miss of the part scan less the floor's bias [mm] where the scan judged the first
            round's ambiguity (`scan.judge`), empty where it did not.
    """

    effects: Effects
    found: tuple[str, ...]
    verdict: str
    named: tuple[NamedEffect, ...]
    partial: tuple[NamedEffect, ...]
    explained_fraction: float
    model_complete: bool
    remainder: dict[str, Any]
    rounds: tuple[Step, ...]
    chi2_before: dict[str, float]
    chi2_after: dict[str, float]
    gap_before: dict[str, float]
    gap_after: dict[str, float]
    noise: dict[str, float]
    confidence: float
    residual_before: dict[str, np.ndarray] = field(repr=False)
    residual_after: dict[str, np.ndarray] = field(repr=False)
    consistency: dict[str, Any] = field(default_factory=dict)
    floor: dict[str, Any] = field(default_factory=dict)
    scan: dict[str, float] = field(default_factory=dict)


def gap(streams: dict[str, np.ndarray]) -> dict[str, float]:
    """Rms of the residual norm: `position_rms_mm`, `force_rms_n`, `profile_rms_mm` (nan when absent)."""
    def rms(values: np.ndarray | None) -> float:
        if values is None:
            return float("nan")
        return float(np.sqrt(np.mean(np.sum(np.atleast_2d(values.T).T ** 2, axis=-1))))
    return {
        "position_rms_mm": 1e3 * rms(streams["position"]),
        "force_rms_n": rms(streams.get("force")),
        "profile_rms_mm": 1e3 * rms(streams.get("profile")) if "profile" in streams else float("nan"),
    }


def find_discrepancy(
    run: Run,
    spec: TwinSpec | None = None,
    *,
    candidates: tuple[str, ...] | None = None,
    progress: Callable[[str], None] | None = None,
    floor: Floor | None = None,
) -> DiscrepancyResult:
    """Run the workflow on one run.

    Args:
        run: Measured run (truth.json is never read).
        spec: The twin as given (robot, process and force model, K_q, and the effects it already has, e.g. from
            an earlier model file); placed at the run's placement. None: the default cell.
        candidates: Family names to try (default: all of `FAMILIES` the run's streams allow).
        progress: Called with each stage's name as it starts (to show a long search moving).
        floor: What the learned cell `spec` leaves on its own clean runs (`twin.analysis.discrepancy.floor`): a
            family's share is of the excess over it, the structure it leaves is above it; a run within it is
            `none` (`Floor.observable`). None: the noise alone.
    """
    spec = spec or TwinSpec()
    start = spec.effects
    model = ResidualModel(run, spec)
    ctx = context(model, start)
    noise = model.noise
    sigma = noise.by_stream
    measured = measured_streams(run)
    fitter = Fitter(ctx, measured, sigma, model.folds())
    sizes = {s: fitter.raw[s].size for s in fitter.streams}
    families = {n: f for n, f in FAMILIES.items() if f.applicable(ctx) and (candidates is None or n in candidates)}
    chi2_before = reduced_chi2(fitter.raw, sigma)
    excess = excess_over_noise(fitter.base, list(sizes.values()))
    significant = is_significant(chi2_before, dict(sizes))
    # a run within the learned cell's floor shows no change, whatever a family would take of it (issue #47)
    within_floor = significant and floor is not None and not floor.observable(excess, sizes)
    significant = significant and not within_floor
    if progress is not None:
        progress("selection")
    offsets = None if floor is None else floor.offsets(sizes)
    fit, steps = forward_select(fitter, list(families.values()), excess, sizes, offsets=offsets) if significant else (
        fitter.fit([]), ())
    accepted = [s.accepted for s in steps if s.accepted is not None]
    if any(families[a].carried_by_learning for a in accepted[1:]):  # carried by the robot learner: first, or not
        families = {n: f for n, f in families.items() if not f.carried_by_learning or n == accepted[0]}
        fit, steps = forward_select(fitter, list(families.values()), excess, sizes, offsets=offsets)
    scanned = _judge_by_scan(model, start, steps, families, ctx, floor)
    if scanned.chosen is not None:  # the part scan prefers an ambiguous candidate: the winner is not tried again
        families = {n: f for n, f in families.items() if n != steps[0].accepted}
        fit, steps = forward_select(fitter, list(families.values()), excess, sizes, offsets=offsets)
    named = named_effects(steps, fit, families)
    # over a learned cell's floor, a family's share is of the excess above it (the selection is judged against the
    # whole excess: against the part above the floor, families soak up the floor's reversal transients)
    share = 1.0 if floor is None else excess / max(excess - floor.excess_on(sizes), FLOOR_SHARE_MIN * excess)
    meaningful = any(n.explained_fraction * share >= MEANINGFUL_SHARE for n in named)
    verdict = "none" if not significant else (named[0].name if meaningful else "unexplained")
    explained = 1.0 - excess_over_noise(fit.residual, list(sizes.values())) / excess if (
        verdict != "unexplained" and named) else 0.0
    if verdict in ("none", "unexplained"):
        effects, remainder, complete = start, dict(fitter.raw), True
    else:
        carried = into_effects(
            ctx, model, start, fit, named, families, lambda c: Fitter(c, measured, sigma, model.folds()), sizes,
            excess, progress, offsets)
        effects, named, remainder, complete = carried.effects, carried.named, carried.remainder, carried.complete
        steps = steps + carried.steps
        verdict = named[0].name
        explained = 1.0 - excess_over_noise(fitter.stack(remainder), list(sizes.values())) / excess
    checked: dict[str, Any] = {}
    if verdict not in ("none", "unexplained"):
        base = None if floor is None else {k: floor.structure.get(k, 0.0) * v.size for k, v in fitter.raw.items()}
        outcome = consistency.check(fitter.raw, remainder, sigma, families[named[0].name].acts_on, base)
        checked = {"family": verdict, "explained_fraction": float(explained), **outcome.summary()}
        if not outcome.consistent:  # the family does not account for the gap: say so, describe the raw gap
            verdict, effects, remainder, complete, explained = "unexplained", start, dict(fitter.raw), True, 0.0
    found = tuple(n.name for n in named) if verdict not in ("none", "unexplained") else ()
    signature = describe_remainder(ctx, remainder, sigma, found)
    if checked and not found:
        signature["words"] += "; " + _not_named(checked)
    if within_floor and floor is not None:
        signature["words"] = floor.unobservable_words(excess, sizes, sigma) + "; " + signature["words"]
    return DiscrepancyResult(
        effects=effects, found=found, verdict=verdict, named=tuple(named) if found else (),
        partial=tuple(named) if not found else (), explained_fraction=float(explained),
        model_complete=complete, remainder=signature, rounds=steps, chi2_before=chi2_before,
        chi2_after=reduced_chi2(remainder, sigma), gap_before=gap(fitter.raw),
        gap_after=gap(remainder) if found else gap(fitter.raw), noise=noise.summary(),
        confidence=_confidence(steps), residual_before=dict(fitter.raw), residual_after=remainder,
        consistency=checked, floor={} if floor is None else floor.to_json(), scan=scanned.miss_mm,
    )


def _judge_by_scan(model: ResidualModel, start: Effects, steps: tuple[Step, ...], families: dict[str, Family],
                   ctx: Context, floor: Floor | None) -> ScanVerdict:
    """The part scan's verdict on the first round's ambiguity (`scan.judge`), where the floor has its scan bias."""
    if (floor is None or floor.scan_bias_m is None or floor.scan_spread_m is None or not steps
            or not steps[0].ambiguous_with):
        return ScanVerdict(None, {})
    return judge(model, start, steps[0], families, ctx, floor.scan_bias_m, floor.scan_spread_m)


def _not_named(checked: dict[str, Any]) -> str:
    """Why the first family was not named: the streams whose gap or slow structure it leaves."""
    why = [f"the families named with it leave a slow structure in the {s} stream, which shows no gap" if c["made"]
           else f"it leaves {c['structure_left']:.0%} of the {s} stream's slow structure"
           for s, c in checked["streams"].items() if c["failed"]]
    why += [f"the {s} stream it acts on shows no gap" for s in checked["no_gap"]]
    return f"{checked['family']} would explain {checked['explained_fraction']:.0%}, but " + " and ".join(why)


def _confidence(steps: tuple[Step, ...]) -> float:
    """The first round's winner's score over its own plus the runner-up's (1 when nothing competes)."""
    first = steps[0].candidates if steps else ()
    if not (first and first[0].gain > 0):
        return 1.0
    runner = max((c.gain for c in first[1:]), default=0.0)
    return float(first[0].gain / (first[0].gain + max(runner, 0.0)))
