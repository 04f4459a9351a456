"""The formed part against its design on both plants, whose sheet is 20 % stronger than declared and springs back
more (`experiments/part_to_design.py`): path-compensated, part-compensated, then learned from the scans. Slow:
`make test-slow`. The note's Ø 80 mm cone numbers come from the script itself (`--width-mm 80 --depth-mm 20`)."""

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


def _all(summary: dict, plant: str, row: str) -> float:
    return summary[plant][row]["rms_mm"]["part"]


@pytest.mark.slow
def test_a_cone_on_both_plants_learns_to_within_0_1_mm(tmp_path: Path) -> None:
    summary = study.part_study(tmp_path, ["--shape", "cone", "--top-width-mm", "40", "--depth-mm", "5"])
    print(f"\n{summary}")
    assert summary["twin_predicted_rms_mm"][-1] < summary["twin_predicted_rms_mm"][0] / 3
    for plant in ("quasi-static", "dynamic"):
        assert _all(summary, plant, "part-compensated") < _all(summary, plant, "path-compensated")
        assert _all(summary, plant, "learn 2") < 0.1
    # docs/any-part.md: learn 2, then path-compensated, then part-compensated; quasi-static / dynamic each
    doc = quoted("any-part.md", "on both plants reaches", 6)
    for k, row in enumerate(("learn 2", "path-compensated", "part-compensated")):
        for j, plant in enumerate(("quasi-static", "dynamic")):
            doc[2 * k + j].check(_all(summary, plant, row))


@pytest.mark.slow
@pytest.mark.parametrize("part", ["pyramid", "gcode"])
def test_a_pyramid_and_a_gcode_part_improve_in_one_iteration(part: str, tmp_path: Path) -> None:
    if part == "gcode":
        program = tmp_path / "stadium.nc"
        program.write_text(stadium_gcode())
        args = ["--gcode", str(program)]
    else:
        args = ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "4"]
    summary = study.part_study(tmp_path / "study", args, plants=("quasi-static",), learn=1)
    print(f"\n{part}: {summary}")
    assert _all(summary, "quasi-static", "part-compensated") < _all(summary, "quasi-static", "path-compensated")
    assert _all(summary, "quasi-static", "learn 1") < 0.5 * _all(summary, "quasi-static", "part-compensated")
    # docs/any-part.md: path-compensated, part, learn 1; pyramid / G-code each
    doc = quoted("any-part.md", "a pyramid and a G-code stadium pocket improve from", 6)
    for k, row in enumerate(("path-compensated", "part-compensated", "learn 1")):
        doc[2 * k + (0 if part == "pyramid" else 1)].check(_all(summary, "quasi-static", row))
