"""Programs a robot programmer accepts (twin/apps/export: motion.py, reach.py, parts.py and the writers): the
compensated groove approaches from above, leaves upwards and keeps its feed in contact near the process feed;
each format has its vendor's structure (checked against open post-processors' output); a program over its
controller's limit is split into parts a main calls; reach, tool and safe height come from the options, the run or
the robot, and bad values are refused naming the option."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.cli import main
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.runs.format import Run, run_meta
from twin.runs.read import read_commanded_csv
from twin.runs.write import write_path_csv, write_run

PROCESS_FEED_MM_S = 2000.0 / 60.0  # the groove's feed, 2 m/min (thesis §1.2.3)


def _krl(dat: Path) -> tuple[np.ndarray, np.ndarray]:
    """P_PATH positions [mm] and V_PATH feeds [mm/s] of a KRL data list, in index order."""
    text = dat.read_text()
    points = {int(i): [float(v) for v in re.findall(r"[XYZ] (-?[\d.]+)", body)[:3]]
              for i, body in re.findall(r"^P_PATH\[(\d+)\]=\{([^}]*)\}$", text, re.M)}
    feeds = {int(i): float(v) for i, v in re.findall(r"^V_PATH\[(\d+)\]=(\S+)$", text, re.M)}
    return np.array([points[i] for i in sorted(points)]), 1e3 * np.array([feeds[i] for i in sorted(feeds)])


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("programs")


@pytest.fixture(scope="module")
def compensated(work: Path) -> Path:
    """The whole groove compensated on the twin (`compensate --method twin`, the default spec)."""
    out = work / "compensated.csv"
    assert main(["compensate", "--method", "twin", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def short(work: Path) -> Path:
    """A 2-pass groove, 279 points."""
    return write_path_csv(groove_path(GrooveSpec(passes=2, bottom_length_m=0.066)), work / "short.csv")


def test_compensated_groove_approaches_from_above_and_keeps_the_feed_in_contact(
    compensated: Path, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    stream = read_commanded_csv(compensated)
    p = 1e3 * stream.values
    path_feed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(stream.t_s)
    assert path_feed.max() > 3.0 * PROCESS_FEED_MM_S  # the reversal jumps the program must not copy (148 mm/s)
    capsys.readouterr()
    assert main(["export", str(compensated), "--format", "krl", "--robot", "kr210", "--out", str(work / "groove.src"),
                 "--json", str(work / "groove.json")]) == 0
    assert "warning:" in capsys.readouterr().err
    points, feed = _krl(work / "groove.dat")
    np.testing.assert_allclose(points[1:-1], p, atol=0.5e-4 + 1e-9)  # the path itself, unchanged
    approach, retract = points[0], points[-1]
    np.testing.assert_allclose(approach[:2], p[0, :2], atol=1e-9)
    np.testing.assert_allclose(retract[:2], p[-1, :2], atol=1e-9)
    assert approach[2] == retract[2] >= max(0.0, p[:, 2].max()) + 20.0 - 1e-9  # above the sheet and the path
    src = (work / "groove.src").read_text()
    joint = re.findall(r"^PTP (\S+)$", src, re.M)  # joint moves HOME and to the approach only
    assert joint == ["XHOME_ISF", "P_PATH[1]", "XHOME_ISF"] and src.index("PTP P_PATH[1]") < src.index("SLIN P_PATH[2]")
    contact = feed[2:-1]  # the path's moves; [1]: down onto the path, [-1]: the retract
    assert contact.max() <= 1.5 * PROCESS_FEED_MM_S
    assert feed[1] <= 1.5 * PROCESS_FEED_MM_S and feed[-1] <= 1.5 * PROCESS_FEED_MM_S
    summary = json.loads((work / "groove.json").read_text())
    assert summary["feed_mm_s"]["max_in_contact"] == pytest.approx(contact.max(), abs=1e-3)
    assert summary["feed_mm_s"]["path_max_in_contact"] == pytest.approx(path_feed.max(), rel=1e-9)
    steps = np.linalg.norm(np.diff(points[1:-1], axis=0), axis=1)
    added = float(np.sum(steps / contact) - (stream.t_s[-1] - stream.t_s[0]))
    assert added == pytest.approx(summary["feed_mm_s"]["added_time_s"], abs=2e-3) and added > 0
    x_jump = np.abs(np.diff(p[:, 0]))[np.diff(stream.t_s) <= 0.0151].max()  # the numbers of docs/import-export.md
    # the numbers docs/import-export.md quotes, read from it
    quoted("import-export.md", "the command jumps up to", 1)[0].check(x_jump, slack=0.5)
    fastest, programmed, process, slower = quoted("import-export.md", "the path's fastest move in contact is", 4)
    fastest.check(path_feed.max(), slack=0.5)
    programmed.check(contact.max(), slack=0.5)
    process.check(PROCESS_FEED_MM_S)
    slower.check(added)
    print(f"\ncompensated groove: x jump {x_jump:.2f} mm in 15 ms; feed in contact {path_feed.max():.1f} mm/s in the path -> {contact.max():.1f} "
          f"mm/s programmed (process {PROCESS_FEED_MM_S:.2f}); the program runs {added:.2f} s longer")


def test_krl_has_the_vendor_structure(short: Path, work: Path) -> None:
    """KRL as RoboDK's KUKA_KRC4.py writes it (github.com/ros-industrial-attic/robodk_postprocessors, 08ec3d3):
    `&ACCESS RVP`/`&REL 1`, `DEF name( )`, the header `;FOLD INI` / `BAS (#INITMOV,0 )` / `;ENDFOLD (INI)` before
    any motion, `$VEL.CP` (setSpeed, m/s), `$ACC.CP` (setAcceleration), `$APO.CDIS` (setZoneData), `END`; the data
    list `DEFDAT name` ... `ENDDAT`; KSS 8's controller data (`$TOOL=TOOL_DATA[16]`, `$LOAD=LOAD_DATA[16]`,
    `$BASE=BASE_DATA[16]`: slot 16 by default, never the cell's calibrated 1), a first and last `PTP` HOME and the path as `SPLINE` ... `ENDSPLINE` blocks
    (`tests/test_program_structure.py` checks the whole program)."""
    assert main(["export", str(short), "--format", "krl", "--robot", "kr210", "--out", str(work / "s.src")]) == 0
    src = (work / "s.src").read_text().splitlines()
    assert src[:3] == ["&ACCESS RVP", "&REL 1", "DEF S( )"] and src[-1] == "END"
    fold = src.index(";FOLD INI")
    assert [line.strip() for line in src[fold + 1 : fold + 4]] == [  # KUKA's template: the stop-message interrupt
        "GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )", "INTERRUPT ON 3", "BAS(#INITMOV,0)"]
    assert src[fold + 4].startswith(";ENDFOLD")
    moves = [i for i, line in enumerate(src) if line.lstrip().startswith(("PTP", "LIN", "SLIN", "SPLINE"))]
    assert fold < moves[0] and [src[i] for i in moves[:2]] == ["PTP XHOME_ISF", "PTP P_PATH[1]"]
    assert src[moves[-1]] == "PTP XHOME_ISF"
    for variable in ("$VEL.CP=", "$ACC.CP=", "$APO.CDIS=", "$TOOL=TOOL_DATA[16]", "$BASE=BASE_DATA[16]",
                     "$LOAD=LOAD_DATA[16]"):
        assert any(line.strip().startswith(variable) for line in src), variable
    assert "SPLINE" in src and "ENDSPLINE" in src and not any(line.startswith("LIN") for line in src)
    dat = (work / "s.dat").read_text().splitlines()
    assert dat[2] == "DEFDAT S PUBLIC" and dat[-1] == "ENDDAT"


def test_rapid_has_the_vendor_structure(short: Path, work: Path) -> None:
    """RAPID as RoboDK's ABB_RAPID_IRC5.py writes it (robodk_postprocessors, 05c5ca8): `MODULE` ... `ENDMODULE`,
    `PERS tooldata` and `PERS wobjdata`, a `PROC` that starts with `ConfJ \\On;` and `ConfL \\Off;`, moves
    `MoveJ`/`MoveL target,speed,zone,tool\\WObj:=wobj;`, `ENDPROC`."""
    assert main(["export", str(short), "--format", "rapid", "--robot", "irb6640", "--out", str(work / "s.mod")]) == 0
    lines = [line.strip() for line in (work / "s.mod").read_text().splitlines()]
    assert lines[0] == "MODULE s" and lines[-1] == "ENDMODULE"
    assert any(line.startswith("PERS tooldata tIsf:=[TRUE,") for line in lines)
    assert any(line.startswith("PERS wobjdata wSheet:=[FALSE,TRUE,") for line in lines)
    proc = lines.index("PROC isf_s()")  # not main: the task has its own main module
    assert lines[proc + 1 : proc + 3] == ["ConfJ \\On;", "ConfL \\Off;"]
    assert lines[proc + 3 : proc + 5] == ["MoveAbsJ jHome,v100,fine,tIsf;", "MoveJ pPath{1},v100,fine,tIsf\\WObj:=wSheet;"]
    moves = [line for line in lines[proc:] if line.startswith(("MoveAbsJ", "MoveJ", "MoveL"))]
    kinds = [m.split()[0] for m in moves]
    assert kinds[:2] == ["MoveAbsJ", "MoveJ"] and kinds[-1] == "MoveAbsJ" and set(kinds[2:-1]) == {"MoveL"}
    assert all(re.fullmatch(r"Move[JL] \S+,\S+,(zPath|fine),tIsf\\WObj:=wSheet;", m) for m in moves[1:-1])
    assert moves[-2].endswith(",fine,tIsf\\WObj:=wSheet;") and "ENDPROC" in lines[proc:]


def test_val3_has_the_vendor_structure_and_its_folder_is_its_name(
    short: Path, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """VAL3 as RoboDK's Staubli_VAL3.py writes it (robodk_postprocessors, 5dbd124): a folder holding `NAME.pjx`
    (Project/3 namespace, `start.pgx` and `stop.pgx` programs, the database `NAME.dtx`), `start.pgx` a `begin` ...
    `end` program with the moves and `waitEndMove()`. A folder VAL3 cannot name is refused, naming `--out`."""
    out = work / "my_prog_1"
    assert main(["export", str(short), "--out", str(out)]) == 0
    assert {f.name for f in out.iterdir()} == {"my_prog_1.pjx", "my_prog_1.dtx", "start.pgx", "stop.pgx"}
    pjx = (out / "my_prog_1.pjx").read_text()
    assert 'xmlns="http://www.staubli.com/robotics/VAL3/Project/3"' in pjx
    assert all(f'file="{name}"' in pjx for name in ("start.pgx", "stop.pgx", "my_prog_1.dtx"))
    code = (out / "start.pgx").read_text()
    assert code.index("begin") < code.index("movej(") < code.index("movel(") < code.rindex("waitEndMove()")
    capsys.readouterr()
    assert main(["export", str(short), "--out", str(work / "my prog-1")]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "'my prog-1'" in err and "my_prog_1" in err
    assert not (work / "my prog-1").exists()


@pytest.mark.parametrize(("fmt", "suffix"), [("krl", ".src"), ("rapid", ".mod")])
def test_a_program_over_the_limit_is_split_into_parts_a_main_calls(
    short: Path, work: Path, fmt: str, suffix: str
) -> None:
    """281 points (approach, 279, retract) with a limit of 100: parts of 100, 100, 81, called in order."""
    n = len(read_commanded_csv(short).t_s) + 2
    whole, split = work / f"whole_{fmt}", work / f"split_{fmt}"
    robot = {"krl": "kr210", "rapid": "irb6640"}[fmt]  # the maker whose language it is
    assert main(["export", str(short), "--format", fmt, "--robot", robot, "--out", str(whole / f"isf{suffix}")]) == 0
    assert main(["export", str(short), "--format", fmt, "--robot", robot, "--max-points", "100",
                 "--out", str(split / f"isf{suffix}")]) == 0
    names = sorted(f.name for f in split.iterdir() if f.suffix == suffix)
    assert names == [f"isf{suffix}", f"isf_1{suffix}", f"isf_2{suffix}", f"isf_3{suffix}"]
    main_text = (split / f"isf{suffix}").read_text()
    calls = re.findall(r"^\s*(?:isf_)?(ISF_\d|isf_\d)(?:\( \))?;?$", main_text, re.M)  # RAPID: isf_NAME_k
    assert [c.lower() for c in calls] == ["isf_1", "isf_2", "isf_3"]
    if fmt == "krl":
        assert ";FOLD INI" in main_text and "BAS(#INITMOV,0)" in main_text
        parts = [_krl(split / f"isf_{k}.dat") for k in (1, 2, 3)]
        assert [len(p) for p, _ in parts] == [100, 100, n - 200] == [100, 100, 81]
        np.testing.assert_array_equal(np.vstack([p for p, _ in parts]), _krl(whole / "isf.dat")[0])
        texts = [(split / f"isf_{k}.src").read_text() for k in (1, 2, 3)]
        assert "PTP P_PATH[1]" in texts[0] and not any("PTP" in t for t in texts[1:])
        assert texts[2].rstrip().endswith("SLIN P_PATH[81]\nEND")  # the retract, at rest
        assert texts[0].rstrip().splitlines()[-2].endswith(" C_SPL")  # part 1 blends into part 2
        assert re.findall(r"^PTP (\S+)$", main_text, re.M) == ["XHOME_ISF", "XHOME_ISF"]
    else:
        texts = [(split / f"isf_{k}.mod").read_text() for k in (1, 2, 3)]
        counts = [int(re.search(r"nPath:=(\d+);", t).group(1)) for t in texts]  # type: ignore[union-attr]
        assert counts == [100, 100, n - 200] and all("LOCAL CONST robtarget" in t for t in texts)
        assert "MoveJ" in texts[0] and not any("MoveJ" in t for t in texts[1:])
        assert texts[2].count(",fine,") == 2 and "PERS tooldata tIsf" in main_text  # the path's end, the retract
        assert main_text.count("MoveAbsJ jHome,") == 2


def _far_path(directory: Path) -> Path:
    """Five points along x; the third 5 m away."""
    rows = ["t_s,x_mm,y_mm,z_mm", "0,0,0,0", "0.1,1,0,0", "0.2,5000,0,0", "0.3,3,0,0", "0.4,4,0,0"]
    (directory / "far.csv").write_text("\n".join(rows) + "\n")
    return directory / "far.csv"


@pytest.mark.parametrize("fmt", ["val3", "gcode"])
def test_a_point_out_of_reach_is_refused_naming_its_row_and_distance(
    work: Path, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    far = _far_path(work)
    capsys.readouterr()
    out = work / f"far_{fmt}"
    assert main(["export", str(far), "--format", fmt, "--origin-mm", "1500", "0", "400", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    distance = float(np.linalg.norm([1500.0 + 5000.0, 0.0, 400.0]))
    assert "row 3" in err and f"{distance:.1f} mm from the base origin" in err and "cannot reach" in err
    assert not out.exists()
    capsys.readouterr()
    assert main(["export", str(far), "--format", fmt, "--origin-mm", "6000", "0", "400", "--out", str(out)]) == 2
    assert "the approach point (above row 1)" in capsys.readouterr().err


def _run_with_tool(path_csv: Path, directory: Path, mass_kg: float) -> Path:
    """An IRB 6640 run along the path whose meta.json records a 300 mm tool and an import with `mass_kg` below the
    sensor."""
    stream = read_commanded_csv(path_csv)
    rate = 1.0 / float(np.median(np.diff(stream.t_s)))
    meta = run_meta(scenario="cell", source="test", tracker_rate_hz=rate, sensor_rate_hz=rate, seed=0,
                    tool_length_m=0.3, robot="irb6640")
    meta["import"] = {"sensor": {"tool_mass_kg": mass_kg}}
    return write_run(directory, Run(None, meta, stream, stream))


def test_tool_length_and_mass_come_from_the_options_the_run_or_the_robot(
    short: Path, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def tooldata(out: Path, *extra: str) -> list[float]:
        assert main(["export", str(short), "--format", "rapid", "--robot", "irb6640", "--out", str(out), *extra]) == 0
        found = re.search(r"tIsf:=\[TRUE,\[\[0,0,([\d.]+)\],\[1,0,0,0\]\],\[([\d.]+),", out.read_text())
        assert found
        return [float(found.group(1)), float(found.group(2))]

    run_dir = _run_with_tool(short, work / "run_tool", 2.5)
    assert tooldata(work / "robot.mod") == [274.94, 2.0]  # the IRB 6640 model's tool: 274.94 mm, its body 2 kg
    assert tooldata(work / "run.mod", "--run", str(run_dir)) == [300.0, 2.5]
    assert tooldata(work / "opt.mod", "--run", str(run_dir), "--tool-length-mm", "250",
                    "--tool-mass-kg", "3.1") == [250.0, 3.1]
    for option, value in (("--tool-mass-kg", "-3"), ("--tool-length-mm", "0"), ("--feed-mm-s", "-1")):
        capsys.readouterr()
        assert main(["export", str(short), "--format", "rapid", "--robot", "irb6640", "--out", str(work / "bad.mod"), option, value]) == 2
        assert f"{option} {value}" in capsys.readouterr().err
    assert not (work / "bad.mod").exists()


def test_safe_height_option_and_its_refusal(short: Path, work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(short), "--format", "krl", "--robot", "kr210", "--safe-height-mm", "50", "--out",
                 str(work / "h.src")]) == 0
    points, _ = _krl(work / "h.dat")
    assert points[0, 2] == points[-1, 2] == 50.0
    capsys.readouterr()
    assert main(["export", str(short), "--format", "krl", "--robot", "kr210", "--safe-height-mm", "-5", "--out",
                 str(work / "low.src")]) == 2
    err = capsys.readouterr().err
    assert "--safe-height-mm -5" in err and "highest point is at z = 0.000 mm" in err


def test_csv_first_line_is_the_header_and_the_frame_is_beside_it(short: Path, work: Path) -> None:
    out = work / "points.csv"
    assert main(["export", str(short), "--format", "csv", "--out", str(out)]) == 0
    with out.open(newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg", "feed_mm_s", "contact"]
    assert len(rows) == 1 + len(read_commanded_csv(short).t_s) + 2 and all(len(r) == 8 for r in rows)
    assert [r[7] for r in rows[1:3]] == ["0", "0"] and rows[3][7] == "1" and rows[-1][7] == "0"
    frame = json.loads((work / "points.frame.json").read_text())
    assert frame["tool_length_mm"] == pytest.approx(274.94) and frame["frame"] == "sheet"
