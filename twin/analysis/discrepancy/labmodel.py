"""The named families in the lab's vocabulary (`twin.lab.effects`): what a model file and `replay --model` carry.

Families that map onto a lab effect (`Family.to_lab`) are composed into the twin's effects, and the lab effects
are then fitted by Gauss-Newton over twin replays, so the linearised fit becomes exact (`refine`). A mapped family whose removal from the replayed model costs less than the selection's
ROUND_SHARE of what is then left was only soaking up linearisation error and is dropped (`prune`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from twin.analysis.discrepancy.context import Context, build_context
from twin.analysis.discrepancy.families.base import Family
from twin.analysis.discrepancy.fitting import Fit, Fitter
from twin.analysis.discrepancy.residuals import ResidualModel
from twin.analysis.discrepancy.selection import ROUND_SHARE
from twin.analysis.discrepancy.significance import excess_over_noise
from twin.lab.effects import Effects

REFINE_ITERATIONS = 4  # replays to make the linearised fit exact (each ~0.1 s)
MULTIPLICATIVE = {"force_scale"}
# finite-difference step of each lab effect in `refine`, in its unit, and bounds it must stay in
LAB_STEP = {
    "direction_dependent_compliance": 0.02,
    "force_scale": 0.02,
    "stream_time_offset": 0.005,
    "tracker_drift": 0.002,
    "tcp_offset": 0.05,
    "sheet_springback": 0.01,
}
LAB_BOUNDS = {"force_scale": (0.0, 10.0), "sheet_springback": (0.0, 0.99)}  # lab effects composed by product; springback composes; the others add


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
    keys: Sequence[str],
    progress: Callable[[str], None] | None = None,
) -> Effects:
    """Gauss-Newton on the lab effects `keys` over twin replays (finite differences), from `effects`.

    The Jacobian is taken once, at the start (a chord method): the lab effects act nearly linearly over the
    step from the linearised fit, and each later iteration then costs one replay instead of 1 + len(keys).

    The lab form is fitted directly (e.g. one lost motion for joints 2 and 3 together), so its parameters are
    as precise as the data allow; replays of measurement-side effects reuse the cached simulation.
    """
    keys = [k for k in keys if k in LAB_STEP]
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
                step = LAB_STEP[key]
                moved = Effects({**effects.values, key: effects.get(key) + step}, effects.lost_motion_takeup_m)
                cols.append((fitter_for(context(model, moved)).base - r) / step)
            jacobian = np.column_stack(cols)
        delta, *_ = np.linalg.lstsq(jacobian, -r, rcond=None)
        values = dict(effects.values)
        for key, d in zip(keys, delta, strict=True):
            values[key] = float(np.clip(effects.get(key) + d, *LAB_BOUNDS.get(key, (-np.inf, np.inf))))
        effects = Effects(values, effects.lost_motion_takeup_m)
        if all(abs(d) < 0.01 * LAB_STEP[k] for k, d in zip(keys, delta, strict=True)):
            sse_new = float(np.sum(fitter_for(context(model, effects)).base ** 2))
            return effects if sse_new < best_sse else best
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

