"""`tx200-twin materials`: the sheet-material library (or a user's materials file), each number with its source."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from twin.base.jsonio import emit_json
from twin.cli._common import add_json_argument
from twin.process.material.file import read_material_library
from twin.process.material.library import Material, MaterialLibrary, library_path, shipped_library

HELP = "List the sheet materials (R_m, R_p0.2, E, ν, ρ, hardening law), each number's source and the bibliography."

#: (field, column title, format) of the table.
COLUMNS = (
    ("tensile_strength_mpa", "R_m [MPa]", "g"),
    ("yield_strength_mpa", "R_p0.2 [MPa]", "g"),
    ("youngs_modulus_gpa", "E [GPa]", "g"),
    ("poisson_ratio", "ν [-]", "g"),
    ("density_kg_m3", "ρ [kg/m³]", "g"),
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `materials` options."""
    parser.add_argument(
        "--file", type=Path, metavar="FILE.toml", help="list a materials file of your own (same format as the library)"
    )
    add_json_argument(parser, "the materials and the bibliography")


def run(args: argparse.Namespace) -> int:
    """List the materials."""
    library = shipped_library() if args.file is None else read_material_library(args.file)
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    print(_table(library), file=out)
    emit_json(args.json, _payload(library), protect=[p for p in (args.file, library_path()) if p is not None])
    return 0


def _cell(material: Material, field: str, spec: str) -> str:
    """A number with its source key, or a dash where the material gives none."""
    value = getattr(material, field)
    return "-" if value is None else f"{value:{spec}} [{material.source_of(field) or '?'}]"


def _table(library: MaterialLibrary) -> str:
    """The human listing: one row per material, then its hardening law, then the bibliography."""
    header = ["material", *(title for _, title, _ in COLUMNS)]
    rows = [[m.name, *(_cell(m, f, spec) for f, _, spec in COLUMNS)] for m in library.materials.values()]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    lines = [f"{library.path}: {len(rows)} material(s); [key]: the source of each number"]
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in [header, *rows]]
    lines.append("hardening laws (true stress, true plastic strain ε):")
    for m in library.materials.values():
        law = "-" if m.hardening is None else f"{m.hardening.formula()} [{m.source_of('hardening') or '?'}]"
        lines.append(f"  {m.name}: {law}" + (f"; {m.note}" if m.note else ""))
    lines.append("sources:")
    for key in library.cited():
        source = library.sources[key]
        lines.append(f"  [{key}] {source.citation}. {source.where}" + (f" {source.url}" if source.url else ""))
    return "\n".join(lines)


def _payload(library: MaterialLibrary) -> dict[str, Any]:
    """The `--json` document: the file, the materials and the entries of the bibliography they cite."""
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
