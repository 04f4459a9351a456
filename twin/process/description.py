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
class Plausible:
    """The range a declared quantity of an ISF cell may take; outside it the value is refused, not warned about.

    Attributes:
        what: The quantity in words.
        low: Lowest accepted value, in `unit` (inclusive).
        high: Highest accepted value, in `unit` (inclusive).
        unit: The unit the range is given in ("" for a pure number).
        scale: `unit` per SI unit of the field (1e3 for a length in m shown in mm).
        why: Why an ISF engineer would not go beyond it.
    """

    what: str
    low: float
    high: float
    unit: str
    scale: float
    why: str


#: The accepted range of every declared process and tool quantity (SI field name -> range). The published force
#: formula's narrower experimental range (`twin.process.force.aerens.VALIDITY`) still only warns; these bound what is
#: physically an ISF cell at all, so a value outside is a typo or a unit slip (1 um for 1 mm, 15 m for 15 mm).
PLAUSIBLE: dict[str, Plausible] = {
    # Sheets formed incrementally run from ~0.1 mm foils (micro-ISF) to ~6 mm plates (thick-plate SPIF, the
    # forces of which already exceed an industrial robot's payload); 0.5-2 mm is the common range.
    "thickness_m": Plausible("sheet thickness", 0.1, 6.0, "mm", 1e3,
                             "ISF forms foils of 0.1 mm to plates of 6 mm"),
    # Tool tip radii: Ø1 mm pins in micro-ISF to Ø100 mm hemispherical tools on large parts.
    "tool_radius_m": Plausible("tool radius", 0.5, 50.0, "mm", 1e3,
                               "ISF tools run from Ø1 mm micro-ISF pins to Ø100 mm hemispheres"),
    # R_m of what is formed: pure lead and soft polymers (~10-20 MPa) to press-hardening and maraging steels
    # (~2000 MPa); titanium alloys ~1000 MPa. Below 10 is a unit slip (GPa), above 2500 no sheet metal.
    "tensile_strength_mpa": Plausible("tensile strength R_m", 10.0, 2500.0, "MPa", 1.0,
                                      "sheet metals and polymers range from ~10 MPa (lead) to ~2000 MPa (maraging "
                                      "steel)"),
    # Coulomb friction tool-sheet: lubricated ISF 0.02-0.2, dry steel on steel up to ~0.8; above 1 is not Coulomb
    # sliding any more (galling).
    "tool_friction": Plausible("tool-sheet friction coefficient", 0.0, 1.0, "", 1.0,
                               "lubricated ISF runs at 0.02-0.2, dry metal on metal below 1"),
    # Flange to tip: a short pin on a compact spindle (~20 mm) to a long extension for deep parts; beyond 1.5 m the
    # tool would out-reach the robot's own arm links (a cell file's tool takes these bounds).
    "tool_length_m": Plausible("tool length (flange to tip)", 20.0, 1500.0, "mm", 1e3,
                               "an ISF tool on a robot flange is 20 mm to 1.5 m long"),
    # Tool mass with an F/T sensor: a few kg; 500 kg is above every ISF robot's payload (KR 210: 210 kg).
    "tool_mass_kg": Plausible("tool mass", 0.0, 500.0, "kg", 1.0,
                              "an ISF tool with its sensor weighs a few kg, far below 500 kg"),
    # A force component of a run (its forces.csv, or an import's sensor export in the declared unit): ISF forces
    # reach a few kN (a robot cell carries no more); 50 kN is ten times that: beyond is a unit slip (mN, a
    # sensor's raw counts).
    "force_n": Plausible("force component", -5e4, 5e4, "N", 1.0,
                         "ISF forces on a robot cell reach a few kN, and 50 kN is ten times that"),
}


def plausibility_problem(name: str, value: float, label: str) -> str | None:
    """What is wrong with `value` (SI) of the field `name` (`PLAUSIBLE`), or None; `label` says where it was
    declared (an option as typed, `FILE: key`, `Process.thickness_m`)."""
    rng = PLAUSIBLE[name]
    shown = value * rng.scale
    if rng.low <= shown <= rng.high:
        return None
    unit = f" {rng.unit}" if rng.unit else ""
    return (f"{rng.what} {shown:g}{unit} ({label}) is outside {rng.low:g}..{rng.high:g}{unit}: {rng.why}; expected a "
            f"value in that range (a unit slip?)")


def check_plausible(name: str, value: float, label: str) -> float:
    """`value` if it lies in the field's `PLAUSIBLE` range, else InputError naming `label`, the value and the range."""
    problem = plausibility_problem(name, value, label)
    if problem:
        raise InputError(problem)
    return value


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
        for name in ("thickness_m", "tool_radius_m", "tensile_strength_mpa", "tool_friction"):
            check_plausible(name, getattr(self, name), f"Process.{name} = {getattr(self, name)!r}")
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
