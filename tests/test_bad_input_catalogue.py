"""Probes of the bad-input classes a user reported: each refused with exit 2, a message naming what was typed and
what was expected, no traceback and nothing written.

Classes: a `--scheduler` address (its form checked before any connection; a connection refused or unanswered within
seconds), G-code words (understood, refused by name or `M98` expanded), physically absurd processes and tools, `place`
with no feasible placement, STL files (garbage, empty, truncated, a missing optional module, a non-manifold design)
and a design or scan of another part than the path's (`twin.process.part.match`).
"""

from __future__ import annotations

import re
import socket
import struct
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from cli_refusal import refused

from twin.cli import main
from twin.errors import InputError


# ---------------------------------------------------------------- 1. --scheduler
def test_a_scheduler_that_is_no_address_is_refused_before_any_work(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "p.json"
    start = time.perf_counter()
    refused(["place", "--ideal", str(tiny), "--scheduler", "banana", "--json", str(out)], capsys,
            "--scheduler banana", "missing port", "tcp://HOST:8786", never=(out,))
    refused(["place", "--ideal", str(tiny), "--scheduler", "tcp://h:70000", "--json", str(out)], capsys,
            "--scheduler tcp://h:70000", "1..65535", never=(out,))
    assert time.perf_counter() - start < 2.0


def test_a_scheduler_where_nothing_listens_is_refused_within_seconds(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "p.json"
    start = time.perf_counter()
    refused(["place", "--ideal", str(tiny), "--candidates", "2", "--confirm", "1", "--scheduler",
             "tcp://127.0.0.1:1", "--json", str(out)], capsys, "--scheduler tcp://127.0.0.1:1", "cannot connect",
            never=(out,))
    assert time.perf_counter() - start < 8.0  # the twin's setup, then at most the 5 s connection limit


def test_a_silent_peer_is_no_scheduler_and_no_hang(monkeypatch: pytest.MonkeyPatch) -> None:
    from twin.base import jobs

    monkeypatch.setattr(jobs, "CONNECT_TIMEOUT_S", 0.5)
    with socket.socket() as server:  # accepts the TCP connection, never speaks Dask
        server.bind(("127.0.0.1", 0))
        server.listen(4)
        address = f"127.0.0.1:{server.getsockname()[1]}"
        start = time.perf_counter()
        with pytest.raises(InputError, match=f"--scheduler {address}: .*is not a Dask scheduler"):
            jobs.Jobs(scheduler=address)
        assert time.perf_counter() - start < 3.0


def test_scheduler_address_forms() -> None:
    from twin.base.jobs import scheduler_address

    assert scheduler_address("tcp://127.0.0.5:8786") == ("tcp", "127.0.0.5", 8786)  # parsed only, never dialled
    assert scheduler_address("node-1.lab:8786") == ("tcp", "node-1.lab", 8786)
    assert scheduler_address("tcp://[::1]:8786") == ("tcp", "::1", 8786)
    for bad, why in (("udp://h:1", "unknown address scheme"), ("h:0", "1..65535"), ("h:x", "1..65535"),
                     ("bad host:1", "not a host name"), ("", "empty")):
        with pytest.raises(InputError, match=why):
            scheduler_address(bad)


# ---------------------------------------------------------------- 2. G-code
SUBPROGRAM = "%\nO100\nG21 G90\nG1 X0 Y0 Z0 F600\nM98 P200 L2\nM30\nO200 (one step along x)\nG91 G1 X1\nG90\nM99\n%\n"


def test_m98_expands_a_subprogram_the_file_holds(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    program, out = tmp_path / "sub.nc", tmp_path / "p.csv"
    program.write_text(SUBPROGRAM)
    assert main(["path", "--gcode", str(program), "--spacing-mm", "1", "--out", str(out), "--no-reach-check"]) == 0
    x_mm = np.loadtxt(out, delimiter=",", skiprows=1, usecols=1)
    np.testing.assert_allclose(x_mm, [0.0, 1.0, 2.0])  # O200 run twice: two 1 mm steps


@pytest.mark.parametrize(("text", "needles"), [
    ("G1 X0 Y0 Z0 F600\nG1 X1\nM98 P7\nM30\n", ("line 3", "M98 P7", "O7", "does not hold")),
    ("G1 X0 Y0 Z0 F600\nG1 X1 M42\n", ("line 2", "M42 is not supported", "M98")),
    ("G1 X0 Y0 Z0 F600\nG1 X1 P5\n", ("line 2", "P5 without G4", "M98")),
    ("G1 X0 Y0 Z0 F600\nG1 X1 Q3\n", ("line 2", "word Q3 is not supported")),
    ("G1 X0 Y0 Z0 F600\nG1 X1 I4\n", ("line 2", "I (arc centre or radius) with G1")),
    ("G1 X0 Y0 Z0 F600\nG1 X1\nM30\nG1 X2\n", ("line 4", "after the program end on line 3")),
])
def test_a_gcode_word_is_understood_or_refused_by_name(
    text: str, needles: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    program, out = tmp_path / "g.nc", tmp_path / "p.csv"
    program.write_text(text)
    refused(["path", "--gcode", str(program), "--out", str(out), "--no-reach-check"], capsys, str(program), *needles,
            never=(out,))


# ---------------------------------------------------------------- 3. physically absurd processes and tools
@pytest.mark.parametrize(("flags", "needles"), [
    (["--thickness-mm", "0.001"], ("sheet thickness 0.001 mm (--thickness-mm 0.001)", "0.1..6 mm")),
    (["--tool-radius-mm", "15000"], ("tool radius 15000 mm (--tool-radius-mm 15000)", "0.5..50 mm")),
])
def test_an_absurd_process_flag_is_refused_not_warned(
    flags: list[str], needles: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "p.csv"
    err = refused(["path", "--out", str(out), "--no-reach-check", *flags], capsys, *needles, never=(out,))
    assert "warning" not in err


@pytest.mark.parametrize(("text", "needles"), [
    ('format = "tx200-twin-process/1"\nthickness_mm = 0.001\n', ("thickness_mm", "0.001 mm", "0.1..6 mm")),
    ('format = "tx200-twin-process/1"\ntool_friction = 3.0\n', ("tool_friction", "0..1")),
    ('format = "tx200-twin-process/1"\nmaterial = { name = "Hard", tensile_strength_mpa = 4000 }\n',
     ("material.tensile_strength_mpa = 4000", "10..2500")),
])
def test_an_absurd_process_file_is_refused_naming_the_file_and_key(
    text: str, needles: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    declared, out = tmp_path / "process.toml", tmp_path / "p.csv"
    declared.write_text(text)
    refused(["path", "--out", str(out), "--no-reach-check", "--process", str(declared)], capsys, str(declared),
            *needles, never=(out,))


@pytest.mark.parametrize(("flags", "needles"), [
    (["--tool-length-mm", "15000"], ("tool length (flange to tip) 15000 mm (--tool-length-mm 15000)", "20..1500 mm")),
    (["--tool-mass-kg", "5000"], ("tool mass 5000 kg (--tool-mass-kg 5000)", "0..500 kg")),
])
def test_an_absurd_tool_is_refused(
    flags: list[str], needles: tuple[str, ...], tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "o.mod"
    refused(["export", str(tiny), "--format", "rapid", "--out", str(out), *flags], capsys, *needles, never=(out,))


# ---------------------------------------------------------------- 4. place with no feasible placement
def test_place_with_no_feasible_placement_exits_2_saying_what_was_tried(
    tiny: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, figure = tmp_path / "p.json", tmp_path / "p.png"
    refused(["place", "--ideal", str(tiny), "--candidates", "2", "--confirm", "1", "--joint-margin-deg", "170",
             "--workers", "1", "--json", str(out), "--figure", str(figure)], capsys,
            f"no placement reaches the part (--ideal {tiny})", "0 of 2 candidates feasible", "joint_margin 2",
            "--joint-margin-deg 170", "--box-mm 300 400 100", never=(out, figure))


# ---------------------------------------------------------------- 5. STL files
def _binary_stl(triangles: np.ndarray, header: bytes = b"binary stl") -> bytes:
    records = b"".join(struct.pack("<12fH", 0.0, 0.0, 1.0, *t.ravel(), 0) for t in np.asarray(triangles, float))
    return header.ljust(80, b" ")[:80] + struct.pack("<I", len(triangles)) + records


TRIANGLES = np.array([[[0, 0, 0], [40, 0, -5], [0, 40, 0]], [[40, 0, -5], [40, 40, 0], [0, 40, 0]]])
FIN = np.array([[[0, 0, 0], [50, 0, 0], [25, 40, 0]], [[0, 0, 0], [50, 0, 0], [25, -40, 0]],
                [[0, 0, 0], [50, 0, 0], [25, 0, -40]]])


@pytest.mark.parametrize(("data", "needles"), [
    (b"\x00\x01garbage", ("neither start with 'solid'",)),
    (b"", ("is empty",)),
    (_binary_stl(TRIANGLES)[:-30], ("announces 2 triangles", "truncated")),
    (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid x\n",
     ("line 6", "2 vertices")),
    (_binary_stl(FIN), ("non-manifold", "shared by 3")),
])
def test_a_bad_stl_is_refused_naming_the_file_without_a_missing_module(
    data: bytes, needles: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "charset_normalizer", None)  # as an install without the optional module
    design, out = tmp_path / "d.stl", tmp_path / "c.csv"
    design.write_bytes(data)
    err = refused(["compensate", "--method", "twin", "--target-stl", str(design), "--out", str(out)], capsys,
                  str(design), *needles, never=(out,))
    assert "No module" not in err and "charset" not in err


def test_a_binary_stl_with_a_latin1_header_reads_without_charset_detection(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from twin.analysis.surface_check import read_target_mesh

    monkeypatch.setitem(sys.modules, "charset_normalizer", None)
    design = tmp_path / "d.stl"
    design.write_bytes(_binary_stl(TRIANGLES, "Maße µm".encode("latin-1")))
    mesh = read_target_mesh(design)
    np.testing.assert_allclose(mesh.bounds, [[0, 0, -5e-3], [40e-3, 40e-3, 0]])


# ---------------------------------------------------------------- 6. a design or scan of another part
@pytest.fixture(scope="module")
def parts(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small cone and pyramid (40 mm, 5 mm deep): their paths, designs and the pyramid's springback target."""
    folder = tmp_path_factory.mktemp("parts")
    for shape in ("cone", "pyramid"):
        assert main(["path", "--shape", shape, "--top-width-mm", "40", "--depth-mm", "5", "--step-down-mm", "1",
                     "--out", str(folder / f"{shape}.csv"), "--design-stl", str(folder / f"{shape}.stl"),
                     "--stl-out", str(folder / f"{shape}_formed.stl"), "--no-reach-check"]) == 0
    return folder


def test_a_pyramid_design_with_a_cone_path_is_refused(parts: Path, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "c.csv"
    refused(["compensate", "--method", "twin", "--ideal", str(parts / "cone.csv"), "--target-stl",
             str(parts / "pyramid.stl"), "--out", str(out)], capsys,
            f"--target-stl {parts / 'pyramid.stl'} is not the part --ideal {parts / 'cone.csv'} forms",
            "another shape", "accepted: 4.0 mm", never=(out,))


def test_the_shape_rule_accepts_the_same_part_and_refuses_another_design_or_scan(parts: Path) -> None:
    from twin.analysis.surface_check import read_target_mesh
    from twin.process.part.match import check_same_part

    def path(shape: str) -> np.ndarray:
        return np.loadtxt(parts / f"{shape}.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3)) * 1e-3

    cone, cone_path = read_target_mesh(parts / "cone.stl"), path("cone")
    formed_pyramid = np.asarray(read_target_mesh(parts / "pyramid_formed.stl").vertices)  # a scan: its points
    assert check_same_part(cone_path, cone, "design") is not None
    assert not check_same_part(path("pyramid"), formed_pyramid, "scan").problems  # type: ignore[union-attr]
    with pytest.raises(InputError, match=re.escape("the scan s.xyz is not the part --ideal cone.csv forms: its outline")):
        check_same_part(cone_path, formed_pyramid, "the scan s.xyz", path_what="--ideal cone.csv")
    deeper = cone_path * np.array([1.0, 1.0, 2.0])  # a cone path twice as deep
    with pytest.raises(InputError, match=re.escape("5.0 mm deep where the path goes 10.0 mm deep")):
        check_same_part(deeper, cone, "design")
    wider = cone_path * np.array([1.5, 1.5, 1.0])  # a cone of 60 mm for the 40 mm design
    with pytest.raises(InputError, match="outside the path's"):
        check_same_part(wider, cone, "design")
