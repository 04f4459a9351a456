"""Sliding friction of the tool on the sheet: the tangential force follows the tool's real travel.

The sheet's in-plane force on the tool (friction and ploughing, ~30 % of Fz on the groove) opposes the tool's
sliding. A force field evaluated with the *commanded* travel direction flips that force the instant the
program reverses; a real tool does not slide back at once. At a reversal it sticks while the robot unwinds
the deflection the force had caused, and the force reverses only as the tool starts to slide the other way.
With the TX200's compliance the commanded path travels 1-2 mm (60 ms at 2 m/min) before the tip moves back.

Model (rate-independent, a Dahl-type friction law along x, the groove's travel axis): a slip state
s in [-1, 1] that follows the tool's real travel,

    s = clip(s_prev + 2 (x - x_prev) / w, -1, 1),

with x_prev the last committed tip position and w the travel over which the force reverses (`reversal_m`,
0.05 mm: the tangential contact compliance of a lubricated sliding contact, a few tens of micrometres); the
tangential force is s·Fx(+1), Fx(+1) the wrapped field's in-plane force for travel in +x. Within the band the
force is stiff in x (dFx/dx = 2 Fx(+1)/w, ~2e7 N/m), which the twin's Newton solve takes as an analytic
stiffness: the tip holds where it stopped until the robot's spring exceeds the friction, as a stuck joint does.

Solving with this law: a Newton iteration across the clip's corners cycles between "stuck" and "sliding"
(the force is flat outside the band, 2e7 N/m steep inside). The twin therefore solves each sample under one
regime at a time, as it does joint friction (`solve_sample`): sliding in the commanded direction (the slip
state held at +-1: the old model, one solve away from reversals), then inside the band (the law unclipped,
linear in x), then sliding the other way; the first whose solution lies in its own regime is the one.

The wrapped field must flip only the sign of Fx with the direction: the models that declare
`tangential_from_command` (`twin.process.force.base`; the table `SheetForceField` does).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import TypeVar

import numpy as np

from twin.errors import InputError
from twin.process.force.base import FieldState, FieldWrapper, ForceField

T = TypeVar("T")
#: Tip position in the sheet frame [m] -> (force of the sheet on the tool [N], its gradient [N/m]).
SheetModel = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]

#: Travel over which the tangential force reverses [m].
REVERSAL_M = 5e-5


@dataclass(frozen=True)
class SlipState(FieldState):
    """The sliding state of the tool.

    Attributes:
        slip: Slip state s in [-1, 1], None before the first sample [-].
        x_prev_m: Last committed tip x [m].
        first_direction: The first commanded direction (+1/-1).
    """

    slip: float | None
    x_prev_m: float
    first_direction: int


class SlidingFriction(FieldWrapper):
    """A sheet force field whose tangential force follows the tool's real travel along x.

    Args:
        field: The wrapped field (a model that declares `tangential_from_command`: Fx flips with direction).
        reversal_m: Travel over which the tangential force reverses from -1 to +1 of its value [m].

    Its formed surface, tool radius and unloading stiffness are the wrapped field's.
    """

    def __init__(self, field: ForceField, reversal_m: float = REVERSAL_M) -> None:
        if not (np.isfinite(reversal_m) and reversal_m > 0.0):
            raise InputError(f"reversal_m = {reversal_m!r}: expected a finite travel > 0 [m]")
        self.inner = field
        self.radius, self.k_unload = field.radius, field.k_unload
        self.reversal_m = float(reversal_m)
        self._gain = 2.0 / self.reversal_m
        self._slip: float | None = None
        self._x_prev = 0.0
        self._last_direction = 1
        #: The sticking part of the last `force_and_stiffness`'s dFx/dx, 2 Fx(+1)/w inside the band, else 0
        #: [N/m]: what a command step large enough to make the tool slide does not meet.
        self.last_stick_stiffness = 0.0
        self._in_band = False  # True while a sample is solved inside the band: the law unclipped

    def reset(self) -> None:
        """The wrapped field's reset; the slip state starts with the first commanded direction."""
        self.inner.reset()
        self._slip = None

    @property
    def state(self) -> SlipState:
        """The slip state, the last committed tip x and the first direction."""
        return SlipState(self._slip, self._x_prev, self._last_direction)

    def restore(self, state: FieldState) -> None:
        """Set the slip state (a loop that advanced it itself, the twin's compiled loop `twin.sim.compiled`)."""
        if not isinstance(state, SlipState):
            raise InputError(f"state {state!r} is not a SlipState")
        self._slip, self._x_prev, self._last_direction = state.slip, float(state.x_prev_m), int(state.first_direction)

    def _slip_at(self, x: float, direction: int) -> tuple[float, float]:
        """Slip state at tip x [m] and its derivative ds/dx [1/m] (0 where clipped)."""
        if self._slip is None:
            self._last_direction = direction
            return float(direction), 0.0
        s = self._slip + self._gain * (x - self._x_prev)
        if self._in_band:
            return s, self._gain
        if s >= 1.0:
            return 1.0, 0.0
        if s <= -1.0:
            return -1.0, 0.0
        return s, self._gain

    def solve_sample(
        self,
        pass_index: int,
        direction: int,
        solve: Callable[[SheetModel], T],
        tip_of: Callable[[T], np.ndarray],
    ) -> T:
        """One sample's equilibrium, one regime at a time: sliding along `direction`, in the band, sliding back.

        Args:
            pass_index, direction: The sample's pass and commanded direction.
            solve: Solves the equilibrium against a sheet model (tip position -> force, stiffness).
            tip_of: The tool tip of a solution, sheet frame [m].

        Returns:
            The first solution whose tip lies in the regime it was solved in (the last one tried otherwise).
        """
        if self._slip is None:  # the first sample: no travel yet, the commanded direction
            return solve(partial(self.force_and_stiffness, pass_index=pass_index, direction=direction))
        result = None
        try:
            for regime in (float(direction), 0.0, -float(direction)):
                self._in_band = regime == 0.0
                if self._in_band:
                    result = solve(partial(self.force_and_stiffness, pass_index=pass_index, direction=direction))
                else:  # sliding: the wrapped field itself, no wrapper in the Newton loop
                    self.last_stick_stiffness = 0.0
                    sign = 1 if regime > 0 else -1
                    result = solve(partial(self.inner.force_and_stiffness, pass_index=pass_index, direction=sign))
                u = self._slip + self._gain * (float(tip_of(result)[0]) - self._x_prev)
                if (-1.0 <= u <= 1.0) if regime == 0.0 else (u * regime >= 1.0):
                    break
        finally:
            self._in_band = False
        assert result is not None
        return result

    def force(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        """Force of the sheet on the tool [N], sheet frame; pure. `direction` only starts the slip state."""
        s, _ = self._slip_at(float(p_sheet_m[0]), direction)
        if s == 1.0 or s == -1.0:  # sliding: the wrapped field's force for that direction
            return self.inner.force(p_sheet_m, pass_index, int(s))
        f = self.inner.force(p_sheet_m, pass_index, 1)
        f[0] *= s
        return f

    def force_and_stiffness(
        self, p_sheet_m: np.ndarray, pass_index: int, direction: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """`force` and ∂f/∂p [N/m], shape (3, 3), the slip state's stiffness included."""
        s, ds_dx = self._slip_at(float(p_sheet_m[0]), direction)
        if ds_dx == 0.0 and (s == 1.0 or s == -1.0):  # sliding: the wrapped field's force for that direction
            self.last_stick_stiffness = 0.0
            return self.inner.force_and_stiffness(p_sheet_m, pass_index, int(s))
        f, k = self.inner.force_and_stiffness(p_sheet_m, pass_index, 1)
        fx_plus = float(f[0])
        f[0] = s * fx_plus
        k[0] *= s
        self.last_stick_stiffness = fx_plus * ds_dx
        k[0, 0] += self.last_stick_stiffness
        return f, k

    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None) -> None:
        """Commit the tip position: the slip state and the wrapped field's formed surface."""
        x = float(p_sheet_m[0])
        if self._slip is None:
            self._slip = float(self._last_direction)
        else:
            self._slip = min(1.0, max(-1.0, self._slip + self._gain * (x - self._x_prev)))
        self._x_prev = x
        self.inner.advance(p_sheet_m, pass_index)


def solve_sample(
    field: ForceField,
    pass_index: int,
    direction: int,
    solve: Callable[[SheetModel], T],
    tip_of: Callable[[T], np.ndarray],
) -> T:
    """One sample's equilibrium against any sheet field: by regimes for `SlidingFriction`, else in one solve.

    Args:
        field: The sheet force field (`force_and_stiffness(p, pass_index, direction)`).
        pass_index, direction: The sample's pass and commanded direction.
        solve: Solves the equilibrium against a sheet model (tip position -> force, stiffness).
        tip_of: The tool tip of a solution, sheet frame [m] (used by `SlidingFriction` only).
    """
    if isinstance(field, SlidingFriction):
        return field.solve_sample(pass_index, direction, solve, tip_of)
    return solve(partial(field.force_and_stiffness, pass_index=pass_index, direction=direction))
