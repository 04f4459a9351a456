"""A cone 20 mm across through `path`, `lab`, `compensate`, `check` and `export`, as a user types it.

Every reader once refused a part narrower than 30 mm as "in metres"; units are now read from the column names
and checked by the path's speed, whatever the part's size (`twin.base.units`). The force model follows the part:
`--force-model auto` takes the height-map ISF model for a path off the groove, and the run records it.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from twin.analysis.compensation_record import read_record
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
    # with --target-stl the part is judged: the nominal part misses the design, the compensated one is within the
    # default tolerance of it (this small cone's springback is small)
    nominal = _check(capsys, small_cone / "nominal", small_cone, code=1)
    right = _check(capsys, small_cone / "compensated", small_cone, code=0)
    assert nominal["judged"] == right["judged"] == "part"
    assert not nominal["part_within_tolerance"] and right["part_within_tolerance"]
    print(f"\n20 mm cone: nominal {nominal['residual_rms_mm']:.3f} mm, compensated {right['residual_rms_mm']:.3f} mm")
    assert float(right["residual_rms_mm"]) < 0.1  # type: ignore[arg-type]
    assert float(nominal["residual_rms_mm"]) > 10.0 * float(right["residual_rms_mm"])  # type: ignore[arg-type]


@pytest.mark.parametrize(("fmt", "name"), [("val3", "cone_val3"), ("krl", "cone.src"), ("rapid", "cone.mod"),
                                           ("gcode", "cone.nc"), ("csv", "cone_points.csv")])
def test_its_compensated_command_exports_to_every_format(small_cone: Path, fmt: str, name: str) -> None:
    out = small_cone / "programs" / name
    out.parent.mkdir(exist_ok=True)
    robot = {"krl": ["--robot", "kr210"], "rapid": ["--robot", "irb6640"]}.get(fmt, [])  # its maker's robot
    assert main(["export", str(small_cone / "cone_cmd.csv"), "--format", fmt, *robot, "--out", str(out)]) == 0
    assert out.exists()


def test_a_part_compensated_to_its_design_is_judged_as_a_part(small_cone: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    """`compensate --target-stl` leaves a record naming the design; `check` judges such a run's part against it,
    and refuses to judge its path (which leaves the ideal path on purpose) without it."""
    cmd, run = small_cone / "part_cmd.csv", small_cone / "part"
    assert main(["compensate", "--method", "twin", "--target-stl", str(small_cone / "cone.stl"), "--ideal",
                 str(small_cone / "cone.csv"),
                 "--part-iterations", "1", "--out", str(cmd)]) == 0
    out = capsys.readouterr().out
    assert "the part" in out and "mm rms" in out and "part_cmd.compensation.json" in out  # the result on screen
    record = read_record(cmd)
    assert record is not None and record.design_file == str(small_cone / "cone.stl")
    assert record.f_used_n.shape == (len(record.t_s), 3)
    assert main(["lab", "--scenario", "compensated", "--commanded", str(cmd), "--seed", "2", "--out", str(run)]) == 0
    capsys.readouterr()
    assert main(["check", str(run), "--ideal", str(small_cone / "cone.csv")]) == 2
    err = capsys.readouterr().err
    assert "compensated to the design" in err and "--target-stl" in err and "Traceback" not in err
    judged = _check(capsys, run, small_cone, code=0)
    assert judged["judged"] == "part" and judged["part_within_tolerance"]
    # a tolerance tighter than the part's deviation fails it: the exit code follows the part
    tight = float(judged["part_quantile_mm"]) / 2  # type: ignore[arg-type]
    assert main(["check", str(run), "--ideal", str(small_cone / "cone.csv"), "--target-stl",
                 str(small_cone / "cone.stl"), "--part-tolerance-mm", f"{tight:.4f}"]) == 1
    assert "OUTSIDE the tolerance" in capsys.readouterr().out


def test_check_refuses_the_design_of_another_part(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A pyramid's design against a cone's run of the same width and depth: a shape check refuses it (exit 2)
    instead of judging the part (`twin.process.part.match`)."""
    for shape in ("cone", "pyramid"):
        assert main(["path", "--shape", shape, "--depth-mm", "8", "--top-width-mm", "60", "--out",
                     str(tmp_path / f"{shape}.csv"), "--stl-out", str(tmp_path / f"{shape}.stl")]) == 0
    assert main(["lab", "--scenario", "nominal", "--commanded", str(tmp_path / "cone.csv"), "--seed", "1",
                 "--out", str(tmp_path / "run")]) == 0
    capsys.readouterr()
    assert main(["check", str(tmp_path / "run"), "--ideal", str(tmp_path / "cone.csv"), "--target-stl",
                 str(tmp_path / "pyramid.stl")]) == 2
    err = capsys.readouterr().err
    assert "pyramid.stl" in err and "Traceback" not in err
    assert main(["check", str(tmp_path / "run"), "--ideal", str(tmp_path / "cone.csv"), "--target-stl",
                 str(tmp_path / "cone.stl")]) in (0, 1)  # its own design is judged
