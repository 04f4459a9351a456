"""The materials file (`tx200-twin-materials/1`, TOML): the shipped library and a user's own materials.

    format = "tx200-twin-materials/1"          # optional in a user's file

    [sources.aa-handbook]                      # the bibliography: one entry per source
    citation = "Publisher, Title, edition, year"
    where = "Table 3, p. 12"
    url = "https://..."                        # optional

    [materials."AA5086-H111"]                  # one table per material
    aliases = ["EN AW-5086 H111"]              # other designations (optional)
    tensile_strength_mpa = 275.0               # R_m [MPa], required
    yield_strength_mpa = 100.0                 # R_p0.2 [MPa]; optional, as every number below
    youngs_modulus_gpa = 71.0                  # E [GPa]
    poisson_ratio = 0.33                       # ν [-]
    density_kg_m3 = 2660.0                     # ρ [kg/m³]
    hardening = { kind = "voce", sigma0_mpa = 130.2, q_mpa = 300.37, b = 3.94, m = 0.5 }
    note = "free text"
    [materials."AA5086-H111".sources]          # the source key of each number given
    tensile_strength_mpa = "aa-handbook"

A source key names an entry of the file's `[sources]` (a user's file may also cite the library's). The library
must name a source for every number it gives (`require_sources`); a user's file need not. Every error names the
file and the key (`materials.NAME.KEY`) and says what was expected. The shipped library is read once
(`shipped_library`); `material` finds a name among a user's materials, then the library's.
"""

from __future__ import annotations

import functools
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from twin.base.jsonio import NonFiniteNumberError, finite_float, non_finite_problem
from twin.errors import DataFileError, InputError
from twin.process.material.hardening import HardeningLaw
from twin.process.material.library import (
    NUMBER_FIELDS,
    SOURCED_FIELDS,
    Material,
    MaterialLibrary,
    Source,
    find_material,
    name_key,
    number_problem,
)

MATERIALS_FORMAT = "tx200-twin-materials/1"
#: The keys of a material's table (an inline material of a process file also takes `name`).
MATERIAL_KEYS = (*NUMBER_FIELDS, "hardening", "sources", "aliases", "note")
SOURCE_KEYS = ("citation", "where")
SOURCE_OPTIONAL_KEYS = ("url",)


def read_toml(path: str | Path) -> dict[str, Any]:
    """A TOML file's document; DataFileError naming the file when it is missing or not TOML."""
    path = Path(path)
    if not path.is_file():
        raise DataFileError(path, "file not found")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark (Windows editors) dropped
        return tomllib.loads(text, parse_float=finite_float)
    except NonFiniteNumberError as exc:
        raise non_finite_problem(path, tomllib.loads(text), exc.text) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"not valid TOML: {exc}") from None


def read_material_file(path: str | Path) -> dict[str, Material]:
    """A user's materials file: its materials, by name (module docstring).

    Raises:
        DataFileError: Not TOML, no `[materials.NAME]` table, an unknown key, a missing `tensile_strength_mpa`, a
            bad value (R_m in Pa, a Poisson's ratio outside (0, 0.5), ...), a source not in `[sources]`.
    """
    return dict(read_material_library(path).materials)


def read_material_library(path: str | Path, *, require_sources: bool = False) -> MaterialLibrary:
    """A materials file with its bibliography (module docstring).

    Args:
        path: The file.
        require_sources: Every number and hardening law must name its source (the shipped library).

    Raises:
        DataFileError: As `read_material_file`, naming the file and the key.
    """
    path = Path(path)
    data = read_toml(path)
    if "format" in data and data["format"] != MATERIALS_FORMAT:
        raise DataFileError(path, f"format = {data['format']!r}: expected {MATERIALS_FORMAT!r}")
    unknown = sorted(set(data) - {"format", "sources", "materials"})
    if unknown:
        raise DataFileError(path, f"unknown key(s) {unknown}; a materials file has format, [sources], [materials.NAME]")
    sources = _sources(path, data.get("sources", {}))
    if not require_sources:  # a user's file may cite the library's sources
        sources = {**shipped_library().sources, **sources}
    tables = data.get("materials")
    if not isinstance(tables, Mapping) or not tables:
        raise DataFileError(path, "no [materials.NAME] table; expected one per material, each with tensile_strength_mpa")
    materials: dict[str, Material] = {}
    seen: dict[str, str] = {}
    for name, table in tables.items():
        try:
            entry = material_from_table(name, table, f"materials.{name}", sources, require_sources=require_sources)
        except InputError as exc:
            raise DataFileError(path, str(exc)) from None
        for designation in (entry.name, *entry.aliases):
            other = seen.setdefault(name_key(designation), name)
            if other != name:
                raise DataFileError(path, f"materials.{name}: {designation!r} also designates materials.{other}")
        materials[name] = entry
    return MaterialLibrary(path, materials, sources)


def material_from_table(
    name: str,
    table: Any,
    where: str,
    sources: Mapping[str, Source],
    *,
    require_sources: bool = False,
    inline: bool = False,
) -> Material:
    """A material from its TOML table.

    Args:
        name: Its name (the table's key; an inline table's `name`).
        table: The table.
        where: Its dotted key, for messages (`materials.AA5086-H111`, `material`).
        sources: The bibliography its source keys must be in.
        require_sources: Every number and the hardening law must name a source.
        inline: The table is a process file's inline material (it names itself with `name`).

    Raises:
        InputError: A message that starts with the offending dotted key and says what was expected.
    """
    if not isinstance(table, Mapping):
        raise InputError(f"{where} = {table!r}: expected a table of the material's numbers")
    keys = (*MATERIAL_KEYS, "name") if inline else MATERIAL_KEYS
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise InputError(f"{where}: unknown key(s) {unknown}; expected some of {list(keys)}")
    if "tensile_strength_mpa" not in table:
        raise InputError(f"{where}: missing tensile_strength_mpa (R_m [MPa]); every material needs it")
    for key in NUMBER_FIELDS:
        if key in table and (problem := number_problem(key, table[key])):
            raise InputError(f"{where}.{key} = {table[key]!r}: {problem}")
    hardening = None
    if "hardening" in table:
        if not isinstance(table["hardening"], Mapping):
            raise InputError(f"{where}.hardening = {table['hardening']!r}: expected a table {{kind = ..., ...}}")
        try:
            hardening = HardeningLaw.from_mapping(table["hardening"])
        except InputError as exc:
            raise InputError(f"{where}.hardening: {exc}") from None
    cited = _cited(table.get("sources", {}), where, sources)
    given = [key for key in SOURCED_FIELDS if key in table]
    extra = sorted(set(cited) - set(given))
    if extra:
        raise InputError(f"{where}.sources names a source for {extra}, which the material does not give")
    missing = [key for key in given if key not in cited]
    if require_sources and missing:
        raise InputError(f"{where}: no source for {missing}; name each number's source in {where}.sources")
    aliases = table.get("aliases", [])
    if not (isinstance(aliases, list) and all(isinstance(a, str) and a.strip() for a in aliases)):
        raise InputError(f"{where}.aliases = {aliases!r}: expected a list of names")
    note = table.get("note", "")
    if not isinstance(note, str):
        raise InputError(f"{where}.note = {note!r}: expected text")
    try:
        return Material(
            name=name,
            **{key: table[key] for key in NUMBER_FIELDS if key in table},
            hardening=hardening,
            sources=tuple(cited.items()),
            aliases=tuple(aliases),
            note=note,
        )
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def _cited(entry: Any, where: str, sources: Mapping[str, Source]) -> dict[str, str]:
    """A material's `sources` table: field -> source key, each key in the bibliography."""
    if not isinstance(entry, Mapping):
        raise InputError(f"{where}.sources = {entry!r}: expected a table field = \"source key\"")
    for key, value in entry.items():
        if key not in SOURCED_FIELDS:
            raise InputError(f"{where}.sources.{key}: unknown field; expected some of {list(SOURCED_FIELDS)}")
        if not isinstance(value, str) or value not in sources:
            raise InputError(
                f"{where}.sources.{key} = {value!r}: not an entry of [sources]; known: {sorted(sources)}"
            )
    return dict(entry)


def _sources(path: Path, entry: Any) -> dict[str, Source]:
    """The `[sources]` bibliography."""
    if not isinstance(entry, Mapping):
        raise DataFileError(path, f"sources = {entry!r}: expected tables [sources.KEY] with citation and where")
    out: dict[str, Source] = {}
    for key, table in entry.items():
        keys = (*SOURCE_KEYS, *SOURCE_OPTIONAL_KEYS)
        if not isinstance(table, Mapping) or not set(SOURCE_KEYS) <= set(table) <= set(keys):
            raise DataFileError(path, f"sources.{key}: expected the keys {list(SOURCE_KEYS)} (and optionally url)")
        if not all(isinstance(value, str) and value.strip() for value in table.values()):
            raise DataFileError(path, f"sources.{key}: {list(table)} must be non-empty text")
        out[key] = Source(key, table["citation"].strip(), table["where"].strip(), table.get("url", "").strip())
    return out


def library_path() -> Path:
    """The shipped library file, `models/materials/library.toml`."""
    from twin.base.resources import models_dir

    return models_dir() / "materials" / "library.toml"


@functools.cache
def shipped_library() -> MaterialLibrary:
    """The shipped library, every number with its source (read once)."""
    return read_material_library(library_path(), require_sources=True)


def shipped_materials() -> dict[str, Material]:
    """The shipped materials, by name."""
    return dict(shipped_library().materials)


def material(name: str, user: Mapping[str, Material] | None = None) -> Material:
    """The material `name` designates: first among the user's materials, then in the library.

    Args:
        name: A name or designation ("AA5086-H111", "EN AW-5086-H111", "1.4301", ...; case does not matter).
        user: The user's materials (`read_material_file`), or None.

    Raises:
        InputError: No such material (the message lists the library and the user's materials).
    """
    for materials in (user or {}, shipped_library().materials):
        found = find_material(name, materials)
        if found is not None:
            return found
    known = [*(user or {}), *shipped_library().materials]
    alloy = re.match(r"\d{4}", name_key(name))
    close = [n for n in known if alloy and name_key(n).startswith(alloy.group())]
    hint = f" (did you mean {' or '.join(close)}?)" if close else ""
    raise InputError(
        f"unknown material {name!r}{hint}; known: {', '.join(known)}. A material of your own: a materials "
        "file (`material_file` of a process file)"
    )
