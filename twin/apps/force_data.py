"""Published measurements of ISF forming forces (`twin/data/force_measurements.toml`), read as validated records.

The file holds what sources measured, with the conditions of each test and where in the source each number
stands: steady and peak axial forces of formed parts (`Case`), ratios of forces under one change of condition
(`Trend`), and the build-up of the axial force with depth on one cone (`BuildUp`). Nothing in it comes from the
twin; `twin.apps.force_validation` puts the twin's predictions beside it.
"""

from __future__ import annotations

import functools
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.resources import data_file
from twin.errors import DataFileError

FORMAT = "tx200-twin-force-measurements/1"


@dataclass(frozen=True)
class Source:
    """One publication.

    Attributes:
        key: Its key in the file.
        citation: Authors, title, journal, volume, year, pages, doi.
        group: The research group (independence of sources).
        read: What was read and where (primary or secondary).
    """

    key: str
    citation: str
    group: str
    read: str


@dataclass(frozen=True)
class Case:
    """A formed part whose axial force was published.

    Attributes:
        key: Short name.
        source: Key of its `Source`.
        where: Table, figure or section of the number.
        material: Sheet material as the source names it.
        tensile_strength_mpa: R_m the source gives [MPa], or None (then the library's value of `material`).
        tensile_strength_source: Where R_m comes from.
        thickness_m: Sheet thickness [m].
        tool_radius_m: Tool radius [m].
        step_down_m: Step-down [m].
        wall_angle_deg: Wall angle [deg].
        shape: `cone` or `groove`.
        strategy: Tool-path strategy as the source describes it.
        top_diameter_m: Diameter of the first contour [m] (cones), else None.
        depth_m: Depth of the part [m].
        fz_steady_n: Published steady axial force [N], or None.
        fz_peak_n: Published peak axial force [N], or None.
        approximate: Whether the number was read from a figure or stated as "about".
    """

    key: str
    source: str
    where: str
    material: str
    tensile_strength_mpa: float | None
    tensile_strength_source: str
    thickness_m: float
    tool_radius_m: float
    step_down_m: float
    wall_angle_deg: float
    shape: str
    strategy: str
    top_diameter_m: float | None
    depth_m: float
    fz_steady_n: float | None
    fz_peak_n: float | None
    approximate: bool


@dataclass(frozen=True)
class Trend:
    """A published ratio of two forces under one change of condition.

    Attributes:
        key: Short name.
        source: Key of its `Source`.
        where: Where the ratio stands, quoted.
        material: Sheet material.
        condition: The condition changed (`thickness_mm`).
        from_value: Its first value.
        to_value: Its second value.
        tool_diameter_mm: Tool diameter of the tests [mm].
        ratio: Published force at `to_value` over force at `from_value` [-].
        note: What the source leaves out.
    """

    key: str
    source: str
    where: str
    material: str
    condition: str
    from_value: float
    to_value: float
    tool_diameter_mm: float
    ratio: float
    note: str


@dataclass(frozen=True)
class BuildUp:
    """Window means of a measured axial force over depth.

    Attributes:
        source: Key of its `Source`.
        where: Where the numbers stand.
        derived: How the depths were derived from the source's own numbers.
        depth_from_m: Start depth of each window [m].
        depth_to_m: End depth of each window [m].
        fz_mean_n: Mean axial force over each window [N].
    """

    source: str
    where: str
    derived: str
    depth_from_m: np.ndarray
    depth_to_m: np.ndarray
    fz_mean_n: np.ndarray


@dataclass(frozen=True)
class Measurements:
    """The whole file."""

    sources: dict[str, Source]
    cases: tuple[Case, ...]
    trends: tuple[Trend, ...]
    build_up: BuildUp


def _number(path: Path, table: dict[str, Any], key: str, where: str, optional: bool = False) -> float | None:
    value = table.get(key)
    if value is None and optional:
        return None
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value) or value <= 0:
        raise DataFileError(path, f"{where}: {key} = {value!r}, expected a positive number")
    return float(value)


def read_measurements(path: str | Path | None = None) -> Measurements:
    """Read and check the measurements file (default: the shipped one).

    Raises:
        DataFileError: A missing key, a bad number, an unknown source.
    """
    path = Path(path) if path is not None else data_file("force_measurements.toml")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise DataFileError(path, f"cannot read it as TOML: {exc}") from None
    if doc.get("format") != FORMAT:
        raise DataFileError(path, f"format = {doc.get('format')!r}, expected {FORMAT!r}")
    try:
        sources = {k: Source(k, v["citation"], v["group"], v["read"]) for k, v in doc["sources"].items()}
        cases = []
        for i, c in enumerate(doc["cases"]):
            where = f"cases[{i}] ({c.get('key')!r})"
            if c["source"] not in sources:
                raise DataFileError(path, f"{where}: source {c['source']!r} is not in [sources] {sorted(sources)}")
            top = _number(path, c, "top_diameter_mm", where, optional=True)
            cases.append(Case(
                key=c["key"], source=c["source"], where=c["where"], material=c["material"],
                tensile_strength_mpa=_number(path, c, "tensile_strength_mpa", where, optional=True),
                tensile_strength_source=c["tensile_strength_source"],
                thickness_m=1e-3 * float(_number(path, c, "thickness_mm", where) or 0.0),
                tool_radius_m=0.5e-3 * float(_number(path, c, "tool_diameter_mm", where) or 0.0),
                step_down_m=1e-3 * float(_number(path, c, "step_down_mm", where) or 0.0),
                wall_angle_deg=float(_number(path, c, "wall_angle_deg", where) or 0.0),
                shape=c["shape"], strategy=c["strategy"], top_diameter_m=None if top is None else 1e-3 * top,
                depth_m=1e-3 * float(_number(path, c, "depth_mm", where) or 0.0),
                fz_steady_n=_number(path, c, "fz_steady_n", where, optional=True),
                fz_peak_n=_number(path, c, "fz_peak_n", where, optional=True),
                approximate=bool(c["approximate"]),
            ))
        trends = tuple(
            Trend(t["key"], t["source"], t["where"], t["material"], t["condition"], float(t["from_value"]),
                  float(t["to_value"]), float(t["tool_diameter_mm"]), float(t["ratio"]), t["note"])
            for t in doc.get("trends", [])
        )
        b = doc["build_up"]
        build = BuildUp(b["source"], b["where"], b["derived"], 1e-3 * np.asarray(b["depth_from_mm"], dtype=float),
                        1e-3 * np.asarray(b["depth_to_mm"], dtype=float), np.asarray(b["fz_mean_n"], dtype=float))
    except KeyError as exc:
        raise DataFileError(path, f"missing key {exc.args[0]!r}") from None
    if not (len(build.depth_from_m) == len(build.depth_to_m) == len(build.fz_mean_n) >= 2):
        raise DataFileError(path, "build_up: depth_from_mm, depth_to_mm and fz_mean_n must have one equal length >= 2")
    return Measurements(sources, tuple(cases), trends, build)


@functools.cache
def shipped_measurements() -> Measurements:
    """The shipped file, read once."""
    return read_measurements()
