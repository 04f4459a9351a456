"""A cone 20 mm across through `path`, `lab`, `compensate`, `check` and `export`, as a user types it.

Every reader once refused a part narrower than 30 mm as "in metres"; units are now read from the column names
and checked by the path's speed, whatever the part's size (`twin.base.units`). The force model follows the part:
`--force-model auto` takes the height-map ISF model for a path off the groove, and the run records it.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from twin.cli import main


@pytest.fixture(scope="module")
def small_cone(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("small_cone")
    ideal, cmd = base / "cone.csv", base / "cone_cmd.csv"
    assert main(["path", "--shape", "cone", "--depth-mm", "5", "--top-width-mm", "20", "--out", str(ideal),
                 "--stl-out", str(base / "cone.stl")]) == 0
    assert main(["lab", "--scenario", "nominal", "--commanded", str(ideal), "--seed", "1",
                 "--out", str(base / "nominal")]) == 0
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--out", str(cmd),
                 "--json", str(base / "compensate.json")]) == 0
    assert main(["lab", "--scenario", "compensated", "--commanded", str(cmd), "--seed", "2",
                 "--out", str(base / "compensated")]) == 0
    return base


def _check(capsys: pytest.CaptureFixture[str], run: Path, base: Path, code: int = 0) -> dict[str, object]:
    capsys.readouterr()
    assert main(["check", str(run), "--ideal", str(base / "cone.csv"), "--target-stl", str(base / "cone.stl"),
                 "--json", "-"]) == code
    payload: dict[str, object] = json.loads(capsys.readouterr().out)
    return payload


def test_a_20_mm_cone_is_formed_compensated_and_checked(small_cone: Path, capsys: pytest.CaptureFixture[str]) -> None:
    meta = json.loads((small_cone / "compensated" / "meta.json").read_text())
    assert meta["force_model"] == "isf"
    compensation = json.loads((small_cone / "compensate.json").read_text())
    assert compensation["force_model"] == "isf"
    nominal = _check(capsys, small_cone / "nominal", small_cone)  # a nominal run: exit 0, the residual of no compensation
    right = _check(capsys, small_cone / "compensated", small_cone)
    print(f"\n20 mm cone: nominal {nominal['residual_rms_mm']:.3f} mm, compensated {right['residual_rms_mm']:.3f} mm")
    assert float(right["residual_rms_mm"]) < 0.1  # type: ignore[arg-type]
    assert float(nominal["residual_rms_mm"]) > 10.0 * float(right["residual_rms_mm"])  # type: ignore[arg-type]


@pytest.mark.parametrize(("fmt", "name"), [("val3", "cone_val3"), ("krl", "cone.src"), ("rapid", "cone.mod"),
                                           ("gcode", "cone.nc"), ("csv", "cone_points.csv")])
def test_its_compensated_command_exports_to_every_format(small_cone: Path, fmt: str, name: str) -> None:
    out = small_cone / "programs" / name
    out.parent.mkdir(exist_ok=True)
    assert main(["export", str(small_cone / "cone_cmd.csv"), "--format", fmt, "--out", str(out)]) == 0
    assert out.exists()
