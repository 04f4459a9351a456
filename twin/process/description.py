"""The process as data: the sheet, the tool and the force model every stage receives.

A `Process` declares what the user's cell forms with: the sheet's material and its tensile strength, its
thickness, the tool radius, the tool-sheet friction, the travel over which the tool's sliding friction
reverses, the force model (a name of the registry `twin.process.force.registry`) and the FE force history that
model is fitted to. The defaults are the thesis's cell: AA5086-H111, 1 mm, a Ø 15 mm tool, friction 0.1
(§1.2.1-1.2.2, §2.2, §2.4.2), the per-pass table field fitted to the shipped stand-in history.

The table model takes its in-plane force from the history (the friction is in its Fx), the ISF model its
in-plane ratio from the calibration on the history; `tool_friction` is recorded with the process for the force
models that use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from twin.errors import InputError
from twin.process.fe.load import ForceHistory, default_force_history
from twin.process.force.table import TOOL_RADIUS_M
from twin.process.force.tool_friction import REVERSAL_M

#: The thesis's sheet: AA5086-H111 (§1.2.1). Its tensile strength R_m is the handbook value the stand-in history
#: uses; the thesis's Voce law necks at an engineering R_m of about 288 MPa (within 5 %, `twin.process.force.isf`).
DEFAULT_MATERIAL = "AA5086-H111"
DEFAULT_TENSILE_STRENGTH_MPA = 275.0
#: Coulomb friction between tool and sheet, the thesis's FE value (§2.4.2) [-].
DEFAULT_TOOL_FRICTION = 0.1


@dataclass(frozen=True)
class Process:
    """The declared process (module docstring).

    Attributes:
        material: Sheet material, a name.
        tensile_strength_mpa: Its tensile strength R_m [MPa].
        thickness_m: Sheet thickness t [m].
        tool_radius_m: Tool radius R [m].
        tool_friction: Coulomb friction coefficient between tool and sheet [-].
        friction_reversal_m: Tool travel over which the sheet's tangential force reverses at a reversal [m]
            (`twin.process.force.tool_friction`), for models whose in-plane force flips with the command; None: it
            flips with the commanded direction.
        force_model: Name of the force model (`twin.process.force.registry.FORCE_MODELS`).
        history: The FE force history the force model is fitted to; None: the shipped stand-in (a half model,
            doubled on load).
        force_fit: Force-model constants learned from the cell (`identify --forces`), (name, value) pairs that
            replace the model's shipped ones (`scale`, the level over the published one; `build_up_m`, `mu_eff`,
            `mu_radial` for the `isf` model; the `table` model takes `scale` only).
    """

    material: str = DEFAULT_MATERIAL
    tensile_strength_mpa: float = DEFAULT_TENSILE_STRENGTH_MPA
    thickness_m: float = 1.0e-3
    tool_radius_m: float = TOOL_RADIUS_M
    tool_friction: float = DEFAULT_TOOL_FRICTION
    friction_reversal_m: float | None = REVERSAL_M
    force_model: str = "table"
    history: ForceHistory | None = None
    force_fit: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("tensile_strength_mpa", "thickness_m", "tool_radius_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(f"Process.{name} = {value!r}: expected a finite number > 0")
        if self.tool_radius_m <= self.thickness_m:
            raise InputError(
                f"Process.tool_radius_m = {self.tool_radius_m!r} is not larger than thickness_m = {self.thickness_m!r}: "
                "a tool smaller than the sheet is thick"
            )
        if not (math.isfinite(self.tool_friction) and self.tool_friction >= 0):
            raise InputError(f"Process.tool_friction = {self.tool_friction!r}: expected a finite number >= 0")
        if self.friction_reversal_m is not None and not (
            math.isfinite(self.friction_reversal_m) and self.friction_reversal_m > 0
        ):
            raise InputError(f"Process.friction_reversal_m = {self.friction_reversal_m!r}: expected > 0 [m] or None")
        for item in self.force_fit:
            if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)
                    and isinstance(item[1], int | float) and math.isfinite(item[1])):
                raise InputError(f"Process.force_fit item {item!r}: expected (name, finite value); the model's "
                                 "builder checks its own ranges")
        if not self.material or not self.force_model:
            raise InputError(f"Process: material {self.material!r} and force_model {self.force_model!r} must be named")

    def force_history(self) -> ForceHistory:
        """The FE force history (the shipped stand-in when none was given)."""
        return self.history if self.history is not None else default_force_history()
