"""Sheet materials as data: a material, each number with its source, a library of them, and names looked up.

A `Material` holds what a process needs of a sheet (its tensile strength R_m) and what a force model may use
(0.2 % proof strength, Young's modulus, Poisson's ratio, density, a hardening law, `twin.process.material.hardening`);
only R_m is required. Every number of the shipped library (`models/materials/library.toml`) names the entry of
the file's bibliography (`[sources]`) it comes from; a number without a source is left out (None), never
guessed. A user's materials file has the same format; `twin.process.material.file` reads both and looks a
material up by name (`material`, `shipped_library`).

Names are looked up as people write them: case, spaces, hyphens and dots do not matter, nor the prefixes `AA`
and `EN AW` of aluminium alloys ("AA5086-H111", "5086-H111", "EN AW-5086-H111", "AA 5086 H111" are one
material), and a material may list other designations (`aliases`, e.g. "1.4301" for AISI 304).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.errors import InputError
from twin.process.material.hardening import PA_SUSPECT_MPA, HardeningLaw

#: The numbers of a material, each with its unit in the name; `tensile_strength_mpa` is required.
NUMBER_FIELDS = ("tensile_strength_mpa", "yield_strength_mpa", "youngs_modulus_gpa", "poisson_ratio", "density_kg_m3")
#: The range each number of a material may take (low, high, why), in the field's unit: what sheet metals (and the
#: polymers ISF also forms) have. Outside it a number is refused as a typo or a unit slip, never used.
PLAUSIBLE_NUMBERS: dict[str, tuple[float, float, str]] = {
    # pure lead (~12-17 MPa) and soft polymers to maraging and press-hardened steels (~2000 MPa)
    "tensile_strength_mpa": (10.0, 2500.0, "what sheet metals have: ~12 MPa (lead) to ~2000 MPa (maraging steel)"),
    # R_p0.2 of annealed lead (~5 MPa) and pure aluminium 1050-O (~25 MPa) up to the same strongest steels
    "yield_strength_mpa": (5.0, 2500.0, "what sheet metals have: ~5 MPa (lead) to ~2000 MPa (maraging steel)"),
    # polymers (~1-3 GPa), magnesium 45 GPa, steels 210 GPa, tungsten 411 GPa
    "youngs_modulus_gpa": (0.5, 450.0, "from polymers (~1 GPa) to tungsten (411 GPa)"),
    # polymers (~900 kg/m³), magnesium 1740, steel 7850, tungsten 19300, osmium 22590
    "density_kg_m3": (500.0, 23000.0, "from polymers (~900 kg/m³) to osmium (22590 kg/m³)"),
}
#: What may carry a source: the numbers and the hardening law.
SOURCED_FIELDS = (*NUMBER_FIELDS, "hardening")
#: Prefixes of an aluminium alloy's designation that do not change the material (after normalising).
_NAME_PREFIXES = ("ENAW", "AA", "AW")


@dataclass(frozen=True)
class Source:
    """One entry of a materials file's bibliography.

    Attributes:
        key: Its key in `[sources]`, as the materials cite it.
        citation: The full citation (authors or publisher, title, edition, year).
        where: Where in it the numbers are: table, section, page.
        url: Where to read it online, or "".
    """

    key: str
    citation: str
    where: str
    url: str = ""


@dataclass(frozen=True)
class Material:
    """A sheet material (module docstring).

    Attributes:
        name: Its name, as the library or the user's file writes it.
        tensile_strength_mpa: Tensile strength R_m [MPa].
        yield_strength_mpa: 0.2 % proof strength R_p0.2 [MPa], or None.
        youngs_modulus_gpa: Young's modulus E [GPa], or None.
        poisson_ratio: Poisson's ratio ν [-], in (0, 0.5), or None.
        density_kg_m3: Density ρ [kg/m³], or None.
        hardening: Its hardening law, or None.
        sources: (field, source key) for every field given (`SOURCED_FIELDS`) whose source is named.
        aliases: Other designations of the same material.
        note: Free text: temper, product form, what a number stands for.
    """

    name: str
    tensile_strength_mpa: float
    yield_strength_mpa: float | None = None
    youngs_modulus_gpa: float | None = None
    poisson_ratio: float | None = None
    density_kg_m3: float | None = None
    hardening: HardeningLaw | None = None
    sources: tuple[tuple[str, str], ...] = field(default=())
    aliases: tuple[str, ...] = ()
    note: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"Material.name = {self.name!r}: expected a non-empty name")
        for name in NUMBER_FIELDS:
            value = getattr(self, name)
            if value is None and name != "tensile_strength_mpa":
                continue
            problem = number_problem(name, value)
            if problem:
                raise InputError(f"material {self.name!r}: {name} = {value!r}: {problem}")
            object.__setattr__(self, name, float(value))
        if self.yield_strength_mpa is not None and self.yield_strength_mpa > self.tensile_strength_mpa:
            raise InputError(
                f"material {self.name!r}: yield_strength_mpa = {self.yield_strength_mpa:g} is above "
                f"tensile_strength_mpa = {self.tensile_strength_mpa:g}; expected R_p0.2 <= R_m"
            )
        if self.hardening is not None and not isinstance(self.hardening, HardeningLaw):
            raise InputError(f"material {self.name!r}: hardening = {self.hardening!r}: expected a HardeningLaw")
        for name, _ in self.sources:
            if name not in SOURCED_FIELDS or getattr(self, name) is None:
                raise InputError(f"material {self.name!r}: a source for {name!r}, which it does not give")
        object.__setattr__(self, "sources", tuple(sorted(self.sources)))
        object.__setattr__(self, "aliases", tuple(self.aliases))

    def source_of(self, name: str) -> str | None:
        """The source key of field `name` (`SOURCED_FIELDS`), or None."""
        return dict(self.sources).get(name)

    def given(self) -> tuple[str, ...]:
        """The fields this material gives (`SOURCED_FIELDS` that are not None)."""
        return tuple(name for name in SOURCED_FIELDS if getattr(self, name) is not None)

    def to_json(self) -> dict[str, Any]:
        """Its fields for a JSON summary (the hardening law as kind, parameters and formula)."""
        law = self.hardening
        return {
            "name": self.name,
            "aliases": list(self.aliases),
            **{name: getattr(self, name) for name in NUMBER_FIELDS},
            "hardening": None if law is None else {"kind": law.kind, **law.parameters(), "formula": law.formula()},
            "sources": dict(self.sources),
            "note": self.note,
        }


def number_problem(name: str, value: Any) -> str | None:
    """What is wrong with the value of the number `name` (`NUMBER_FIELDS`), or None: not a finite positive
    number, a strength in Pa (> 5000 "MPa"), a modulus in MPa, a density in g/cm³, Poisson's ratio outside (0, 0.5).
    """
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return "expected a finite number"
    if name == "poisson_ratio":
        return None if 0.0 < value < 0.5 else "expected Poisson's ratio in (0, 0.5)"
    if value <= 0:
        return "expected a number > 0"
    if name.endswith("_mpa") and value > PA_SUSPECT_MPA:
        return "looks like Pa; expected MPa"
    if name.endswith("_mpa") and value < 1.0:
        return "looks like GPa; expected MPa"
    if name == "youngs_modulus_gpa" and value > 2000.0:
        return "looks like MPa or Pa; expected GPa"
    if name == "density_kg_m3" and value < 100.0:
        return "looks like g/cm³; expected kg/m³"
    low, high, why = PLAUSIBLE_NUMBERS.get(name, (0.0, math.inf, ""))
    if not low <= value <= high:
        return f"outside {low:g}..{high:g}, {why}; expected a value in that range"
    return None


def name_key(name: str) -> str:
    """A material name as looked up: upper case, without spaces, hyphens, underscores, dots and slashes, and
    without a leading `EN AW`, `AA` or `AW` ("EN AW-5086-H111" -> "5086H111")."""
    key = re.sub(r"[\s\-_./]", "", name.upper())
    for prefix in _NAME_PREFIXES:
        if key.startswith(prefix) and key[len(prefix):][:1].isdigit():
            return key[len(prefix):]
    return key


def find_material(name: str, materials: Mapping[str, Material]) -> Material | None:
    """The material of `materials` that `name` designates (its name or an alias, `name_key`), or None."""
    key = name_key(name)
    for material in materials.values():
        if key in {name_key(n) for n in (material.name, *material.aliases)}:
            return material
    return None


@dataclass(frozen=True)
class MaterialLibrary:
    """The materials of one file and its bibliography.

    Attributes:
        path: The file.
        materials: Name -> material, in the file's order.
        sources: Key -> bibliography entry.
    """

    path: Path
    materials: Mapping[str, Material]
    sources: Mapping[str, Source]

    def cited(self) -> list[str]:
        """The keys of the sources its materials cite: for a number, or as `[KEY]` in a note or a source's `where`."""
        keys = {key for item in self.materials.values() for _, key in item.sources}
        texts = [item.note for item in self.materials.values()] + [s.where for s in self.sources.values()]
        keys |= {key for text in texts for key in re.findall(r"\[([\w.-]+)\]", text) if key in self.sources}
        return sorted(keys)

