"""Property-based fuzzing of every reader: any input gives a result or a `TwinError`, never another exception.

Readers: CSV tables (`twin.base.csvio`, the path reader of `twin.runs.read`), the importer's raw tables in every
dialect (delimiter, decimal, header line, encoding), the import mapping's TOML, G-code, a run's meta.json, STL
meshes (`read_target_mesh`) and point clouds (`read_scan`). Inputs are raw bytes and texts built from each format's
own vocabulary (so the fuzzing reaches past the first line). Deterministic (`derandomize`), 40-60 examples each.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twin.analysis.surface_check import read_target_mesh
from twin.base.csvio import read_table
from twin.base.jsonio import read_json
from twin.cli import main
from twin.errors import TwinError
from twin.process.toolpath.gcode import parse_gcode, read_gcode
from twin.runs.mapping import TableSpec, load_mapping, mapping_keys
from twin.runs.raw_tables import read_raw_table
from twin.runs.read import read_commanded_csv, read_run
from twin.runs.scan_file import read_scan

FUZZ = settings(max_examples=50, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**6, 10**6).map(str),
    st.sampled_from(["", "1e300", "-1e-300", "nan", "inf", "1,5", "0x10", "abc", "µ", "1.2.3", " 7 "]),
)


def _returns_or_refuses(read: Callable[[], Any]) -> None:
    with contextlib.suppress(TwinError):  # a refusal; any other exception fails the test
        read()


def _file(data: bytes, suffix: str) -> Path:
    folder = Path(tempfile.mkdtemp(prefix="fuzz"))
    path = folder / f"input{suffix}"
    path.write_bytes(data)
    return path


@st.composite
def csv_texts(draw: st.DrawFn, columns: tuple[str, ...] = ("t_s", "x_mm", "y_mm", "z_mm")) -> bytes:
    """A CSV in some dialect: a header (maybe misspelt, maybe in metres), rows of numbers or junk."""
    delimiter = draw(st.sampled_from([",", ";", "\t", " "]))
    header = [draw(st.sampled_from([c, c.replace("_mm", "_m"), c.upper(), "junk"])) for c in columns]
    rows = draw(st.lists(st.lists(NUMBERS, min_size=0, max_size=len(columns) + 1), max_size=8))
    text = delimiter.join(header) + "\n" + "\n".join(delimiter.join(r) for r in rows)
    prefix = draw(st.sampled_from(["", "\ufeff", "# comment, with commas\n", "\n\n"]))
    return (prefix + text).encode(draw(st.sampled_from(["utf-8", "latin-1", "utf-16"])), errors="replace")


@FUZZ
@given(data=st.one_of(st.binary(max_size=300), csv_texts()))
def test_csv_tables_and_paths(data: bytes) -> None:
    path = _file(data, ".csv")
    _returns_or_refuses(lambda: read_table(path, ("t_s", "x_mm")))
    _returns_or_refuses(lambda: read_commanded_csv(path))
    shutil.rmtree(path.parent)


@FUZZ
@given(data=st.one_of(st.binary(max_size=300), csv_texts(("t", "x", "y", "z"))),
       delimiter=st.sampled_from([",", ";", "\t"]), decimal=st.sampled_from([".", ","]),
       header_line=st.integers(0, 3), encoding=st.sampled_from(["utf-8-sig", "latin-1", "utf-16"]),
       by_index=st.booleans(), rate=st.booleans())
def test_importer_raw_tables_in_every_dialect(
    data: bytes, delimiter: str, decimal: str, header_line: int, encoding: str, by_index: bool, rate: bool
) -> None:
    path = _file(data, ".csv")
    columns: tuple[str | int, ...] = (1, 2, 3) if by_index or header_line == 0 else ("x", "y", "z")
    time: str | int | None = None if rate else (0 if by_index or header_line == 0 else "t")
    spec = TableSpec("tracker", path, delimiter, decimal, header_line, columns, 1e-3, time, 1e-3,
                     100.0 if rate else None, encoding)
    _returns_or_refuses(lambda: read_raw_table(spec))
    shutil.rmtree(path.parent)


TOML_VALUES = st.one_of(
    st.integers(-5, 5).map(str), st.floats(allow_nan=False).map(repr),
    st.sampled_from(['"mm"', '"kN"', '"µm"', '"tab"', '","', '"t"', '"x"', '"motion_onset"', '"latin-1"', '"nope"',
                     "[[0, 0, 0], [1, 0, 0], [0, 1, 0]]", "[1, 2]", "true", '"cmd.csv"', '"missing.csv"', "nan",
                     "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"]),
)


@st.composite
def mapping_texts(draw: st.DrawFn) -> bytes:
    """A TOML mapping from the schema's keys (some misspelt) with values of any of its kinds."""
    keys = draw(st.lists(st.sampled_from([*mapping_keys(), "forces.delimeter", "run.scenari"]), max_size=25))
    tables: dict[str, list[str]] = {}
    for key in keys:
        table, name = key.rsplit(".", 1)
        tables.setdefault(table, []).append(f"{name} = {draw(TOML_VALUES)}")
    text = "\n".join(f"[{table}]\n" + "\n".join(dict.fromkeys(lines)) for table, lines in tables.items())
    return text.encode()


@FUZZ
@given(data=st.one_of(st.binary(max_size=200), mapping_texts()))
def test_mapping_toml(data: bytes) -> None:
    path = _file(data, ".toml")
    (path.parent / "cmd.csv").write_text("t,x,y,z\n0,0,0,0\n1,1,0,0\n")
    _returns_or_refuses(lambda: load_mapping(path))
    shutil.rmtree(path.parent)


WORDS = st.builds(lambda letter, number: f"{letter}{number}", st.sampled_from(list("GXYZIJRFNMPSTQ")),
                  st.one_of(st.sampled_from(["0", "1", "2", "3", "-5", "90", "17", "1e300", "", "."]),
                            st.floats(-1e4, 1e4).map(lambda v: f"{v:.3f}")))
GCODE = st.lists(st.lists(WORDS, max_size=6).map(" ".join).map(
    lambda line: line if line else "(comment)"), max_size=12).map("\n".join)


@FUZZ
@given(text=GCODE, junk=st.binary(max_size=100))
def test_gcode(text: str, junk: bytes) -> None:
    _returns_or_refuses(lambda: parse_gcode(text))
    path = _file(junk, ".nc")
    _returns_or_refuses(lambda: read_gcode(path))
    shutil.rmtree(path.parent)


JSON = st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
                    max_leaves=12)


@pytest.fixture(scope="module")
def lab_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("lab") / "run"
    assert main(["lab", "--scenario", "nominal", "--seed", "2", "--out", str(folder)]) == 0
    return folder


META_KEYS = ["format", "frame", "tool_length_m", "sample_rate_hz", "sensor_rate_hz", "robot", "process",
             "placement", "force_model", "scenario", "sheet_origin_base_m"]


@FUZZ
@given(edit=st.dictionaries(st.sampled_from(META_KEYS), JSON, max_size=4), drop=st.lists(st.sampled_from(META_KEYS)),
       junk=st.binary(max_size=60), whole=st.booleans())
def test_run_meta_json(lab_run: Path, edit: dict[str, Any], drop: list[str], junk: bytes, whole: bool) -> None:
    folder = Path(tempfile.mkdtemp(prefix="fuzz")) / "run"
    shutil.copytree(lab_run, folder)
    meta = json.loads((folder / "meta.json").read_text())
    meta.update(edit)
    for key in drop:
        meta.pop(key, None)
    (folder / "meta.json").write_bytes(junk if whole else json.dumps(meta).encode())
    _returns_or_refuses(lambda: read_json(folder / "meta.json"))
    _returns_or_refuses(lambda: read_run(folder))
    shutil.rmtree(folder.parent)


COORD = st.one_of(st.floats(-200, 200), st.sampled_from([float("nan"), float("inf"), 1e300, 0.0]))


@st.composite
def ascii_stls(draw: st.DrawFn) -> bytes:
    facets = draw(st.lists(st.lists(st.tuples(COORD, COORD, COORD), min_size=3, max_size=3), max_size=6))
    body = "".join("facet normal 0 0 1\nouter loop\n" + "".join(f"vertex {x!r} {y!r} {z!r}\n" for x, y, z in f)
                   + "endloop\nendfacet\n" for f in facets)
    return f"solid fuzz\n{body}endsolid fuzz\n".encode()


@FUZZ
@given(data=st.one_of(st.binary(max_size=300), ascii_stls()))
def test_stl_meshes(data: bytes) -> None:
    path = _file(data, ".stl")
    _returns_or_refuses(lambda: read_target_mesh(path))
    shutil.rmtree(path.parent)


@st.composite
def point_clouds(draw: st.DrawFn) -> tuple[bytes, str]:
    suffix = draw(st.sampled_from([".xyz", ".csv", ".ply", ".txt", ".pts"]))
    points = draw(st.lists(st.tuples(COORD, COORD, COORD), max_size=40))
    if suffix == ".csv":
        header = draw(st.sampled_from(["x_mm,y_mm,z_mm", "x_m,y_m,z_m", "x,y,z", "a,b"]))
        text = header + "\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in points)
    elif suffix == ".ply":
        text = (f"ply\nformat ascii 1.0\nelement vertex {len(points)}\nproperty float x\nproperty float y\n"
                "property float z\nend_header\n" + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points))
    else:
        text = "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points)
    return text.encode(), suffix


@FUZZ
@given(cloud=point_clouds(), junk=st.binary(max_size=200), suffix=st.sampled_from([".xyz", ".csv", ".ply"]),
       units=st.sampled_from([None, "mm", "m", "inch"]))
def test_point_clouds(cloud: tuple[bytes, str], junk: bytes, suffix: str, units: str | None) -> None:
    for data, ending in (cloud, (junk, suffix)):
        path = _file(data, ending)
        _returns_or_refuses(lambda path=path: read_scan(path, units))  # type: ignore[misc]
        shutil.rmtree(path.parent)
