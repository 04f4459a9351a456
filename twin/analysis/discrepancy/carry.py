"""Carry the named families into the twin: their effects refined over replays, the instruments' families fitted again
on the replayed twin, and a selection on that twin for what they leave (`into_effects`).

Where the effects' form does not hold (the replayed twin leaves more than the linearised fit: a scale that
differs per axis forced onto a scalar, a floor's transient taken for lost motion), the instruments' families of
the stage are still carried on their own (they act on the measurement alone, so their fit on the replay is
exact), and the robot-side ones stay named without an effect (`EffectModel.complete` False).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import numpy as np

from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.effect_model import context, effect_increment, prune, refine, refit_instruments
from twin.analysis.discrepancy.families import Family
from twin.analysis.discrepancy.fitting import Fit, Fitter
from twin.analysis.discrepancy.residuals import ResidualModel
from twin.analysis.discrepancy.selection import Step, forward_select
from twin.analysis.discrepancy.significance import excess_over_noise, split_streams
from twin.sim.effects import EFFECTS, INSTRUMENTS, Effects

STAGES = 3  # replay-and-select rounds after the first selection
# the effects' form of the named families is kept when the twin replayed with it leaves at most this x the excess
# of the linearised fit plus EFFECT_FORM_FLOOR of the run's: replaying removes linearisation error, so an effect's
# form that holds leaves less; one that does not (a per-axis scale forced to a scalar, a drift off the effect's
# direction) leaves more
EFFECT_FORM_SLACK = 1.1
EFFECT_FORM_FLOOR = 0.005


@dataclass(frozen=True)
class NamedEffect:
    """A family named by the search, with what it explains."""

    name: str
    parameters: dict[str, float]
    uncertainty: dict[str, float | None]
    explained_fraction: float
    ambiguous_with: tuple[str, ...]
    effect_name: str | None = None

    @property
    def reported_name(self) -> str:
        """The effect's name (the model file's vocabulary) when the family maps onto one, else its own."""
        return self.effect_name or self.name

    def summary(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "name": self.name, "effect_name": self.effect_name, "parameters": self.parameters,
            "uncertainty": self.uncertainty, "explained_fraction": self.explained_fraction,
            "ambiguous_with": list(self.ambiguous_with),
        }


def named_effects(steps: tuple[Step, ...], fit: Fit, families: dict[str, Family]) -> list[NamedEffect]:
    out = []
    for step in steps:
        if step.accepted is None:
            continue
        share = next(c.share for c in step.candidates if c.name == step.accepted)
        family = families[step.accepted]
        theta, sd = fit.theta[step.accepted], fit.sigma[step.accepted]
        out.append(NamedEffect(
            step.accepted,
            {p: float(v) for p, v in zip(family.parameters, theta, strict=True)},
            {p: (float(s) if np.isfinite(s) else None) for p, s in zip(family.parameters, sd, strict=True)},
            float(share), step.ambiguous_with,
        ))
    return out


class EffectModel(NamedTuple):
    """The named families carried into the twin's effects (`into_effects`).

    Attributes:
        effects: The twin's effects.
        named: The named families.
        remainder: What is left by stream (SI).
        complete: Whether the effects carry every named family.
        steps: The selection rounds on the replayed twin.
    """

    effects: Effects
    named: list[NamedEffect]
    remainder: dict[str, np.ndarray]
    complete: bool
    steps: tuple[Step, ...]


def into_effects(
    ctx: Context,
    model: ResidualModel,
    start: Effects,
    fit: Fit,
    named: list[NamedEffect],
    families: dict[str, Family],
    fitter_for: Callable[[Context], Fitter],
    sizes: dict[str, int],
    excess: float,
    progress: Callable[[str], None] | None,
    offsets: Mapping[str, float] | None = None,
) -> EffectModel:
    """Carry the named families that map onto an effect into the twin, replayed and refitted; then select again on
    the replayed twin for what they leave (families without an effect, small effects the linearisation hid)."""
    effects = start
    mapped: dict[str, list[str]] = {}
    fits = {n.name: n for n in named}
    steps: tuple[Step, ...] = ()
    final, more, fit_now = fit, list(named), fit
    for _ in range(STAGES):
        found = {n.name: inc for n in more
                 if (inc := effect_increment(fit_now, families, n.name, ctx, lenient=True)) is not None}
        if not found:
            break
        new = {name: list(inc) for name, inc in found.items()}
        scalar = {k: v for inc in found.values() for k, v in inc.items() if not k.startswith(INSTRUMENTS)}
        trial_mapped = {**mapped, **new}
        effect_keys = [k for keys in trial_mapped.values() for k in keys if k in EFFECTS]
        trial = refine(model, effects.composed(scalar), fitter_for, effect_keys, progress) if effect_keys \
            else effects.composed(scalar)
        trial = refit_instruments(model, trial, [families[n] for n, keys in new.items()
                                                 if keys[0].startswith(INSTRUMENTS)], fitter_for)
        trial, kept = prune(model, start, trial, trial_mapped, fitter_for, list(sizes.values()))
        replayed_trial = fitter_for(context(model, trial))
        rest = excess_over_noise(replayed_trial.base, list(sizes.values()))
        linearised = excess_over_noise(fit_now.residual, list(sizes.values()))
        if rest > EFFECT_FORM_SLACK * linearised + EFFECT_FORM_FLOOR * excess:
            # the effects' form does not hold (e.g. a scale that differs per axis): carry the instruments' alone
            instrumental = {n: keys for n, keys in new.items() if keys[0].startswith(INSTRUMENTS)}
            if not instrumental or len(instrumental) == len(new):
                break
            trial = refit_instruments(model, effects, [families[n] for n in instrumental], fitter_for)
            replayed_trial = fitter_for(context(model, trial))
            rest = excess_over_noise(replayed_trial.base, list(sizes.values()))
            trial_mapped, kept = {**mapped, **instrumental}, [*mapped, *instrumental]
            if rest >= excess_over_noise(fitter_for(context(model, effects)).base, list(sizes.values())):
                break
        effects, replayed = trial, replayed_trial
        mapped = {k: v for k, v in trial_mapped.items() if k in kept}
        others = {k: f for k, f in families.items() if k not in mapped}
        final, steps = forward_select(replayed, list(others.values()), rest, sizes, of_rest=True,
                                      offsets=offsets) if rest > 0 else (replayed.fit([]), ())
        more = [replace(n, explained_fraction=n.explained_fraction * rest / excess)
                for n in named_effects(steps, final, others)]
        fits.update({n.name: n for n in more if n.name not in fits})
        fit_now = final
    if not mapped:
        fitter = fitter_for(context(model, start))
        streams = {s: (v * fitter.sigma[s]).reshape(fitter.raw[s].shape)
                   for s, v in split_streams(fit.residual, sizes).items()}
        return EffectModel(start, named, streams, False, ())
    mapped_named = [replace(fits[name], effect_name=keys[0] if keys[0] in EFFECTS else None)
                    for name, keys in mapped.items()]
    streams = {s: (v * replayed.sigma[s]).reshape(replayed.raw[s].shape)
               for s, v in split_streams(final.residual, sizes).items()}
    return EffectModel(effects, mapped_named + more, streams, not more, steps)


