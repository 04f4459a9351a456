"""Model selection among effect families: nested candidates, held-out error, an information criterion.

Forward selection. The current model starts empty. Each round every family not yet in it is fitted jointly
with it (`Fitter.fit`); a candidate's gain is the drop of the HELD-OUT error (fit on odd passes, scored on even
ones and back) and its share is that gain over the run's excess over noise. The best candidate enters when

- its held-out gain is at least ROUND_SHARE of the run's excess over noise (a family explaining less is not
  told apart from the noise estimate's own error of a few per cent, nor from the linearisation's), or, on a
  twin replayed with the effects already named, of the excess they leave (`of_rest`: a small second effect
  next to a large first one is then still found),
- its gain in the full-data sum of squares beats the BIC penalty, k log N for its k observable parameters,
- it makes no stream significantly worse (`significance.is_contradicted`): an effect of the robot or its
  sensors should agree with every stream. A candidate that does is still taken when its held-out gain is
  CONTRADICTED_LEAD times that of the best candidate that agrees with every stream (or none agrees): the
  family then explains most of the gap while one stream disagrees (e.g. forces and deflections edited by
  hand, the part profile not), and the report says which stream (`Candidate.contradicted`).

Against a learned cell's floor, each family's gain is counted above what it finds on the cell's own clean runs
(`offsets`: a lost-motion family soaking up the reversal transients a clean run has too is no evidence of play).

Candidates whose held-out gain reaches AMBIGUITY_RATIO of the best one's cannot be told apart by the held-out
error; among them the information criterion (BIC gain) picks the winner. Those that add less than ROUND_SHARE
once the winner is in explain the same thing: they are reported as ambiguous with it rather than guessed away.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from twin.analysis.discrepancy.families.base import Family
from twin.analysis.discrepancy.fitting import Fit, Fitter
from twin.analysis.discrepancy.significance import excess_over_noise, is_contradicted

ROUND_SHARE = 0.05
AMBIGUITY_RATIO = 0.8
CONTRADICTED_LEAD = 1.2
MAX_FAMILIES = 3


@dataclass(frozen=True)
class Candidate:
    """One family tried on top of the current model in one round."""

    name: str
    gain: float
    share: float
    share_of_rest: float
    bic_gain: float
    contradicted: bool
    fit: Fit


@dataclass(frozen=True)
class Step:
    """One round: the candidates in order of held-out gain, the family accepted (or None), ambiguities."""

    candidates: tuple[Candidate, ...]
    accepted: str | None
    ambiguous_with: tuple[str, ...]


def _chi2(fit: Fit, sizes: dict[str, int]) -> dict[str, float]:
    parts = np.split(fit.residual, np.cumsum(list(sizes.values()))[:-1])
    return {name: float(np.mean(part**2)) for name, part in zip(sizes, parts, strict=True)}


def _candidates(
    fitter: Fitter,
    families: Sequence[Family],
    current: list[Family],
    fit: Fit,
    sizes: dict[str, int],
    penalty: float,
    excess: float,
    rest: float,
    offsets: Mapping[str, float] | None = None,
) -> list[Candidate]:
    """Fit every family not yet in the model jointly with it; the candidates by decreasing held-out gain.

    Args:
        fitter: Fitter of the run.
        families: Families that may enter.
        current: Families of the current model.
        fit: The current model's fit (its parameters start the trials).
        sizes: Stream name -> length in the stacked vector.
        penalty: BIC penalty per observable parameter, log N.
        excess: The run's excess over noise.
        rest: The excess over noise the current model leaves.
        offsets: Family -> the gain it finds on a learned cell's own clean runs of this size (the floor's,
            `twin.analysis.discrepancy.floor.Floor.family_gain`), taken off its gains here.
    """
    starts = dict(fit.theta)
    chi2_now = _chi2(fit, sizes)
    candidates = []
    for family in families:
        if family in current:
            continue
        trial = fitter.fit([*current, family], starts)
        observable = int(np.sum(np.isfinite(trial.sigma[family.name])))
        floor = 0.0 if offsets is None else offsets.get(family.name, 0.0)
        gain = fit.heldout - trial.heldout - floor
        candidates.append(Candidate(
            family.name, gain, gain / excess, gain / rest, fit.sse - trial.sse - floor - observable * penalty,
            is_contradicted(chi2_now, _chi2(trial, sizes), sizes), trial,
        ))
    candidates.sort(key=lambda c: -c.gain)
    return candidates


def _pool(candidates: list[Candidate], of_rest: bool) -> list[Candidate]:
    """The candidates that may enter the model, by decreasing held-out gain.

    Eligible: a held-out share of at least ROUND_SHARE (of the rest with `of_rest`) and a positive BIC gain.
    Only the agreeing ones stay when the leader is contradicted and does not lead the best agreeing one by
    CONTRADICTED_LEAD.
    """
    eligible = [c for c in candidates
                if (c.share_of_rest if of_rest else c.share) >= ROUND_SHARE and c.bic_gain > 0]
    agreeing = [c for c in eligible if not c.contradicted]
    pool = eligible
    if agreeing and eligible[0].contradicted and eligible[0].gain < CONTRADICTED_LEAD * agreeing[0].gain:
        pool = agreeing
    return pool


def _best(pool: list[Candidate]) -> Candidate:
    """The pool's winner: the highest BIC gain among the candidates the held-out error cannot tell apart.

    Those reach AMBIGUITY_RATIO of the leader's (`pool[0]`) held-out gain and are alike in contradiction.
    """
    band = [
        c for c in pool if c.gain >= AMBIGUITY_RATIO * pool[0].gain and c.contradicted == pool[0].contradicted
    ]
    return max(band, key=lambda c: c.bic_gain)


def _ambiguous_with(
    fitter: Fitter,
    current: list[Family],
    best: Candidate,
    candidates: list[Candidate],
    by_name: dict[str, Family],
    scale: float,
) -> list[str]:
    """Names of the agreeing candidates close to `best` that add less than ROUND_SHARE of `scale` to it.

    Args:
        fitter: Fitter of the run.
        current: Families of the current model (without the winner).
        best: The winning candidate.
        candidates: All candidates of the round.
        by_name: Family name -> family.
        scale: The excess the shares are judged against (the rest, or the run's excess).
    """
    winner = by_name[best.name]
    ambiguous = []
    for other in candidates:
        if other is best or other.gain < AMBIGUITY_RATIO * best.gain or other.contradicted:
            continue
        both = fitter.fit([*current, winner, by_name[other.name]], dict(best.fit.theta))
        if (best.fit.heldout - both.heldout) / scale < ROUND_SHARE:
            ambiguous.append(other.name)
    return ambiguous


def single_gains(fitter: Fitter, families: Sequence[Family], sizes: dict[str, int]) -> dict[str, float]:
    """Each family's held-out gain alone on the run (what a first round scores), >= 0."""
    fit = fitter.fit([])
    excess = max(excess_over_noise(fitter.base, list(sizes.values())), 1e-9)
    candidates = _candidates(fitter, families, [], fit, sizes, 0.0, excess, excess)
    return {c.name: max(c.gain, 0.0) for c in candidates}


def forward_select(
    fitter: Fitter, families: Sequence[Family], excess: float, sizes: dict[str, int], *, of_rest: bool = False,
    offsets: Mapping[str, float] | None = None,
) -> tuple[Fit, tuple[Step, ...]]:
    """Grow a model family by family while a family explains a significant held-out share of the gap.

    Args:
        fitter: Fitter of the run.
        families: Families that may enter.
        excess: The run's excess over noise (`significance.excess_over_noise` of the base residual).
        sizes: Stream name -> length in the stacked vector.
        of_rest: Judge ROUND_SHARE against the excess the current model leaves (True, used on a twin replayed
            with the effects already named, where no linearisation error is left to be soaked up) or against
            `excess` (False: on the linearised twin as given, where a small share can be linearisation error).
        offsets: Family -> its gain on the learned cell's own clean runs (`_candidates`), or None.

    Returns:
        The final joint fit and the rounds.
    """
    current: list[Family] = []
    fit = fitter.fit(current)
    steps: list[Step] = []
    penalty = np.log(max(fitter.base.size, 2))
    while len(current) < MAX_FAMILIES and excess > 0:
        rest = excess_over_noise(fit.residual, list(sizes.values()))
        if rest <= 0.0:
            break
        candidates = _candidates(fitter, families, current, fit, sizes, penalty, excess, rest, offsets)
        pool = _pool(candidates, of_rest)
        if not pool:
            steps.append(Step(tuple(candidates), None, ()))
            break
        best = _best(pool)
        by_name = {f.name: f for f in families}
        winner = by_name[best.name]
        ambiguous = _ambiguous_with(fitter, current, best, candidates, by_name, rest if of_rest else excess)
        steps.append(Step(tuple(candidates), best.name, tuple(ambiguous)))
        current.append(winner)
        fit = best.fit
    return fit, tuple(steps)
