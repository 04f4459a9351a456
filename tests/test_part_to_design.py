"""The formed part against its design on both plants, whose sheet is 20 % stronger than declared and springs back
otherwise (`experiments/part_to_design.py`): path-compensated, part-compensated, then learned from the scans: the
issue's Ø 80 mm cone, a pyramid and a G-code part. Slow: `make test-slow`; they hold docs/any-part.md's tables."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from doc_numbers import quoted

_SPEC = importlib.util.spec_from_file_location(
    "part_to_design", Path(__file__).resolve().parent.parent / "experiments" / "part_to_design.py")
assert _SPEC is not None and _SPEC.loader is not None
study = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(study)


def stadium_gcode(levels: int = 8, step_mm: float = 0.5, half_length_mm: float = 10.0, radius_mm: float = 15.0) -> str:
    """A CAM-like program written here: a stadium pocket with 45° walls, z-levels joined by plunges, arcs G3."""
    lines = ["G21 G90", "G1 X10 Y-15 Z0 F2000"]
    for k in range(1, levels + 1):
        z, r, L = -k * step_mm, radius_mm - k * step_mm, half_length_mm
        lines += [f"G1 X{L:g} Y{-r:g} Z{z:g}", f"G3 X{L:g} Y{r:g} I0 J{r:g}", f"G1 X{-L:g} Y{r:g}",
                  f"G3 X{-L:g} Y{-r:g} I0 J{-r:g}", f"G1 X{L:g} Y{-r:g}"]
    return "\n".join(lines) + "\n"


def _numbers(lines: list[str]) -> list[float]:
    """The cells after each row's stage name (nan for a stage a plant refused)."""
    cells = [cell.strip() for line in lines[2:] for cell in line.strip("|").split("|")[1:]]
    return [float("nan") if cell == "refused" else float(cell) for cell in cells]


def _documented(anchor: str) -> list[float]:
    """The numbers of the table after `<!-- anchor` in docs/any-part.md."""
    documented = (Path(__file__).resolve().parent.parent / "docs" / "any-part.md").read_text()
    return _numbers(documented.split(f"<!-- {anchor}")[1].split("\n\n")[0].splitlines()[1:])


def _all(summary: dict, plant: str, row: str) -> float:
    return summary[plant][row]["rms_mm"]["part"]


@pytest.fixture(scope="module")
def cone80(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    """The issue's part: a 45° cone, Ø 80 mm, 20 mm deep, on both plants (about 10 min on 2 cores)."""
    out = tmp_path_factory.mktemp("cone80")
    summary = study.part_study(out, ["--shape", "cone", "--top-width-mm", "80", "--depth-mm", "20"])
    print(f"\n{summary}")
    return summary, out


@pytest.mark.slow
def test_the_cone_tables_are_what_the_study_gives(cone80: tuple[dict, Path]) -> None:
    """docs/any-part.md's numbers of the Ø 80 mm cone, guarded before any target is asserted."""
    summary, out = cone80
    for found, rms in zip(quoted("any-part.md", "On the Ø 80 mm cone below the twin's predicted part goes", 3),
                          summary["twin_predicted_rms_mm"], strict=True):
        found.check(rms)
    found = quoted("any-part.md", "Identified\n(recovery_scale, depth_ratio):", 4)
    plants = ("quasi-static", "dynamic")
    for k, (plant, name) in enumerate((p, n) for p in plants for n in ("recovery_scale", "depth_ratio")):
        found[k].check(summary["identified"][plant]["springback_fit"][name])
    assert _documented("part-to-design table") == pytest.approx(_numbers(study.stage_table(summary).splitlines()),
                                                                abs=0.005, nan_ok=True)
    for stem in ("twin_stages", "quasi-static_stages", "dynamic_stages"):  # the maps and recordings of each stage
        assert (out / f"{stem}.png").stat().st_size > 20_000 and (out / f"{stem}.rrd").stat().st_size > 10_000


@pytest.mark.slow
def test_the_cone_on_both_plants_learns_to_within_0_1_mm(cone80: tuple[dict, Path]) -> None:
    summary, _ = cone80
    assert summary["twin_predicted_rms_mm"][-1] < summary["twin_predicted_rms_mm"][0] / 10
    for plant in ("quasi-static", "dynamic"):  # the scans learn what the twin does not know, on both plants
        assert _all(summary, plant, "learn 2") < 0.1
    assert _all(summary, "quasi-static", "learn 2") < _all(summary, "quasi-static", "path-compensated") / 3
    # the quasi-static lab springs back as the twin's model does, 5 % more: the twin's part compensation helps, and
    # with the forces identified from the nominal part and the springback from its scan it removes nearly all
    qs, both = "quasi-static", ", identified forces and springback"
    assert _all(summary, qs, "part-compensated") < _all(summary, qs, "path-compensated")
    assert _all(summary, qs, "part-compensated, identified forces") < _all(summary, qs, "path-compensated") / 2
    assert _all(summary, qs, f"part-compensated{both}") < _all(summary, qs, "path-compensated") / 3
    assert summary["identified"][qs]["springback_fit"]["depth_ratio"] == pytest.approx(0.95, abs=0.01)  # lab: 0.95
    # the dynamic plant's own sheet springs back far less than the twin predicts: the part compensation over-forms,
    # unless the springback is identified from the nominal scan
    dyn = "dynamic"
    assert _all(summary, dyn, "part-compensated") > _all(summary, dyn, "path-compensated")
    assert _all(summary, dyn, f"part-compensated{both}") < _all(summary, dyn, "path-compensated") / 1.5
    assert summary["identified"][dyn]["springback_fit"]["recovery_scale"] < 0.5


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "since 0.21.0's enclosure (the plant's law 1 holds a closed part's inside flat: the cone's force ~5 % lower) the "
    "dynamic plant's cone after two learning iterations is at 0.086 mm, over a third of its path-compensated 0.221"))
def test_on_the_dynamic_plant_two_learning_iterations_take_two_thirds_off(cone80: tuple[dict, Path]) -> None:
    summary, _ = cone80
    assert _all(summary, "dynamic", "learn 2") < _all(summary, "dynamic", "path-compensated") / 3


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "found with 0.21's regeneration, not explained yet (CHANGELOG): on the quasi-static lab the twin alone, its forces "
    "and springback identified, leaves the cone at 0.300 mm (it reached the scan's noise, 0.029 mm, when the table was "
    "last generated; the pyramid's and the stadium's moved alike; bisected to fc085f3, the wall tilt in every formed "
    "part); the quasi-static lab is not the plant 0.21 changed"))
def test_on_the_quasi_static_lab_the_twin_alone_reaches_the_scans_noise(cone80: tuple[dict, Path]) -> None:
    summary, _ = cone80
    assert _all(summary, "quasi-static", "part-compensated, identified forces and springback") < 0.1


def test_the_words_under_the_tables_are_theirs() -> None:
    """docs/any-part.md's words on its three tables: the numbers they quote, then the shares they claim."""
    cone, pyramid, gcode = (_documented(f"{name} table") for name in ("part-to-design", "pyramid", "gcode"))

    def cell(table: list[float], row: int, plant: int) -> float:  # plant 0: quasi-static, 1: dynamic
        return table[2 * row + plant]

    said = quoted("any-part.md", "the twin alone takes the part to", 2)
    said[0].check(cell(cone, 6, 0))
    said[1].check(cell(cone, 8, 0))
    small = quoted("any-part.md", "with the identified model, takes the pyramid to", 4)
    for k, (table, row) in enumerate(((pyramid, 6), (gcode, 6), (pyramid, 7), (gcode, 7))):
        small[k].check(cell(table, row, 0))
    assert 0.45 <= 1.0 - cell(cone, 2, 0) / cell(cone, 1, 0) <= 0.55  # the declared sheet "removes half"
    assert 0.3 <= 1.0 - cell(cone, 6, 1) / cell(cone, 1, 1) <= 0.37  # "a third" on the dynamic plant
    for table in (pyramid, gcode):  # "three quarters of the stadium's and the pyramid's"
        assert 0.7 <= 1.0 - cell(table, 6, 1) / cell(table, 1, 1) <= 0.8


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason="the dynamic plant's wall keeps a ring where its axial force rises steeply "
                   "and its tool tip runs further in than the twin predicts; a factor on the axial force per mm of "
                   "depth did not remove it; only the scans do")
def test_on_the_dynamic_plant_the_twin_alone_removes_two_thirds(cone80: tuple[dict, Path]) -> None:
    summary, _ = cone80
    both = ", identified forces and springback"
    assert _all(summary, "dynamic", f"part-compensated{both}") < _all(summary, "dynamic", "path-compensated") / 3


@pytest.fixture(scope="module", params=["pyramid", "gcode"])
def small_part(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, dict]:
    """A pyramid (40 mm, 4 mm deep) or the stadium G-code part, one learning iteration, both plants."""
    part, tmp_path = request.param, tmp_path_factory.mktemp(request.param)
    if part == "gcode":
        program = tmp_path / "stadium.nc"
        program.write_text(stadium_gcode())
        args = ["--gcode", str(program)]
    else:
        args = ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "4"]
    summary = study.part_study(tmp_path / "study", args, learn=1)
    print(f"\n{part}: {summary}")
    return part, summary


@pytest.mark.slow
def test_the_pyramid_and_gcode_tables_are_what_the_study_gives(small_part: tuple[str, dict]) -> None:
    part, summary = small_part
    assert _documented(f"{part} table") == pytest.approx(_numbers(study.stage_table(summary).splitlines()),
                                                         abs=0.005, nan_ok=True)


@pytest.mark.slow
def test_a_pyramid_and_a_gcode_part_improve_in_one_iteration(small_part: tuple[str, dict]) -> None:
    part, summary = small_part
    qs, dyn = "quasi-static", "dynamic"  # thresholds set after a first run of both parts (not blind)
    assert _all(summary, qs, "part-compensated") < _all(summary, qs, "path-compensated")
    assert _all(summary, qs, "learn 1") < min(_all(summary, qs, "path-compensated") / 3,
                                              _all(summary, qs, "part-compensated") / 2)
    # the dynamic plant: the pyramid's corners are beyond the twin's force model, yet one learning iteration is its
    # best stage
    assert _all(summary, dyn, "learn 1") < min(_all(summary, dyn, "nominal"), _all(summary, dyn, "path-compensated"))
    if part == "gcode":  # the stadium as the cone: the identified model removes two thirds and more
        both = ", identified forces and springback"
        assert _all(summary, dyn, f"part-compensated{both}") < _all(summary, dyn, "path-compensated") / 2.5
