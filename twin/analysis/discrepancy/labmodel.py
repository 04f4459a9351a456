"""The named families in the lab's vocabulary (`twin.lab.effects`): what a model file and `replay --model` carry.

Families that map onto a lab effect (`Family.to_lab`) are composed into the twin's effects, the run is replayed
with them and the same families are refitted on the new linearisation, a few times, so the linearised fit
becomes exact (`refine`). A mapped family whose removal from the replayed model costs less than the selection's
ROUND_SHARE of what is then left was only soaking up linearisation error and is dropped (`prune`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from twin.analysis.discrepancy.context import Context, build_context
from twin.analysis.discrepancy.families.base import Family
from twin.analysis.discrepancy.fitting import Fit, Fitter
from twin.analysis.discrepancy.residuals import ResidualModel
from twin.analysis.discrepancy.selection import ROUND_SHARE
from twin.analysis.discrepancy.significance import excess_over_noise
from twin.lab.effects import Effects

REFINE_ITERATIONS = 4  # replays to make the linearised fit exact (each ~0.1 s)
MULTIPLICATIVE = {"force_scale"}  # lab effects composed by product; springback composes; the others add


def lab_increment(
    fit: Fit, families: dict[str, Family], name: str, *, lenient: bool = False
) -> dict[str, float] | None:
    """One fitted family in the lab's vocabulary (None: no lab equivalent, or not of the lab's form).

    `lenient` projects onto the lab's form whatever the uncertainty (used once the form is chosen).
    """
    return families[name].to_lab(fit.theta[name], fit.covariance[name] * (1e8 if lenient else 1.0))


def compose(base: Effects, increments: dict[str, float]) -> Effects:
    """The twin's effects `base` with fitted increments added (multiplied for a scale)."""
    values = dict(base.values)
    for name, inc in increments.items():
        if name in MULTIPLICATIVE:
            values[name] = base.get(name) * inc
        elif name == "sheet_springback":
            values[name] = 1.0 - (1.0 - base.get(name)) * (1.0 - inc)
        else:
            values[name] = base.get(name) + inc
    return Effects(values, base.lost_motion_takeup_m)


def context(model: ResidualModel, effects: Effects) -> Context:
    """The linearised replay of the model's run with `effects`."""
    twin, sim = model.simulate(effects)
    return build_context(model.run, twin, sim, effects)


def refine(
    model: ResidualModel,
    effects: Effects,
    fitter_for: Callable[[Context], Fitter],
    names: Sequence[str],
    families: dict[str, Family],
    progress: Callable[[str], None] | None = None,
) -> Effects:
    """Replay with the lab effects and refit the families `names` on the new linearisation, while it helps."""
    best, best_sse = effects, float("inf")
    for _ in range(REFINE_ITERATIONS):
        if progress is not None:
            progress("replay")
        refit = fitter_for(context(model, effects))
        sse = float(refit.base @ refit.base)
        if sse >= best_sse:
            break
        best, best_sse = effects, sse
        fit = refit.fit([families[n] for n in names])
        increments: dict[str, float] = {}
        for name in names:
            inc = lab_increment(fit, families, name, lenient=True)
            if inc is None:
                return best
            increments.update(inc)
        effects = compose(effects, increments)
    return best


def prune(
    model: ResidualModel,
    start: Effects,
    effects: Effects,
    keys: dict[str, list[str]],
    fitter_for: Callable[[Context], Fitter],
    sizes: list[int],
) -> tuple[Effects, list[str]]:
    """Drop families whose lab effects, removed from the replayed model, cost < ROUND_SHARE of what is left.

    Args:
        keys: Family name -> the lab effect names it set.

    Returns:
        The effects without the dropped families' lab effects, and the names kept.
    """
    excess_with = excess_over_noise(fitter_for(context(model, effects)).base, sizes)
    kept = []
    for name, lab_keys in keys.items():
        values = {k: v for k, v in effects.values.items() if k not in lab_keys}
        values.update({k: start.get(k) for k in lab_keys})
        without = Effects(values, effects.lost_motion_takeup_m)
        excess_without = excess_over_noise(fitter_for(context(model, without)).base, sizes)
        if len(keys) > 1 and excess_without - excess_with <= ROUND_SHARE * max(excess_without, 0.0):
            effects = without
        else:
            kept.append(name)
    return effects, kept

