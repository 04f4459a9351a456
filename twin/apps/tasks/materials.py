"""`materials`: the sheet-material library (or a user's materials file) as a table, each number beside the key of
its source, then each material's hardening law and the bibliography the numbers cite; the JSON document holds the
file, the materials and the cited sources.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from twin.apps.tasks.base import Note, Report, silent
from twin.process.material.file import read_material_library, shipped_library
from twin.process.material.library import Material, MaterialLibrary

#: (field, column title, format) of the table.
COLUMNS = (
    ("tensile_strength_mpa", "R_m [MPa]", "g"),
    ("yield_strength_mpa", "R_p0.2 [MPa]", "g"),
    ("youngs_modulus_gpa", "E [GPa]", "g"),
    ("poisson_ratio", "ν [-]", "g"),
    ("density_kg_m3", "ρ [kg/m³]", "g"),
)


@dataclass(frozen=True)
class MaterialsRequest:
    """Which materials to list.

    Attributes:
        file: A materials file (the library's format), or None for the shipped library.
    """

    file: Path | None = None


@dataclass(frozen=True)
class MaterialsReport(Report):
    """A materials library as read.

    Attributes:
        library: The materials and their bibliography.
    """

    library: MaterialLibrary

    def lines(self) -> list[str]:
        """One row per material, then its hardening law, then the bibliography."""
        library = self.library
        header = ["material", *(title for _, title, _ in COLUMNS)]
        rows = [[m.name, *(_cell(m, f, spec) for f, _, spec in COLUMNS)] for m in library.materials.values()]
        widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
        lines = [f"{library.path}: {len(rows)} material(s); [key]: the source of each number"]
        lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
                  for row in [header, *rows]]
        lines.append("hardening laws (true stress, true plastic strain ε):")
        for m in library.materials.values():
            law = "-" if m.hardening is None else f"{m.hardening.formula()} [{m.source_of('hardening') or '?'}]"
            lines.append(f"  {m.name}: {law}" + (f"; {m.note}" if m.note else ""))
        lines.append("sources:")
        for key in library.cited():
            source = library.sources[key]
            lines.append(f"  [{key}] {source.citation}. {source.where}" + (f" {source.url}" if source.url else ""))
        return lines

    def record(self) -> dict[str, Any]:
        """The file, the materials and the entries of the bibliography they cite."""
        library = self.library
        cited = library.cited()
        return {
            "file": library.path,
            "materials": [m.to_json() for m in library.materials.values()],
            "sources": {
                key: {"citation": s.citation, "where": s.where, "url": s.url}
                for key, s in sorted(library.sources.items())
                if key in cited
            },
        }


def materials_task(request: MaterialsRequest, note: Note = silent) -> MaterialsReport:
    """Read the shipped library or the request's materials file.

    Raises:
        DataFileError: A bad materials file (naming the file and the key).
    """
    library = shipped_library() if request.file is None else read_material_library(request.file)
    return MaterialsReport(library)


def _cell(material: Material, field: str, spec: str) -> str:
    """A number with its source key, or a dash where the material gives none."""
    value = getattr(material, field)
    return "-" if value is None else f"{value:{spec}} [{material.source_of(field) or '?'}]"
