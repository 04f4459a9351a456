"""The process as the user declares it: a process file (`tx200-twin-process/1`, TOML), and the record of a process.

    format = "tx200-twin-process/1"
    material = "AA1050-O"             # a library name (`tx200-twin materials`), one of material_file's,
                                      # or an inline table { name = "...", tensile_strength_mpa = ..., ... }
    material_file = "materials.toml"  # optional: the user's materials (`twin.process.material.file`), relative to
                                      # this file
    thickness_mm = 1.5                # sheet thickness t [mm]
    tool_radius_mm = 7.5              # tool radius R [mm], larger than t
    tool_friction = 0.1               # tool-sheet Coulomb friction [-]
    force_model = "isf"               # a registered force model, or "auto"

Every key but `format` may be left out: it keeps the value of the process the file is applied to (the model
file's, the run's, else the thesis's). A `ProcessDeclaration` is what a file or the command line declares;
`applied_to` lays it over a process and checks that the tool is larger than the sheet is thick, naming where each
value came from. `process_record` / `process_from_record` are the process as `meta.json` records it (millimetres
at the edge, SI inside).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from twin.errors import DataFileError, InputError
from twin.process.description import PLAUSIBLE, Process, check_plausible
from twin.process.material.file import (
    material,
    material_from_table,
    read_material_library,
    read_toml,
    shipped_library,
)
from twin.process.material.library import Material, number_problem

PROCESS_FORMAT = "tx200-twin-process/1"
PROCESS_KEYS = ("format", "material", "material_file", "thickness_mm", "tool_radius_mm", "tool_friction", "force_model")
#: The process as runs record it (`meta.json`'s `process`).
RECORD_KEYS = ("material", "tensile_strength_mpa", "thickness_mm", "tool_radius_mm", "tool_friction")


@dataclass(frozen=True)
class ProcessDeclaration:
    """What a process file or the command line declares; None: not declared (the underlying process's value).

    Attributes:
        material: The sheet material (its name and R_m go into the process).
        thickness_m: Sheet thickness [m].
        tool_radius_m: Tool radius [m].
        tool_friction: Tool-sheet friction coefficient [-].
        force_model: A registered force model's name.
        origins: (field, where it was declared: an option as typed, or "FILE: key") of each declared field.
    """

    material: Material | None = None
    thickness_m: float | None = None
    tool_radius_m: float | None = None
    tool_friction: float | None = None
    force_model: str | None = None
    origins: tuple[tuple[str, str], ...] = ()

    def over(self, under: ProcessDeclaration) -> ProcessDeclaration:
        """This declaration laid over `under`: what this one declares wins."""
        changes = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "origins"}
        merged = replace(under, **{k: v for k, v in changes.items() if v is not None})
        return replace(merged, origins=tuple({**dict(under.origins), **dict(self.origins)}.items()))

    def applied_to(self, base: Process, base_name: str | None = None) -> Process:
        """`base` with the declared values.

        Args:
            base: The process declared over.
            base_name: Where `base` comes from, for messages ("the run's recorded process"); None: "the thesis's
                process" for the default one.

        Raises:
            InputError: The tool radius is not larger than the sheet thickness, or a value outside its physically
                plausible range (`twin.process.description.PLAUSIBLE`), naming where each came from.
        """
        where = dict(self.origins)
        base_name = base_name or ("the thesis's process" if base == Process() else "the process it applies to")
        thickness = base.thickness_m if self.thickness_m is None else self.thickness_m
        radius = base.tool_radius_m if self.tool_radius_m is None else self.tool_radius_m
        if radius <= thickness:
            raise InputError(
                f"tool radius {1e3 * radius:g} mm ({where.get('tool_radius_m', base_name)}) is not larger "
                f"than the sheet thickness {1e3 * thickness:g} mm ({where.get('thickness_m', base_name)}): "
                "a tool smaller than the sheet is thick; expected tool radius > thickness"
            )
        for name, value in (("thickness_m", thickness), ("tool_radius_m", radius)):
            check_plausible(name, value, where.get(name, base_name))
        if self.tool_friction is not None:
            check_plausible("tool_friction", self.tool_friction, where.get("tool_friction", "tool_friction"))
        changes: dict[str, Any] = {"thickness_m": thickness, "tool_radius_m": radius}
        if self.material is not None:
            changes |= {"material": self.material.name, "tensile_strength_mpa": self.material.tensile_strength_mpa}
        if self.tool_friction is not None:
            changes["tool_friction"] = self.tool_friction
        if self.force_model is not None:
            changes["force_model"] = self.force_model
        return replace(base, **changes)


def read_process_file(path: str | Path, base: Process | None = None) -> Process:
    """The process a process file declares (module docstring), over `base` (default: the thesis's process).

    Raises:
        DataFileError: Not TOML, a wrong format, an unknown key (the message lists the valid ones), an unknown
            material, a bad value, a tool not larger than the sheet is thick; naming the file and the key.
    """
    try:
        return read_process_declaration(path).applied_to(base or Process())
    except DataFileError:
        raise
    except InputError as exc:
        raise DataFileError(path, str(exc)) from None


def read_process_declaration(path: str | Path) -> ProcessDeclaration:
    """What a process file declares (module docstring); errors as `read_process_file`."""
    path = Path(path)
    data = read_toml(path)
    if data.get("format") != PROCESS_FORMAT:
        raise DataFileError(path, f"format = {data.get('format')!r}: expected {PROCESS_FORMAT!r}")
    unknown = sorted(set(data) - set(PROCESS_KEYS))
    if unknown:
        raise DataFileError(path, f"unknown key(s) {unknown}; a process file takes {list(PROCESS_KEYS)}")
    return declaration_from_table(path, data)


def declaration_from_table(path: Path, data: Mapping[str, Any], where: str = "") -> ProcessDeclaration:
    """What a table of a process file's keys declares (a process file, a cell file's `[process]`); `where` prefixes
    the keys in messages and origins (e.g. "process.")."""
    origins: dict[str, str] = {}
    values: dict[str, Any] = {}
    try:
        for key, name in (("thickness_mm", "thickness_m"), ("tool_radius_mm", "tool_radius_m")):
            if key in data:
                values[name] = positive(where + key, data[key]) / 1e3
                origins[name] = f"{path}: {where}{key}"
        if "tool_friction" in data:
            values["tool_friction"] = friction(data["tool_friction"], where + "tool_friction")
            origins["tool_friction"] = f"{path}: {where}tool_friction"
        if data.get("force_model", "auto") != "auto":
            values["force_model"] = registered_force_model(data["force_model"], where + "force_model")
    except InputError as exc:
        raise DataFileError(path, str(exc)) from None
    if "material" in data:
        values["material"] = _material(path, data)
    elif "material_file" in data:
        raise DataFileError(path, "material_file names the user's materials; say which one with material = NAME")
    return ProcessDeclaration(**values, origins=tuple(origins.items()))


def declare_process(
    file: str | Path | None = None,
    material_name: str | None = None,
    thickness_mm: float | None = None,
    tool_radius_mm: float | None = None,
) -> ProcessDeclaration:
    """What a user declares: a process file, and values given one by one over it (the CLI's `--material`,
    `--thickness-mm`, `--tool-radius-mm`, named so in messages).

    Raises:
        InputError: An unknown material, a length that is not > 0 (naming the option).
        DataFileError: A bad process file (naming the file and the key).
    """
    declared = ProcessDeclaration() if file is None else read_process_declaration(file)
    flags: dict[str, Any] = {}
    origins: dict[str, str] = {}
    if material_name is not None:
        try:
            flags["material"] = material(material_name)
        except InputError as exc:
            raise InputError(f"--material {material_name}: {exc}") from None
    for option, name, value in (("--thickness-mm", "thickness_m", thickness_mm),
                                ("--tool-radius-mm", "tool_radius_m", tool_radius_mm)):
        if value is not None:
            flags[name] = positive(option, value) / 1e3
            origins[name] = f"{option} {value:g}"
    return ProcessDeclaration(**flags, origins=tuple(origins.items())).over(declared)


def _material(path: Path, data: Mapping[str, Any]) -> Material:
    """The process file's `material`: a name (of `material_file` or the library) or an inline table."""
    user: dict[str, Material] = {}
    sources = dict(shipped_library().sources)
    if "material_file" in data:
        if not isinstance(data["material_file"], str) or not data["material_file"]:
            raise DataFileError(path, f"material_file = {data['material_file']!r}: expected a file name")
        file = Path(data["material_file"])
        library = read_material_library(file if file.is_absolute() else path.parent / file)
        user, sources = dict(library.materials), {**sources, **library.sources}
    entry = data["material"]
    try:
        if isinstance(entry, str):
            return material(entry, user)
        if isinstance(entry, Mapping):
            name = entry.get("name")
            if not isinstance(name, str) or not name.strip():
                raise InputError(f"material.name = {name!r}: an inline material needs a name")
            return material_from_table(name, entry, "material", sources, inline=True)
    except InputError as exc:
        raise DataFileError(path, f"material: {exc}" if isinstance(entry, str) else str(exc)) from None
    raise DataFileError(path, f"material = {entry!r}: expected a material name or an inline table")


def process_for(
    material_: Material | str,
    *,
    thickness_m: float | None = None,
    tool_radius_m: float | None = None,
    tool_friction: float | None = None,
    force_model: str | None = None,
    base: Process | None = None,
) -> Process:
    """A process of a material (a `Material`, or a name of the library), over `base` (default: the thesis's).

    Args:
        material_: The sheet material; its name and tensile strength go into the process.
        thickness_m: Sheet thickness [m]; None: the base's.
        tool_radius_m: Tool radius [m], larger than the thickness; None: the base's.
        tool_friction: Tool-sheet friction [-]; None: the base's.
        force_model: A registered force model; None: the base's.
        base: The process to change.

    Raises:
        InputError: An unknown material, a bad value, a tool not larger than the sheet is thick.
    """
    chosen = material(material_) if isinstance(material_, str) else material_
    origins = {name: f"{name}={value!r}" for name, value in
               (("thickness_m", thickness_m), ("tool_radius_m", tool_radius_m)) if value is not None}
    return ProcessDeclaration(
        material=chosen,
        thickness_m=None if thickness_m is None else positive("thickness_m", thickness_m),
        tool_radius_m=None if tool_radius_m is None else positive("tool_radius_m", tool_radius_m),
        tool_friction=None if tool_friction is None else friction(tool_friction, "tool_friction"),
        force_model=None if force_model is None else registered_force_model(force_model, "force_model"),
        origins=tuple(origins.items()),
    ).applied_to(base or Process())


def positive(key: str, value: Any, what: str = "length") -> float:
    """A number as given, checked finite and > 0 (InputError naming `key` and saying it expected a `what`)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not (math.isfinite(value) and value > 0):
        raise InputError(f"{key} = {value!r}: expected a finite {what} > 0")
    return float(value)


def friction(value: Any, key: str) -> float:
    """A friction coefficient as given, checked finite and >= 0 (InputError naming `key`)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not (math.isfinite(value) and value >= 0):
        raise InputError(f"{key} = {value!r}: expected a finite friction coefficient >= 0")
    return float(value)


def registered_force_model(name: Any, key: str) -> str:
    """A registered force model's name (InputError naming `key` and listing the registered models)."""
    from twin.process.force.registry import FORCE_MODELS

    if not isinstance(name, str) or name not in FORCE_MODELS:
        raise InputError(f"{key} = {name!r}: expected 'auto' or a registered force model {sorted(FORCE_MODELS)}")
    return name


def process_record(process: Process) -> dict[str, Any]:
    """The process as `meta.json` records it (`RECORD_KEYS`; lengths [mm])."""
    return {
        "material": process.material,
        "tensile_strength_mpa": process.tensile_strength_mpa,
        "thickness_mm": round(1e3 * process.thickness_m, 12),
        "tool_radius_mm": round(1e3 * process.tool_radius_m, 12),
        "tool_friction": process.tool_friction,
    }


def process_from_record(entry: Any, base: Process, where: str = "process") -> Process:
    """`base` with what a record (`process_record`, a model file's `process`) gives; a library material's name
    without `tensile_strength_mpa` takes the library's R_m.

    Raises:
        InputError: Not an object, a bad value or an unknown material without R_m (naming `where.key`).
    """
    if not isinstance(entry, Mapping):
        raise InputError(f"{where} = {entry!r}: expected an object with some of {list(RECORD_KEYS)}")
    changes: dict[str, Any] = {}
    if "material" in entry:
        name = entry["material"]
        if not isinstance(name, str) or not name.strip():
            raise InputError(f"{where}.material = {name!r}: expected a material name")
        changes["material"] = name
        if "tensile_strength_mpa" not in entry:
            try:
                changes["tensile_strength_mpa"] = material(name).tensile_strength_mpa
            except InputError as exc:
                raise InputError(f"{where}.material: {exc}; or give {where}.tensile_strength_mpa") from None
    if "tensile_strength_mpa" in entry:
        value = entry["tensile_strength_mpa"]
        problem = number_problem("tensile_strength_mpa", value)
        if problem:
            raise InputError(f"{where}.tensile_strength_mpa = {value!r}: {problem}")
        changes["tensile_strength_mpa"] = float(value)
    for key, name in (("thickness_mm", "thickness_m"), ("tool_radius_mm", "tool_radius_m")):
        if key in entry:
            changes[name] = positive(f"{where}.{key}", entry[key]) / 1e3
    if "tool_friction" in entry:
        changes["tool_friction"] = friction(entry["tool_friction"], f"{where}.tool_friction")
    for name, value in changes.items():
        if name in PLAUSIBLE:
            key = {"thickness_m": "thickness_mm", "tool_radius_m": "tool_radius_mm"}.get(name, name)
            check_plausible(name, value, f"{where}.{key}")
    return replace(base, **changes)
