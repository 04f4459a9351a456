"""Programs a robot programmer loads unchanged (twin/apps/export: krl.py, krl_rsi.py, rapid.py, val3.py): one
structural checker per language, run on a cone exported for the robot that speaks it (`tx200-twin path --shape cone
--top-width-mm 60 --depth-mm 15`, then `export --robot kr210 | irb6640 | tx200`).

- **KRL** (KUKA KR210): the files are read as the controller runs them, the main `.src` with its part calls
  expanded: `DEF`/`END` once per `.src`, `DEFDAT`/`ENDDAT` per `.dat`; every name a statement uses declared in its
  own `.src` or `.dat` (or the controller's: `TOOL_DATA`, `BASE_DATA`, `LOAD_DATA`, `BAS`, RSI's functions) or a
  part it calls; `SPLINE`/`ENDSPLINE` balanced, not nested, holding only `SPL` segments, at most
  `krl.SPLINE_SEGMENTS` each; `TOOL_DATA[t]`, `LOAD_DATA[t]`, `BASE_DATA[b]` (`--tool-number`, `--base-number`,
  default 16: never the cell's calibrated 1 unless asked) assigned from the cell, no other slot, and `$TOOL`,
  `$LOAD`, `$BASE` set from them before the first motion; KUKA's `$STOPMESS` interrupt declared and switched on
  before it; the first and the last motion `PTP XHOME_ISF`, the
  robot's home in controller axes; every Cartesian move at `$VEL.CP` = the process feed in m/s; every point of the
  program (approach, path, retract) a target, in order, once; the robot at rest only on a corner of the path
  (`motion.corners`); and the advance run fed: at most `MAX_BLOCKS_PER_S` motion statements start in any second
  of the path at its programmed feeds.

  Why statements, and why 20 a second: a KR C4 interprets a few motion statements ahead of the robot ($ADVANCE =
  3) and plans each before the robot reaches it. A SPLINE block is planned as one motion, as a whole, so it counts
  once however many segments it holds; the user's program of single 0.5 mm `LIN` blocks at 34 mm/s asked for ~70
  statements a second and starved it. 20 a second leaves each statement 50 ms of motion, several of the
  controller's 12 ms interpolation cycles, which the user's KSS programmers keep LIN blocks above (feed / 20 mm
  = 1.7 mm at 34 mm/s); the spline program is far below it (the cone: ~0.5 a second).
- **RAPID** (ABB IRB 6640): `MODULE`/`PROC`/`FOR` balanced and `main` run with its calls and loops expanded (the
  interpreter of `tests/test_export_rapid_egm.py`); `tooldata` with a mass > 0, its centre of gravity and inertia set
  (`CellSetup.tool_cog_mm`); `MoveAbsJ jHome` the first and the last move, `jHome` the robot's home; every
  `robtarget` moved to, in order, once; `fine` only on a corner or at the end, and the `zPath` zone's corner path
  within `motion.CHORD_TOL_MM` of every blended point.
- **VAL3** (Stäubli TX200): `val3_check` passes; `stop` resets the motion (`resetMotion()`) and closes every socket
  a program opens (`clearBuffer`); `movej(jHome, ...)` the first and the last move, `jHome` the robot's home; the path's `mdesc` blend Cartesian with leave and reach.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted
from test_export_rapid_egm import Program as RapidProgram

from twin.apps.export import krl, krl_rsi, rapid, rapid_egm_pose
from twin.apps.export.motion import CHORD_TOL_MM, CORNER_DEG, turn_angles_deg, with_moves
from twin.apps.export.program import (
    DEFAULT_BASE_NUMBER,
    DEFAULT_TOOL_NUMBER,
    CellSetup,
    ProgramPath,
    default_cell,
    home_axes_deg,
    load_program_path,
)
from twin.apps.export.val3_check import check_application
from twin.cli import main
from twin.errors import InputError
from twin.robot.controller import MAX_CORRECTION_LIMIT_MM
from twin.sim.online import OnlineSettings

#: Motion statements that may start within one second of the path at its programmed feeds (module docstring).
MAX_BLOCKS_PER_S = 20.0
POSITION_TOL_MM = 0.5e-4 + 1e-9  # the programs' 4 decimals
ROBOTS = {"kr210": "krl", "irb6640": "rapid", "tx200": "val3"}
#: Names KRL takes from the controller (`$config.dat`, `BAS`, the RSI package) rather than the program.
KRL_GLOBALS = {"TOOL_DATA", "BASE_DATA", "LOAD_DATA", "BAS", "RSI_CREATE", "RSI_ON", "RSI_OFF", "RSIOK",
               "IR_STOPM"}
KRL_KEYWORDS = {"DEF", "END", "DECL", "INT", "REAL", "POS", "E6AXIS", "PTP", "SLIN", "SPL", "SPLINE", "ENDSPLINE",
                "WITH", "C_SPL", "IF", "THEN", "ENDIF", "HALT", "TRUE", "FALSE", "DEFDAT", "ENDDAT", "PUBLIC",
                "GLOBAL", "INTERRUPT", "WHEN", "DO", "ON"}
#: KUKA's stop-message interrupt as its template declares it (`krl` module docstring).
STOPMESS = re.compile(r"GLOBAL INTERRUPT DECL (\d+) WHEN \$STOPMESS==TRUE DO IR_STOPM \( \)")


@pytest.fixture(scope="module")
def cone_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The cone of the user's report, as `tx200-twin path` writes it (11 521 points)."""
    out = tmp_path_factory.mktemp("cone") / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "60", "--depth-mm", "15", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def groove_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The groove: its reversals are corners the robot stops on."""
    out = tmp_path_factory.mktemp("groove") / "groove.csv"
    assert main(["path", "--shape", "groove", "--out", str(out)]) == 0
    return out


def _expected(path_csv: Path, robot: str) -> ProgramPath:
    """The program's points and feeds as `export` makes them (approach, path, retract), and the robot's cell."""
    return with_moves(load_program_path(path_csv, default_cell(robot=robot), "expected"))[0]


#: The programs written so far in this module: (path, robot, the file or folder's name, options) -> name -> text.
_EXPORTED: dict[tuple[Path, str, str, tuple[str, ...]], dict[str, str]] = {}


def _export(path_csv: Path, robot: str, out: Path, *extra: str) -> dict[str, str]:
    """`tx200-twin export PATH --robot ROBOT --out OUT` into a fresh folder: the files written, name -> text (a
    copy: the checkers' tests edit it). Run once per module for the same path, robot, name and options, which
    give the same program (the exporter is deterministic): the checker grids edit one export each."""
    key = (path_csv, robot, out.name, extra)
    if key not in _EXPORTED:
        assert main(["export", str(path_csv), "--robot", robot, "--out", str(out), *extra]) == 0
        folder = out if out.is_dir() else out.parent
        _EXPORTED[key] = {f.name: f.read_text(encoding="utf-8") for f in sorted(folder.iterdir()) if f.is_file()}
    return dict(_EXPORTED[key])


# ----------------------------------------------------------------------------------------------------------- KRL


def _strip(line: str) -> str:
    """A KRL line without its comment (from `;`; the programs' strings hold none) and the blanks around it."""
    return line.split(";", 1)[0].strip()


def _numbers(literal: str) -> dict[str, float]:
    """The top-level numeric fields of a KRL aggregate `{X 1.0,Y 2.0,...}` (nested ones left out)."""
    flat = re.sub(r"\{[^{}]*\}", "", literal[1:-1]) if literal.count("{") > 1 else literal[1:-1]
    return {k: float(v) for k, v in re.findall(r"([A-Z][A-Z0-9]*) (-?[\d.]+)", flat)}


@dataclass
class KrlModule:
    """One `.src`/`.dat` pair: its statements (DEF .. END, comments out), declared names and data values."""

    name: str
    body: list[str]
    declared: set[str]
    data: dict[str, object]


def _read_dat(name: str, text: str) -> tuple[set[str], dict[str, object]]:
    """A data list's declarations and values: REAL -> float, aggregate -> its fields, array -> index -> value."""
    lines = [_strip(line) for line in text.splitlines()]
    lines = [line for line in lines if line and not line.startswith("&")]
    assert lines[0] == f"DEFDAT {name} PUBLIC" and lines[-1] == "ENDDAT", f"{name}.dat: DEFDAT ... ENDDAT"
    declared: set[str] = set()
    data: dict[str, object] = {}
    for line in lines[1:-1]:
        decl = re.fullmatch(r"DECL (\w+) (\w+)(?:\[(\d+)\])?(?:=(.*))?", line)
        if decl:
            kind, var, size, value = decl.groups()
            assert var not in declared, f"{name}.dat declares {var} twice"
            declared.add(var)
            data[var] = {} if size else (float(value) if kind == "REAL" else _numbers(value) if value else None)
            continue
        item = re.fullmatch(r"(\w+)\[(\d+)\]=(.*)", line)
        assert item and item.group(1) in declared, f"{name}.dat: {line!r} assigns an undeclared array"
        array = data[item.group(1)]
        assert isinstance(array, dict)
        array[int(item.group(2))] = float(item.group(3)) if item.group(3)[0] != "{" else _numbers(item.group(3))
    return declared, data


def _read_krl(files: dict[str, str]) -> dict[str, KrlModule]:
    """Each `.src` with its `.dat`: `DEF NAME( )` ... `END` once, the name the file's."""
    modules = {}
    for file, text in files.items():
        if not file.endswith(".src"):
            continue
        name = file[:-4].upper()
        lines = [_strip(line) for line in text.splitlines()]
        lines = [line for line in lines if line and not line.startswith("&")]
        defs = [i for i, line in enumerate(lines) if line.startswith("DEF ")]
        assert defs == [0] and lines[0] == f"DEF {name}( )", f"{file}: one DEF {name}( ), first"
        assert lines.count("END") == 1 and lines[-1] == "END", f"{file}: one END, last"
        declared, data = _read_dat(name, files[file[:-4] + ".dat"])
        for line in lines[1:-1]:
            local = re.fullmatch(r"DECL \w+ (\w+)", line)
            if local:
                assert local.group(1) not in declared, f"{file} declares {local.group(1)} twice"
                declared.add(local.group(1))
        modules[name] = KrlModule(name, lines[1:-1], declared, data)
    return modules


def _check_names(modules: dict[str, KrlModule]) -> None:
    """Every name a statement uses is declared in its module, the controller's, a keyword or a module called."""
    for module in modules.values():
        for line in module.body:
            text = re.sub(r'"[^"]*"', "", line)
            while "{" in text:
                text = re.sub(r"\{[^{}]*\}", "", text)
            text = re.sub(r"[$#]\w+(\.\w+)?", "", text)
            for name in re.findall(r"[A-Za-z_]\w*", text):
                known = name in KRL_KEYWORDS or name in KRL_GLOBALS or name in module.declared or name in modules
                assert known, f"{module.name}.src: {name!r} in {line!r} is declared nowhere"


@dataclass
class KrlMove:
    """One motion as the controller runs it."""

    kind: str  # PTP, SLIN, SPL
    target: str
    module: str
    value: dict[str, float]  # the target's fields (X..C or A1..E6)
    vel_m_s: float | None  # $VEL.CP for a Cartesian move
    statement: int  # the motion statement it belongs to (a SPLINE block or a single motion)
    rests: bool  # the robot is at rest at its end (a statement's last move without C_SPL)


class KrlRun:
    """The program run from its main `.src`: the moves in order and what was set before the first one."""

    def __init__(self, files: dict[str, str]) -> None:
        self.modules = _read_krl(files)
        _check_names(self.modules)
        self.moves: list[KrlMove] = []
        self.assigned: dict[str, str] = {}  # TOOL_DATA[n], $TOOL, ... -> value, as set before the first move
        self.interrupts: dict[int, bool] = {}  # declared interrupt -> switched on, before the first move
        self.vel: float | None = None
        self.statements = 0
        main_name = next(f for f in files if f.endswith(".src"))[:-4].upper()
        self._run(self.modules[main_name], set())

    def _value(self, module: KrlModule, ref: str) -> object:
        found = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", ref)
        assert found and found.group(1) in module.data, f"{module.name}: {ref} is not in its data list"
        value = module.data[found.group(1)]
        if found.group(2) is not None:
            assert isinstance(value, dict) and int(found.group(2)) in value, f"{module.name}: {ref} has no value"
            return value[int(found.group(2))]
        return value

    def _move(self, module: KrlModule, line: str, kind: str, statement: int, last: bool) -> None:
        found = re.fullmatch(rf"{kind} (\w+(?:\[\d+\])?)(?: WITH \$VEL\.CP=(\w+(?:\[\d+\])?))?( C_SPL)?", line)
        assert found, f"{module.name}: {line!r} is not a {kind} this program writes"
        target, vel, blend = found.groups()
        value = self._value(module, target)
        assert isinstance(value, dict), f"{module.name}: {target} is not a position"
        speed = None
        if kind != "PTP":
            speed = float(self._value(module, vel)) if vel else self.vel  # type: ignore[arg-type]
            assert speed is not None, f"{module.name}: {line!r} runs before $VEL.CP is set"
        rests = last and not blend
        self.moves.append(KrlMove(kind, target, module.name, value, speed, statement, rests))

    def _run(self, module: KrlModule, calling: set[str]) -> None:
        assert module.name not in calling, f"{module.name} calls itself"
        body = [line for line in module.body if not line.startswith("DECL ")]
        i = 0
        while i < len(body):
            line = body[i]
            if line in ("SPLINE",):
                end = next((k for k in range(i + 1, len(body)) if body[k].startswith(("ENDSPLINE", "SPLINE"))), None)
                assert end is not None and body[end].startswith("ENDSPLINE"), f"{module.name}: SPLINE not closed"
                assert body[end] in ("ENDSPLINE", "ENDSPLINE C_SPL"), f"{module.name}: {body[end]!r}"
                segments = body[i + 1 : end]
                assert 2 <= len(segments) <= krl.SPLINE_SEGMENTS, f"{module.name}: a block of {len(segments)}"
                self.statements += 1
                for k, segment in enumerate(segments):
                    assert segment.startswith("SPL "), f"{module.name}: {segment!r} inside a SPLINE block"
                    self._move(module, segment + (" C_SPL" if body[end].endswith("C_SPL") else ""), "SPL",
                               self.statements, k == len(segments) - 1)
                i = end + 1
                continue
            assert not line.startswith(("ENDSPLINE", "SPL ")), f"{module.name}: {line!r} outside a SPLINE block"
            head = line.split()[0]
            if head in ("PTP", "SLIN"):
                self.statements += 1
                self._move(module, line, head, self.statements, True)
            elif re.fullmatch(r"\w+\( \)", line):
                called = line[:-3]
                assert called in self.modules, f"{module.name} calls {called}, which is no file of the program"
                self._run(self.modules[called], calling | {module.name})
            elif STOPMESS.fullmatch(line) or line.startswith(("GLOBAL ", "INTERRUPT ")):
                declared = STOPMESS.fullmatch(line)
                switched = re.fullmatch(r"INTERRUPT ON (\d+)", line)
                assert declared or switched, f"{module.name}: {line!r} is not an interrupt this program writes"
                if declared:
                    self.interrupts.setdefault(int(declared.group(1)), False)
                elif switched and not self.moves:
                    assert int(switched.group(1)) in self.interrupts, f"{module.name}: {line!r} before its DECL"
                    self.interrupts[int(switched.group(1))] = True
            elif line == "$VEL.CP=V_PROC":
                self.vel = float(self._value(module, "V_PROC"))  # type: ignore[arg-type]
            elif "=" in line and not line.startswith(("IF", "ret=")):
                var, value = line.split("=", 1)
                if not self.moves:
                    self.assigned[var] = value
            i += 1

    def check_tool_load_base(self, cell: CellSetup, tool_no: int = DEFAULT_TOOL_NUMBER,
                             base_no: int = DEFAULT_BASE_NUMBER) -> None:
        """TOOL_DATA[t], LOAD_DATA[t], BASE_DATA[b] from the cell, then $TOOL, $LOAD, $BASE from them, before the
        first move; no other slot written (the cell's calibrated tool 1 and base 1 untouched unless asked for)."""
        order = list(self.assigned)
        slots = {"$TOOL": f"TOOL_DATA[{tool_no}]", "$LOAD": f"LOAD_DATA[{tool_no}]", "$BASE": f"BASE_DATA[{base_no}]"}
        for sys_var, data in slots.items():
            assert data in self.assigned and self.assigned.get(sys_var) == data, f"{sys_var}={data} before a move"
            assert order.index(data) < order.index(sys_var), f"{data} assigned after {sys_var} reads it"
        written = {var for var in self.assigned if re.match(r"(TOOL|LOAD|BASE)_DATA\[", var)}
        assert written == set(slots.values()), f"writes {sorted(written)}; expected only {sorted(slots.values())}"
        tool_data, load_data, base_data = slots["$TOOL"], slots["$LOAD"], slots["$BASE"]
        tool = _numbers(self.assigned[tool_data])
        assert [tool[k] for k in "XYZABC"] == pytest.approx([0, 0, cell.tool_length_mm, 0, 0, 0], abs=1e-4)
        load = self.assigned[load_data]
        found = re.fullmatch(r"\{M ([\d.]+),CM (\{[^}]*\}),J \{X ([\d.]+),Y ([\d.]+),Z ([\d.]+)\}\}", load)
        assert found, load
        mass = float(found.group(1))
        inertia = [float(found.group(k)) for k in (3, 4, 5)]  # a mass has an inertia: the cell tool's cylinder
        assert inertia == pytest.approx(cell.tool_inertia_kgm2, abs=1e-6) and min(inertia) > 0
        cog = _numbers(re.search(r"CM (\{[^}]*\})", load).group(1))  # type: ignore[union-attr]
        assert mass == pytest.approx(cell.tool_mass_kg, abs=1e-3) and mass > 0
        assert [cog[k] for k in "XYZ"] == pytest.approx(cell.tool_cog_mm, abs=1e-4) and cog["Z"] > 0
        base = _numbers(self.assigned[base_data])
        assert [base[k] for k in "XYZ"] == pytest.approx(cell.p_base_sheet_mm, abs=1e-4)
        assert [base[k] for k in "ABC"] == pytest.approx([cell.yaw_deg, 0, 0], abs=1e-4)

    def check_stop_interrupt(self) -> None:
        """KUKA's stop-message interrupt declared and switched on before the first move."""
        assert any(self.interrupts.values()), (f"no $STOPMESS interrupt declared and switched on before the first "
                                               f"move (declared: {self.interrupts})")

    def check_path(self, expected: ProgramPath) -> tuple[int, float]:
        """HOME first and last; every point a target, in order, once; $VEL.CP the process feed; rests on corners;
        the advance run fed. Returns the motion statements on the path and its duration at its feeds [s]."""
        home, last = self.moves[0], self.moves[-1]
        assert (home.kind, home.target) == (last.kind, last.target) == ("PTP", krl.HOME), "HOME first and last"
        axes = [home.value[f"A{i}"] for i in range(1, 7)]
        assert axes == pytest.approx(home_axes_deg(expected.cell), abs=1e-4)
        assert all(home.value[f"E{i}"] == 0.0 for i in range(1, 7))
        path = self.moves[1:-1]
        assert all(m.target != krl.HOME for m in path) and path[0].kind == "PTP"
        assert {m.kind for m in path[1:]} <= {"SLIN", "SPL"}, "one joint move: to the approach point"
        xyz = np.array([[m.value[k] for k in "XYZ"] for m in path])
        np.testing.assert_allclose(xyz, expected.points_mm, atol=POSITION_TOL_MM)  # all points, in order, once
        process = expected.process_feed * 1e-3
        vel = np.array([m.vel_m_s for m in path[1:]], dtype=float)
        np.testing.assert_allclose(vel, process, atol=0.5e-7)  # $VEL.CP the process feed [m/s], 7 decimals
        turn = turn_angles_deg(expected.points_mm)
        for k, move in enumerate(path[1:], start=1):  # move k reaches point k
            corner = turn[k] > CORNER_DEG or k == len(path) - 1
            assert move.rests == corner, (f"point {k + 1}: the robot {'stops' if move.rests else 'does not stop'} "
                                          f"there, where the path turns by {turn[k]:.2f} deg")
        steps = np.linalg.norm(np.diff(xyz, axis=0), axis=1) * 1e-3  # [m]; move k reaches point k
        t_end = np.cumsum(steps / vel)  # when each move ends, at its programmed feed [s]
        starts = np.concatenate([[0.0], t_end[:-1]])
        begin: dict[int, float] = {}
        for k, move in enumerate(path[1:]):
            begin.setdefault(move.statement, float(starts[k]))
        first = np.sort(np.array(list(begin.values())))
        window = max(int(np.searchsorted(first, s + 1.0, side="left")) - i for i, s in enumerate(first))
        assert window <= MAX_BLOCKS_PER_S, f"{window} motion statements within 1 s (the bound: {MAX_BLOCKS_PER_S:g})"
        print(f"\nKRL: {len(first)} motion statements over {t_end[-1]:.1f} s of path ({len(first) / t_end[-1]:.2f}/s, "
              f"at most {window} in any second), {len(path)} points, $VEL.CP {process:.7f} m/s")
        return len(first), float(t_end[-1])


def check_krl(files: dict[str, str], expected: ProgramPath) -> tuple[KrlRun, int, float]:
    """The KRL rules (module docstring); returns the run, its motion statements on the path and the path's
    duration at its feeds [s]."""
    run = KrlRun(files)
    run.check_tool_load_base(expected.cell, expected.tool_number, expected.base_number)
    run.check_stop_interrupt()
    statements, duration = run.check_path(expected)
    return run, statements, duration


@pytest.mark.parametrize("shape", ["cone", "groove"])
def test_krl_for_the_kr210_loads_unchanged_and_runs_at_the_process_feed(
    shape: str, cone_csv: Path, groove_csv: Path, tmp_path: Path
) -> None:
    path_csv = cone_csv if shape == "cone" else groove_csv
    files = _export(path_csv, "kr210", tmp_path / "ISF.src")
    expected = _expected(path_csv, "kr210")
    run, statements, duration = check_krl(files, expected)
    if shape == "cone":  # 11 523 points: split into parts the main program calls, the path in spline blocks
        assert len([f for f in files if f.endswith(".src")]) > 2
        assert sum(m.kind == "SPL" for m in run.moves) > 0.99 * len(expected.points_mm)
        # one LIN per point, as before, against the spline blocks: the rate docs/import-export.md quotes
        per_point = (len(expected.points_mm) - 1) / duration
        quoted("import-export.md", "instead of one `LIN` per point (about", 1)[0].check(per_point)
        assert per_point > 4 * MAX_BLOCKS_PER_S and statements / duration < 1.0
    else:  # the groove's 9 reversals: the only stops in contact besides the path's ends
        rests = [m for m in run.moves[2:-2] if m.rests]
        assert len(rests) == 1 + 9 + 1  # the bottom of the move down onto the path, the reversals, the path's end


def test_krl_writes_the_tool_and_base_slots_the_user_names_and_refuses_a_bad_one(
    groove_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--tool-number 5 --base-number 32`: TOOL_DATA[5], LOAD_DATA[5], BASE_DATA[32] and nothing else, the header
    saying which slots it overwrites; a slot KRL does not have is refused (exit 2) naming the option."""
    files = _export(groove_csv, "kr210", tmp_path / "ISF.src", "--tool-number", "5", "--base-number", "32")
    check_krl(files, replace(_expected(groove_csv, "kr210"), tool_number=5, base_number=32))
    assert "; this program OVERWRITES tool 5 (TOOL_DATA[5], LOAD_DATA[5]) and base 32 (BASE_DATA[32])" in files["ISF.src"]
    default = _export(groove_csv, "kr210", tmp_path / "default" / "ISF.src")["ISF.src"]
    assert "TOOL_DATA[16]=" in default and "BASE_DATA[16]=" in default and "_DATA[1]" not in default
    for option, value in (("--tool-number", "0"), ("--tool-number", "17"), ("--base-number", "33"),
                          ("--base-number", "-1")):
        out = tmp_path / "bad" / "ISF.src"
        assert main(["export", str(groove_csv), "--robot", "kr210", "--out", str(out), option, value]) == 2
        err = capsys.readouterr().err
        assert f"{option} {value}" in err and ("1..16" if option == "--tool-number" else "1..32") in err
        assert not out.exists()


def test_krl_with_rsi_switches_it_on_after_the_approach_and_off_after_the_path(cone_csv: Path, tmp_path: Path) -> None:
    """The split cone with `--online`: RSI on in the first part after `PTP P_PATH[1]`, off at the end of the last
    part after the retract; the moves HOME are never corrected."""
    files = _export(cone_csv, "kr210", tmp_path / "ISF.src", "--online")
    check_krl({k: v for k, v in files.items() if k.endswith((".src", ".dat"))}, _expected(cone_csv, "kr210"))
    sources = [name for name in files if name.endswith(".src")]
    main_src, first, last = (files[n].splitlines() for n in ("ISF.src", "ISF_1.src", sources[-1]))
    assert not any("RSI" in _strip(line) for line in main_src)  # HOME, then the parts, then HOME: uncorrected
    on = first.index("ret=RSI_ON(#ABSOLUTE,#IPO_FAST)")
    assert first.index("PTP P_PATH[1]") < first.index('ret=RSI_CREATE("ISF_RSI.rsix",CONTID,TRUE)') < on
    check_rsi(files)
    assert on < first.index("SLIN P_PATH[2]")
    off = last.index("ret=RSI_OFF()")
    assert re.fullmatch(r"SLIN P_PATH\[\d+\]", last[off - 1]) and last[off + 4 :] == ["END"]
    assert "DECL INT ret" in last and "DECL INT ret" in first and "DECL INT CONTID" in first


def check_rsi(files: dict[str, str], limit: float = OnlineSettings().max_correction_mm) -> ET.Element:
    """The RSI rules: `RSI_CREATE` names a context file that is written (with its extension); the context's
    ETHERNET object names the configuration written beside it, with a late-packet `Timeout`; its POSCORR object
    takes the ETHERNET outputs 1-6, its X/Y/Z limits `limit` (the compensator's `max_correction_mm`), its reference frame
    the robot base (`#WORLD`, which the server's `RKorr` is in, said in the main program's header), beside a
    correction monitor; `RSI_ON` absolute (the server's whole corrections) at `#IPO_FAST` (4 ms)."""
    code = [_strip(line) for text in (v for k, v in files.items() if k.endswith(".src")) for line in text.splitlines()]
    (create,) = [line for line in code if "RSI_CREATE" in line]
    found = re.fullmatch(r'ret=RSI_CREATE\("(\w+\.rsix)",CONTID,TRUE\)', create)
    assert found and found.group(1) in files, f"{create!r}: no such context among {sorted(files)}"
    on = [line for line in code if "RSI_ON" in line]
    assert on == ["ret=RSI_ON(#ABSOLUTE,#IPO_FAST)"], f"{on}: RSI_ON absolute at 4 ms"
    context = ET.fromstring(files[found.group(1)])
    objects = {o.get("ObjType"): o for o in context.iter("RsiObject")}
    assert {"Ethernet", "PosCorr", "PosCorrMon"} <= set(objects), sorted(objects)

    def params(kind: str) -> dict[str, str]:
        return {p.get("Name", ""): p.get("ParamValue", "") for p in objects[kind].iter("Parameter")}

    ethernet = params("Ethernet")
    assert ethernet["ConfigFile"] in files and ET.fromstring(files[ethernet["ConfigFile"]]).find("CONFIG") is not None
    assert 0 < int(ethernet["Timeout"]) <= 100
    ethernet_id = objects["Ethernet"].get("ObjId")
    wired = sorted((int(i.get("InIdx", "-1")), i.get("OutObjId"), int(i.get("OutIdx", "-1")))
                   for i in objects["PosCorr"].iter("Input"))
    assert wired == [(i, ethernet_id, i) for i in range(6)], wired
    poscorr = params("PosCorr")
    for axis in "XYZ":
        lower, upper = float(poscorr[f"LowerLim{axis}"]), float(poscorr[f"UpperLim{axis}"])
        assert (lower, upper) == (-limit, limit), f"LowerLim{axis}, UpperLim{axis} {lower:g}, {upper:g}"
    frame = poscorr["RefCorrSys"]
    assert frame == krl_rsi.CORRECTION_FRAME == "#WORLD", f"RefCorrSys {frame}: RKorr comes in the robot base"
    assert float(params("PosCorrMon")["MaxTrans"]) >= math.sqrt(3) * limit
    main_src = files[next(k for k in files if k.endswith(".src"))]
    header = " ".join(line for line in main_src.splitlines() if line.startswith(";"))
    assert "ROBOT BASE frame" in header and "#WORLD" in header and "$ROBROOT" in header
    assert f"limits +/-{limit:g} mm a axis" in header
    return context


def test_an_online_program_takes_the_correction_limit_its_server_is_given(
    groove_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`export --online --max-correction-mm 8` (a cell that bends further than the default 5 mm, the IRB 6640's
    deepest groove passes): the RSI context's POSCORR limits and monitor and the RAPID position-guidance program's
    end tolerance take 8 mm, as `online --max-correction-mm 8` does; a limit that is not one is refused (exit 2)
    naming the option, nothing written."""
    check_rsi(_export(groove_csv, "kr210", tmp_path / "ISF.src", "--online", "--max-correction-mm", "8"), limit=8.0)
    check_rsi(_export(groove_csv, "kr210", tmp_path / "default" / "ISF.src", "--online"))
    rapid = _export(groove_csv, "irb6640", tmp_path / "abb" / "ISF.mod", "--online", "--max-correction-mm", "8")
    assert f"  CONST num nEndTol:={8.0 + rapid_egm_pose.END_MARGIN_MM:g};" in rapid["ISF.mod"].splitlines()
    for value in ("0", "-1", "nan", "60"):
        out = tmp_path / "bad" / "ISF.src"
        assert main(["export", str(groove_csv), "--robot", "kr210", "--online", "--out", str(out),
                     "--max-correction-mm", value]) == 2
        err = capsys.readouterr().err
        assert "--max-correction-mm" in err and f"at most {MAX_CORRECTION_LIMIT_MM:g}" in err and "Traceback" not in err
        assert not out.exists()
    out = tmp_path / "offline" / "ISF.src"  # an offline program has no correction to limit: refused
    assert main(["export", str(groove_csv), "--robot", "kr210", "--out", str(out), "--max-correction-mm", "8"]) == 2
    assert "without --online" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize(
    ("file", "old", "new", "pattern"),
    [
        (".rsix", None, None, r"no such context"),
        (".rsix", 'ParamValue="#WORLD"', 'ParamValue="#BASE"', r"RefCorrSys"),
        (".rsix", 'Name="UpperLimZ" ParamId="5" ParamValue="5"', 'Name="UpperLimZ" ParamId="5" ParamValue="50"',
         r"UpperLimZ"),
        ("ISF.src", "ret=RSI_ON(#ABSOLUTE,#IPO_FAST)", "ret=RSI_ON(#RELATIVE)", r"RSI_ON"),
    ],
)
def test_the_rsi_checker_refuses_a_missing_context_another_frame_or_mode(
    groove_csv: Path, tmp_path: Path, file: str, old: str | None, new: str | None, pattern: str
) -> None:
    """The RSI checker is strict: the context RSI_CREATE names missing, POSCORR in the sheet's `#BASE` while the
    server sends the robot base, limits wider than the compensator's, the relative mode."""
    files = _export(groove_csv, "kr210", tmp_path / "ISF.src", "--online")
    check_rsi(files)
    name = next(n for n in files if n.endswith(file))
    if old is None:
        del files[name]
    else:
        assert old in files[name]
        files[name] = files[name].replace(old, new or "", 1)
    with pytest.raises(AssertionError, match=pattern):
        check_rsi(files)


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ("$LOAD=LOAD_DATA[16]\n", "", r"\$LOAD=LOAD_DATA\[16\] before a move"),
        ("BASE_DATA[16]={", "BASE_DATA[1]={", r"BASE_DATA\[16\] before a move"),
        ("  INTERRUPT ON 3\n", "", r"no \$STOPMESS interrupt"),
        ("ENDSPLINE C_SPL\n", "", r"SPLINE not closed|inside a SPLINE block"),
        ("$VEL.CP=V_PROC\n", "$VEL.CP=V_FAST\n", r"'V_FAST'.*declared nowhere"),
        ("PTP XHOME_ISF\nEND", "END", r"HOME first and last"),
        ("  SPL P_PATH[5]\n", "", r"Not equal to tolerance|shapes"),
    ],
)
def test_the_krl_checker_refuses_what_a_controller_would(
    cone_csv: Path, tmp_path: Path, old: str, new: str, pattern: str
) -> None:
    """The checker is strict: a load not set, a block left open, an undeclared name, no HOME at the end, a point
    left out."""
    files = _export(cone_csv, "kr210", tmp_path / "ISF.src")
    name = next(n for n in files if n.endswith(".src") and old in files[n])
    files[name] = files[name].replace(old, new, 1)
    with pytest.raises(AssertionError, match=pattern):
        check_krl(files, _expected(cone_csv, "kr210"))


# --------------------------------------------------------------------------------------------------------- RAPID


def check_rapid(files: dict[str, str], expected: ProgramPath) -> RapidProgram:
    """The RAPID rules (module docstring); returns the program run."""
    program = RapidProgram(files)  # MODULE/PROC/FOR balanced, statements terminated, main run
    text = "\n".join(files.values())
    cell = expected.cell
    tool = re.search(r"PERS tooldata tIsf:=\[TRUE,\[\[([^\]]*)\],\[[^\]]*\]\],\[([\d.]+),\[([^\]]*)\],"
                     r"\[1,0,0,0\],([\d.]+),([\d.]+),([\d.]+)\]\];", text)
    assert tool, "tooldata tIsf with its load"
    assert [float(v) for v in tool.group(1).split(",")] == pytest.approx([0, 0, cell.tool_length_mm])
    mass, cog = float(tool.group(2)), [float(v) for v in tool.group(3).split(",")]
    assert mass == pytest.approx(cell.tool_mass_kg) and mass > 0
    assert cog == pytest.approx(cell.tool_cog_mm, abs=1e-4) and cog[2] > 0
    inertia = [float(tool.group(k)) for k in (4, 5, 6)]  # ix iy iz: the cell tool's cylinder, not 0 with a mass
    assert inertia == pytest.approx(cell.tool_inertia_kgm2, abs=1e-6) and min(inertia) > 0
    home = re.search(r"CONST jointtarget jHome:=\[\[([^\]]*)\],\[9E9,9E9,9E9,9E9,9E9,9E9\]\];", text)
    assert home and [float(v) for v in home.group(1).split(",")] == pytest.approx(home_axes_deg(cell), abs=1e-4)
    moves = [s for s in program.steps if s.kind in ("MoveAbsJ", "MoveJ", "MoveL")]
    assert moves[0].kind == moves[-1].kind == "MoveAbsJ" and moves[0].args[0] == moves[-1].args[0] == "jHome"
    assert [s.kind for s in moves[1:-1]] == ["MoveJ"] + ["MoveL"] * (len(moves) - 3)
    targets = sum(len(m.data["pPath"]) for m in program.modules if "pPath" in m.data)  # type: ignore[arg-type]
    assert targets == len(moves) - 2 == len(expected.points_mm)  # every robtarget used, once
    np.testing.assert_allclose([s.point for s in moves[1:-1]], expected.points_mm, atol=POSITION_TOL_MM)
    zone = re.search(r"CONST zonedata zPath:=\[FALSE,([\d.]+),", text)
    assert zone
    r = float(zone.group(1))
    turn = turn_angles_deg(expected.points_mm)
    steps = np.linalg.norm(np.diff(expected.points_mm, axis=0), axis=1)
    for k, move in enumerate(moves[2:-1], start=1):  # move k reaches point k
        corner = turn[k] > CORNER_DEG or k == len(expected.points_mm) - 1
        assert move.zone == ("fine" if corner else "zPath"), f"point {k + 1}: {move.zone}, turn {turn[k]:.2f} deg"
        if not corner:  # the controller shortens a zone to half the shorter of the two moves
            r_k = min(r, steps[k - 1] / 2, steps[k] / 2)
            assert r_k * math.sin(math.radians(turn[k]) / 2) / 2 <= CHORD_TOL_MM + 1e-9, f"point {k + 1}"
    return program


def test_rapid_for_the_irb6640_loads_unchanged(cone_csv: Path, tmp_path: Path) -> None:
    files = _export(cone_csv, "irb6640", tmp_path / "ISF.mod")
    expected = _expected(cone_csv, "irb6640")
    check_rapid(files, expected)
    assert rapid.zone_mm(expected) == rapid.ZONE_MAX_MM  # the cone turns by 1° per point at most: z1


def test_rapid_stops_on_the_grooves_corners_only(groove_csv: Path, tmp_path: Path) -> None:
    files = _export(groove_csv, "irb6640", tmp_path / "ISF.mod")
    program = check_rapid(files, _expected(groove_csv, "irb6640"))
    fine = [s for s in program.steps if s.kind == "MoveL" and s.zone == "fine"]
    assert len(fine) == 1 + 9 + 2  # the bottom of the descent, the 9 reversals, the path's last point, the retract


# ---------------------------------------------------------------------------------------------------------- VAL3


def _val3_code(pgx: str) -> list[str]:
    code = ET.fromstring(pgx).find(".//{*}Code")
    text = "" if code is None or code.text is None else code.text
    return [line.split("//", 1)[0].strip() for line in text.splitlines() if line.split("//", 1)[0].strip()]


def check_val3(files: dict[str, str], expected: ProgramPath) -> None:
    """The VAL3 rules (module docstring)."""
    check_application(files)
    stop = _val3_code(files["stop.pgx"])
    assert "resetMotion()" in stop, "stop: the motion left cancelled when the application stops"
    sockets = {line.split("(")[1].split(",")[0].rstrip(")") for text in files.values() if text.startswith("<?xml")
               for line in _val3_code(text) if line.startswith("sioCtrl(")}
    assert all(f"clearBuffer({sio})" in stop for sio in sockets), f"stop closes the sockets {sockets}: {stop}"
    moves = [line for line in _val3_code(files["start.pgx"]) if re.match(r"(movej|movel|alterMovel)\(", line)]
    assert moves[0] == moves[-1] == "movej(jHome, tIsf, mApproach)" and moves[1] == "movej(pPath[0], tIsf, mApproach)"
    dtx = ET.fromstring(next(text for name, text in files.items() if name.endswith(".dtx")))
    data = {d.get("name"): d for d in dtx.iter() if d.tag.endswith("Data")}
    assert data["jHome"].get("type") == "jointRx"
    (home,) = list(data["jHome"])
    axes = [float(home.get(f"j{i}", "nan")) for i in range(1, 7)]
    assert axes == pytest.approx(home_axes_deg(expected.cell), abs=1e-4)
    blends = {(v.get("blend"), float(v.get("leave", "0")) > 0, float(v.get("reach", "0")) > 0) for v in data["mPath"]}
    assert blends == {("Cartesian", True, True)}
    assert int(data["pPath"].get("size", "0")) == len(expected.points_mm)


@pytest.mark.parametrize("online", [False, True])
def test_val3_for_the_tx200_passes_the_checker_and_moves_home(
    cone_csv: Path, tmp_path: Path, online: bool
) -> None:
    files = _export(cone_csv, "tx200", tmp_path / "ISF", *(["--online"] if online else []))
    check_val3(files, _expected(cone_csv, "tx200"))


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ("movel(pPath[i], tIsf, mPath[i])", "movel(jHome, tIsf, mPath[i])", r"not a pointRx"),
        ('type="jointRx" size="1">\n      <Value key="0" j1=', 'type="jointRx" size="1">\n      <Value key="0" j0=',
         r"field j1=None, expected a number"),
        ("movej(jHome, tIsf, mApproach)", "movej(jHome, mApproach, tIsf)", r"not a tool"),
    ],
)
def test_the_val3_checker_takes_a_jointrx_home_strictly(
    cone_csv: Path, tmp_path: Path, old: str, new: str, pattern: str
) -> None:
    """`movej` takes a `jointRx` (the home), `movel` does not; a `jointRx` datum has j1..j6."""
    files = _export(cone_csv, "tx200", tmp_path / "ISF")
    name = next(n for n, text in files.items() if old in text)
    files[name] = files[name].replace(old, new, 1)
    with pytest.raises(InputError, match=pattern):
        check_application(files)


# ---------------------------------------------------------------------------------------------------------- docs


def test_the_numbers_docs_quote_are_the_exporters() -> None:
    """docs/import-export.md's program structure: the spline block size, the corner angle, the chord tolerance and
    RAPID's largest zone, read from the page."""
    (segments,) = quoted("import-export.md", "`SPLINE` ... `ENDSPLINE` blocks of at most", 1)
    segments.check(krl.SPLINE_SEGMENTS)
    (corner,) = quoted("import-export.md", "where the path turns by more than", 1)
    corner.check(CORNER_DEG)
    (tol,) = quoted("import-export.md", "blends within the chord tolerance of", 1)
    tol.check(CHORD_TOL_MM)
    (zone,) = quoted("import-export.md", "`zPath`, at most", 1)
    zone.check(rapid.ZONE_MAX_MM)
    (bound,) = quoted("import-export.md", "for KRL at most", 1)
    bound.check(MAX_BLOCKS_PER_S)
