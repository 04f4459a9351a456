"""The effect-family interface and its registry.

A family is one physical or measurement effect with a vector of parameters. It predicts how the twin's
prediction of a run changes when the effect is present: a `Delta` of the tracker stream [m], the force stream
[N] and the part profile [m], given the linearised replay (`Context`). The search fits the parameters by
`scipy.optimize.least_squares` and never needs to know what a family does.

To add a family, write one subclass and decorate it with `register`:

    @register
    class MyEffect(Family):
        name = "my_effect"
        parameters = ("a_mm",)          # units in the names
        neutral = (0.0,)                # the value that switches it off
        bounds = ((-5.0,), (5.0,))
        scale = (0.1,)                  # a typical size of the parameter (for the solver and the report)
        description = "what the effect is, in words"

        def delta(self, ctx, theta):
            return Delta(position=..., force=..., profile=...)

`twin.analysis.discrepancy.families.FAMILIES` then holds it and every search tries it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from twin.analysis.discrepancy.context import Context
from twin.base.registry import Registry
from twin.sim.effects import EFFECTS


@dataclass(frozen=True)
class Delta:
    """Change of the twin's prediction caused by an effect (None: the stream is untouched).

    Attributes:
        position: Tracker reading change, sheet frame [m], shape (m, 3).
        force: Sensor force change, sheet frame [N], shape (k, 3).
        profile: Part-profile change [m], shape (p,).
    """

    position: np.ndarray | None = None
    force: np.ndarray | None = None
    profile: np.ndarray | None = None


class Family(ABC):
    """Base class of an effect family: a name, named parameters with units, and `delta`.

    Class attributes:
        name: Registry key, also the name in verdicts.
        parameters: Parameter names, each ending with its unit (`_mm`, `_s`, `_ratio`, ...).
        neutral: Parameter values that switch the effect off.
        bounds: (lower, upper) per parameter.
        scale: Typical magnitude of each parameter (solver scaling).
        description: One line in words.
        needs_forces: The family acts only through the force stream (skipped for runs without forces).
        needs_profile: The family acts only through the profile (skipped for runs without one).
        linear: `delta` is linear in theta - neutral (one least-squares solve suffices).
        bilinear: The last parameter w weighs two changes linear in the others: delta = d0 + w (d1 - d0)
            (d0 at w = 0, d1 at w = 1); the fitter caches both bases.
        effect: The effect of the vocabulary (`twin.sim.effects.EFFECTS`) the family maps onto, or None: what a
            model file carries of it (`to_effect`). A family of the instruments maps onto their calibration
            instead (`to_instruments`, `twin.sim.instruments`).
        carried_by_learning: The model file carries the family through the robot learner, not an effect of its own:
            `discrepancy` learns the robot (and the sheet) from the run when it names the family first, as it does
            for a gap no family explains (`JointCompliance`: the learned K_q holds a softer gear).
        acts_on: The streams whose gap the family must explain to be named (`consistency`), its evidence first:
            a robot-side family the tool tip and the forces (its change reaches both through the loaded robot;
            the default), a force-sensor family the forces, a tracker family the tool tip, a part family the
            profile.
    """

    name: ClassVar[str] = ""
    parameters: ClassVar[tuple[str, ...]] = ()
    neutral: ClassVar[tuple[float, ...]] = ()
    bounds: ClassVar[tuple[tuple[float, ...], tuple[float, ...]]] = ((), ())
    scale: ClassVar[tuple[float, ...]] = ()
    description: ClassVar[str] = ""
    needs_forces: ClassVar[bool] = False
    needs_profile: ClassVar[bool] = False
    linear: ClassVar[bool] = True
    bilinear: ClassVar[bool] = False
    effect: ClassVar[str | None] = None
    acts_on: ClassVar[tuple[str, ...]] = ("position", "force")
    carried_by_learning: ClassVar[bool] = False

    @abstractmethod
    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        """Change of the prediction for parameters `theta` (same order as `parameters`)."""

    def start(self, ctx: Context, residual: dict[str, np.ndarray]) -> np.ndarray:
        """Starting parameters of the fit (default neutral); `residual` is measured - predicted by stream."""
        del ctx, residual
        return np.asarray(self.neutral, dtype=float)

    def starts(self, ctx: Context, residual: dict[str, np.ndarray]) -> list[np.ndarray]:
        """Starting parameters to refine from, the best refined fit kept (default: `start` alone)."""
        return [self.start(ctx, residual)]

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        """The fitted family as a value of its `effect` [the effect's unit], for a model file; None when the fit is
        not of the effect's form (or the family has no effect)."""
        del theta, covariance
        return None

    def to_instruments(self, theta: np.ndarray, ctx: Context) -> dict[str, np.ndarray] | None:
        """The fitted family as increments of the instruments' calibration (`twin.sim.instruments.FIELDS`), for a
        model file, where `to_effect` gives none; None: the family is not of the instruments."""
        del theta, ctx
        return None

    def to_increments(self, theta: np.ndarray, ctx: Context) -> dict[str, Any] | None:
        """The fitted family as increments of the twin's effects the scalar vocabulary does not hold (keys
        `twin.sim.effects.Effects.composed` takes, e.g. `GEAR_PLAY`: one value per arm joint), for a model file, where
        it has neither an effect nor the instruments' form; None: none."""
        del theta, ctx
        return None

    def applicable(self, ctx: Context) -> bool:
        """Whether the run has the streams this family acts on."""
        return (ctx.has_forces or not self.needs_forces) and (ctx.has_profile or not self.needs_profile)


#: The discrepancy families, by name (`twin.base.registry.Registry`).
FAMILIES: Registry[Family] = Registry("discrepancy family")


def learns_from_run(verdict: str) -> bool:
    """Whether a verdict is carried by learning the robot and the sheet from the run: `unexplained` (no family
    explains the gap) or a family `carried_by_learning`."""
    return verdict == "unexplained" or (verdict in FAMILIES and FAMILIES[verdict].carried_by_learning)


def register(cls: type[Family]) -> type[Family]:
    """Class decorator: add one instance of a family to `FAMILIES` (names must be unique)."""
    if cls.effect is not None and cls.effect not in EFFECTS:
        raise ValueError(f"family {cls.name}: effect {cls.effect!r} is not one of {sorted(EFFECTS)}")
    n = len(cls.parameters)
    if not (len(cls.neutral) == len(cls.scale) == len(cls.bounds[0]) == len(cls.bounds[1]) == n):
        raise ValueError(f"family {cls.name}: parameters, neutral, scale and bounds differ in length")
    FAMILIES.register(cls())
    return cls
