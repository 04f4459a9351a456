"""The named families as the twin's effects (`twin.sim.effects`): what a model file and `replay --model` carry.

Families that map onto an effect of the vocabulary (`Family.effect`, `Family.to_effect`), or onto the
instruments' calibration (`Family.to_instruments`, `twin.sim.instruments`: measurement-side, exact in the
linearised fit, so not refined), are composed into the twin's effects (each effect's own `compose` rule), and those effects are then fitted by Gauss-Newton over twin
replays, with each effect's finite-difference `step` and `bounds`, so the linearised fit becomes exact
(`refine`). A mapped family whose removal from the replayed model costs less than the selection's ROUND_SHARE of
what is then left was only soaking up linearisation error and is dropped (`prune`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from twin.analysis.discrepancy.context import Context, build_context
from twin.analysis.discrepancy.families.base import Family
from twin.analysis.discrepancy.fitting import Fit, Fitter
from twin.analysis.discrepancy.residuals import ResidualModel
from twin.analysis.discrepancy.selection import ROUND_SHARE
from twin.analysis.discrepancy.significance import excess_over_noise
from twin.sim.effects import EFFECTS, GEAR_PLAY, INSTRUMENTS, Effects

REFINE_ITERATIONS = 4  # replays to make the linearised fit exact (each ~0.1 s)


def effect_increment(
    fit: Fit, families: dict[str, Family], name: str, ctx: Context, *, lenient: bool = False
) -> dict[str, Any] | None:
    """One fitted family as an increment of its effect, or of the instruments' calibration (keys
    `instruments.FIELD`, `twin.sim.instruments`) where the fit is not of its effect's form, or of the effects the
    scalar vocabulary does not hold (`Family.to_increments`: the gear play, `GEAR_PLAY`); None: none of these.

    `lenient` projects onto the effect's form whatever the uncertainty where the family has no instruments' form
    (used once the form is chosen).
    """
    family = families[name]
    theta = fit.theta[name]
    if family.effect is not None:
        value = family.to_effect(theta, fit.covariance[name])
        if value is not None:
            return {family.effect: value}
    carried = family.to_instruments(theta, ctx)
    if carried is not None:
        return {f"{INSTRUMENTS}{k}": v for k, v in carried.items()}
    increments = family.to_increments(theta, ctx)
    if increments is not None:
        return increments
    if family.effect is None or not lenient:
        return None
    value = family.to_effect(theta, fit.covariance[name] * 1e8)
    return None if value is None else {family.effect: value}


def context(model: ResidualModel, effects: Effects) -> Context:
    """The linearised replay of the model's run with `effects`."""
    twin, sim = model.simulate(effects)
    return build_context(model.run, twin, sim, effects)


def refine(
    model: ResidualModel,
    effects: Effects,
    fitter_for: Callable[[Context], Fitter],
    keys: Sequence[str],
    progress: Callable[[str], None] | None = None,
) -> Effects:
    """Gauss-Newton on the effects `keys` over twin replays (finite differences), from `effects`.

    The Jacobian is taken once, at the start (a chord method): the effects act nearly linearly over the
    step from the linearised fit, and each later iteration then costs one replay instead of 1 + len(keys).

    The effect's form is fitted directly (e.g. one lost motion for the robot's lost-motion joints together), so
    its parameters are as precise as the data allow; replays of measurement-side effects reuse the cached
    simulation.
    """
    keys = [k for k in keys if k in EFFECTS]
    best, best_sse = effects, float("inf")
    jacobian: np.ndarray | None = None
    for _ in range(REFINE_ITERATIONS):
        if progress is not None:
            progress("replay")
        r = fitter_for(context(model, effects)).base
        sse = float(r @ r)
        if sse >= best_sse:
            break
        best, best_sse = effects, sse
        if jacobian is None:  # a chord method: the finite-difference Jacobian of the first point serves on
            cols = []
            for key in keys:
                step = EFFECTS[key].step
                moved = effects.with_value(key, effects.get(key) + step)
                cols.append((fitter_for(context(model, moved)).base - r) / step)
            jacobian = np.column_stack(cols)
        delta, *_ = np.linalg.lstsq(jacobian, -r, rcond=None)
        values = dict(effects.values)
        for key, d in zip(keys, delta, strict=True):
            values[key] = float(np.clip(effects.get(key) + d, *EFFECTS[key].bounds))
        effects = effects.with_values(values)
        if all(abs(d) < 0.01 * EFFECTS[k].step for k, d in zip(keys, delta, strict=True)):
            sse_new = float(np.sum(fitter_for(context(model, effects)).base ** 2))
            return effects if sse_new < best_sse else best
    return best


def refit_instruments(
    model: ResidualModel, effects: Effects, families: Sequence[Family], fitter_for: Callable[[Context], Fitter]
) -> Effects:
    """`effects` with the instruments' families fitted again on its replay and added to its instruments.

    The instruments act on the measurement alone, so their fit over the replayed twin is exact; fitted on the
    first linearisation beside a robot-side effect they would keep what they soaked up of its linearisation error
    (e.g. a cross-talk standing in for a force scale's second order)."""
    if not families:
        return effects
    ctx = context(model, effects)
    fit = fitter_for(ctx).fit(list(families))
    increments: dict[str, Any] = {}
    for family in families:
        for key, value in (family.to_instruments(fit.theta[family.name], ctx) or {}).items():
            increments[f"{INSTRUMENTS}{key}"] = value
    return effects.composed(increments)


def prune(
    model: ResidualModel,
    start: Effects,
    effects: Effects,
    keys: dict[str, list[str]],
    fitter_for: Callable[[Context], Fitter],
    sizes: list[int],
) -> tuple[Effects, list[str]]:
    """Drop families whose effects, removed from the replayed model, cost < ROUND_SHARE of what is left.

    Args:
        keys: Family name -> the effect names it set.

    Returns:
        The effects without the dropped families' effects, and the names kept.
    """
    excess_with = excess_over_noise(fitter_for(context(model, effects)).base, sizes)
    kept = []
    for name, effect_keys in keys.items():
        values = {k: v for k, v in effects.values.items() if k not in effect_keys}
        values.update({k: start.get(k) for k in effect_keys if k in EFFECTS})
        fields = [k.removeprefix(INSTRUMENTS) for k in effect_keys if k.startswith(INSTRUMENTS)]
        without = effects.with_values(values).with_instruments(effects.instruments.reset(fields, start.instruments))
        if GEAR_PLAY in effect_keys:
            without = replace(without, gear_play_rad=start.gear_play_rad)
        excess_without = excess_over_noise(fitter_for(context(model, without)).base, sizes)
        if len(keys) > 1 and excess_without - excess_with <= ROUND_SHARE * max(excess_without, 0.0):
            effects = without
        else:
            kept.append(name)
    return effects, kept

