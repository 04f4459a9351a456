"""ABB RAPID with EGM path correction (twin/apps/export/rapid_egm.py, `export --online` for an ABB robot).

The program is read as the controller runs it: a small structural checker balances MODULE/PROC/FOR, resolves the
data each module may see (its own, LOCAL or not, and the other modules' global data) and expands `main`'s calls
and loops into the sequence of instructions. On that sequence: EGM is set up and activated after the joint move
to the approach point, every point of the path (and only those) is an `EGMMoveL` on the declared `egmident`, the
last one ends at rest (`fine`), EGM stops before the uncorrected retract; a split program keeps this across its
modules; the UDP device sends where `online --serve egm` listens; `rapid` without `--online` is still plain RAPID.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pytest

from twin.apps.export import EXPORT_FORMATS, export_path, online_format, rapid, rapid_egm, robot_format
from twin.apps.export.motion import corners
from twin.apps.export.program import CellSetup, ProgramPath, default_cell
from twin.cli import main
from twin.errors import InputError
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.robot.description import load_robot
from twin.runs.write import write_path_csv

ROBOT = "irb6640"
POSITION_TOL_MM = 0.5e-4 + 1e-9  # the program's 4 decimals
MOVES = ("MoveJ", "MoveL", "EGMMoveL")
EGM = ("EGMReset", "EGMGetId", "EGMSetupUC", "EGMActMove", "EGMMoveL", "EGMStop")
_TARGET = re.compile(r"\[\[([^\]]*)\],\[[^\]]*\],\[[^\]]*\],\[[^\]]*\]\]")
_ARRAY = re.compile(r"^\s*(LOCAL )?CONST (robtarget|speeddata) (\w+)\{(\d+)\}:=\[(.*?)\];", re.M | re.S)
_SINGLE = re.compile(r"^\s*(LOCAL )?CONST (robtarget|speeddata) (\w+):=(\[.*\]);$", re.M)
_NUM = re.compile(r"^\s*(LOCAL )?CONST num (\w+):=([\d.]+);$", re.M)
_IDENT = re.compile(r"^\s*(LOCAL )?VAR egmident (\w+);$", re.M)


@dataclass
class Module:
    """One module as the checker reads it: its data (name -> value), which of it is LOCAL, its procedures."""

    name: str
    data: dict[str, object] = field(default_factory=dict)
    local: set[str] = field(default_factory=set)
    procs: dict[str, list[str]] = field(default_factory=dict)
    handlers: dict[str, list[str]] = field(default_factory=dict)
    idents: list[tuple[str, bool]] = field(default_factory=list)


@dataclass
class Step:
    """One executed instruction: its name, arguments, the module it ran in; a move's point [mm], speed, zone."""

    kind: str
    args: list[str]
    module: str
    point: np.ndarray | None = None
    speed: float | None = None
    zone: str | None = None


def _declare(module: Module, local: str | None, name: str, value: object) -> None:
    assert name not in module.data, f"{module.name}: {name} declared twice"
    module.data[name] = value
    if local:
        module.local.add(name)


def _speed(text: str) -> float:
    return float(text.strip("[]").split(",")[0])


def parse_module(text: str) -> Module:
    """The module's structure (MODULE/ENDMODULE, PROC/ENDPROC, FOR/ENDFOR balanced and nested as RAPID nests
    them, every statement of a procedure terminated) and its data."""
    code = [line.split("!")[0].strip() for line in text.splitlines()]
    stack: list[str] = []
    name, proc = "", ""
    procs: dict[str, list[str]] = {}
    handlers: dict[str, list[str]] = {}
    for line in filter(None, code):
        head = line.split()[0]
        if head == "MODULE":
            assert not stack and not name, f"MODULE inside {stack} or a second module: {line}"
            name = line.split()[1]
            stack.append("MODULE")
            continue
        if head == "ENDMODULE":
            assert stack == ["MODULE"], f"ENDMODULE closes {stack}"
            stack.pop()
            continue
        if head == "PROC":
            found = re.fullmatch(r"PROC (\w+)\(\)", line)
            assert stack == ["MODULE"] and found and found.group(1) not in procs, f"PROC inside {stack}: {line}"
            proc = found.group(1)
            procs[proc] = []
            stack.append("PROC")
            continue
        if head == "ENDPROC":
            assert stack in (["MODULE", "PROC"], ["MODULE", "PROC", "ERROR"]), f"ENDPROC closes {stack}"
            del stack[1:]
            continue
        if head == "ERROR":
            assert stack == ["MODULE", "PROC"] and line == "ERROR", f"ERROR outside a PROC's body: {line}"
            stack.append("ERROR")
            handlers[proc] = []
            continue
        if stack[:3] == ["MODULE", "PROC", "ERROR"]:  # the handler: IF/ENDIF balanced, statements terminated
            assert line.endswith((";", " THEN")) or head == "ENDIF", f"unterminated statement in {proc}'s ERROR"
            handlers[proc].append(line)
            continue
        if head in ("FOR", "IF"):
            closing = " DO" if head == "FOR" else " THEN"
            assert stack[:2] == ["MODULE", "PROC"] and line.endswith(closing), f"{head} outside a PROC: {line}"
            stack.append(head)
        elif head in ("ENDFOR", "ENDIF"):
            assert stack[-1:] == [head[3:]], f"{head} closes {stack}"
            stack.pop()
        if stack[:2] == ["MODULE", "PROC"] or head in ("ENDFOR", "ENDIF"):
            assert line.endswith((";", " DO", " THEN")) or head in ("ENDFOR", "ENDIF"), (
                f"unterminated statement in {proc}: {line}")
            procs[proc].append(line)
    assert not stack and name, f"unbalanced module {name!r}: {stack} left open"
    module = Module(name, procs=procs, handlers=handlers)
    for local, kind, var, size, body in _ARRAY.findall(text):
        values = ([np.array([float(v) for v in row.split(",")]) for row in _TARGET.findall(body)]
                  if kind == "robtarget" else [_speed(s) for s in re.findall(r"\[[^\]]*\]", body)])
        assert len(values) == int(size), f"{name}: {var}{{{size}}} holds {len(values)} values"
        _declare(module, local, var, values)
    for local, kind, var, value in _SINGLE.findall(text):
        found = _TARGET.fullmatch(value)
        _declare(module, local, var, np.array([float(v) for v in found.group(1).split(",")])
                 if kind == "robtarget" and found else _speed(value))
    for local, var, value in _NUM.findall(text):
        _declare(module, local, var, float(value) if "." in value else int(value))
    module.idents = [(var, bool(local)) for local, var in _IDENT.findall(text)]
    return module


class Program:
    """The modules of a program and `main` run as the controller runs it (calls and FOR loops expanded)."""

    def __init__(self, files: dict[str, str]) -> None:
        mods = sorted(name for name in files if name.endswith(".mod"))  # NAME.mod before NAME_1.mod
        pgf = [name for name in files if name.endswith(".pgf")]
        if pgf:  # the program file lists exactly the modules, the main one first
            root = ET.fromstring(files[pgf[0]].split("?>", 1)[1])
            listed = [m.text or "" for m in root]
            assert root.tag == "Program" and {m.tag for m in root} == {"Module"} and sorted(listed) == mods
            assert pgf == [listed[0][:-4] + ".pgf"], pgf
            mods = listed
        self.modules = [parse_module(files[name]) for name in mods]
        assert [f"{m.name}.mod" for m in self.modules] == mods, "a module not in the file named as it"
        owners = [(m, p) for m in self.modules for p in m.procs]
        names = [p.lower() for _, p in owners]  # RAPID's names are case-insensitive
        assert len(set(names)) == len(names), "a procedure name used twice"
        assert "main" not in names, "a main beside the task's own main module"
        assert not set(names) & {m.name.lower() for m in self.modules}, "a procedure named as a module"
        self.procs = {p: m for m, p in owners}
        self.main = self.modules[0]
        self.entry = f"isf_{self.main.name}"
        self.steps: list[Step] = []
        self.skipped: list[list[str]] = []
        self._run(self.main, self.main.procs[self.entry], {})

    def value(self, module: Module, name: str) -> object:
        """A name as `module` sees it: its own data, else another module's global data (never its LOCAL data)."""
        if name in module.data:
            return module.data[name]
        seen = [m.data[name] for m in self.modules if name in m.data and name not in m.local]
        assert seen, f"{module.name} uses {name}, which no module gives it"
        return seen[0]

    def _int(self, module: Module, expr: str, env: dict[str, int]) -> int:
        text = re.sub(r"[A-Za-z_]\w*", lambda m: str(env[m.group()] if m.group() in env
                                                       else self.value(module, m.group())), expr)
        assert re.fullmatch(r"[\d\s+-]+", text), expr
        return int(eval(text))  # digits, + and - only

    def _ref(self, module: Module, arg: str, env: dict[str, int]) -> object:
        found = re.fullmatch(r"(\w+)\{(.+)\}", arg)
        if found is None:
            return self.value(module, arg)
        array = self.value(module, found.group(1))
        k = self._int(module, found.group(2), env)
        assert isinstance(array, list) and 1 <= k <= len(array), f"{arg} = {found.group(1)}{{{k}}} out of range"
        return array[k - 1]

    def _run(self, module: Module, body: list[str], env: dict[str, int]) -> None:
        i = 0
        while i < len(body):
            line = body[i]
            if line.startswith("IF "):  # a check that ends the program when it fails: the normal run skips it
                end = body.index("ENDIF", i)
                self.skipped.append(body[i:end + 1])
                i = end + 1
                continue
            loop = re.fullmatch(r"FOR (\w+) FROM (.+) TO (.+) DO", line)
            if loop:
                depth, end = 1, i + 1
                while depth:
                    depth += body[end].startswith("FOR ") - (body[end] == "ENDFOR")
                    end += 1
                var, start, stop = loop.group(1), self._int(module, loop.group(2), env), self._int(
                    module, loop.group(3), env)
                for k in range(start, stop + 1):
                    self._run(module, body[i + 1:end - 1], {**env, var: k})
                i = end
                continue
            found = re.fullmatch(r"(\w+)\s*(.*);", line)
            assert found, f"not an instruction: {line}"
            kind, rest = found.groups()
            if kind in self.procs and not rest:
                self._run(self.procs[kind], self.procs[kind].procs[kind], {})
            else:
                args = [a.strip() for a in rest.split(",")] if rest else []
                step = Step(kind, args, module.name)
                if kind in MOVES:
                    target, speed, zone = args[1:4] if kind == "EGMMoveL" else args[0:3]
                    step.point = np.asarray(self._ref(module, target, env))
                    step.speed = float(speed[1:]) if re.fullmatch(r"v\d+", speed) else float(
                        self._ref(module, speed, env))  # type: ignore[arg-type]
                    step.zone = zone
                self.steps.append(step)
            i += 1

    def kinds(self, *names: str) -> list[int]:
        """Indices of the steps of these kinds."""
        return [i for i, s in enumerate(self.steps) if s.kind in names]


def check_egm_program(files: dict[str, str], path: ProgramPath) -> Program:
    """The rules of an EGM path-correction program (module docstring); returns the program run."""
    program = Program(files)
    idents = [(m.name, var, local) for m in program.modules for var, local in m.idents]
    assert idents == [(program.main.name, idents[0][1], False)], f"one global egmident in the main module: {idents}"
    egm_id = idents[0][1]
    for step in program.steps:
        if step.kind.startswith("EGM"):
            ident = step.args[1] if step.kind == "EGMSetupUC" else step.args[0]  # after the mechanical unit
            assert step.kind in EGM and ident == egm_id, f"{step.kind} {step.args}: expected on {egm_id}"
    (get,), (setup,), (act,), (stop,) = (program.kinds(k) for k in ("EGMGetId", "EGMSetupUC", "EGMActMove",
                                                                      "EGMStop"))
    corrected = program.kinds("EGMMoveL")
    (approach,), (retract,) = program.kinds("MoveJ"), program.kinds("MoveL")
    assert approach < get < setup < act < corrected[0] <= corrected[-1] < stop < retract
    rate = re.fullmatch(r"tIsf\.tframe\\SampleRate:=(\d+)", program.steps[act].args[1])
    assert rate and int(rate.group(1)) % 24 == 0 and int(rate.group(1)) > 0  # path correction: multiples of 24 ms
    options = program.steps[setup].args[-1]
    assert "\\PathCorr" in options and re.search(r"\\CommTimeout:=\d", options)
    assert program.steps[setup].args[0] == "ROB_1"
    main_body = program.main.procs[program.entry]
    check = next(i for i, line in enumerate(main_body) if line.startswith("IF EGMGetState("))
    assert main_body.index(next(x for x in main_body if x.startswith("EGMSetupUC"))) < check < main_body.index(
        next(x for x in main_body if x.startswith("EGMActMove")))
    assert f"EGMGetState({egm_id}) <> EGM_STATE_CONNECTED THEN" in main_body[check]
    assert "EXIT;" in main_body[check:main_body.index("ENDIF", check)]  # stopped before the plunge
    handler = program.main.handlers[program.entry]  # a lost PC: stop, end EGM, lift out of the sheet, end
    assert handler[0] == "IF ERRNO = ERR_UDPUC_COMM THEN" and handler[-1] == "RAISE;"
    kinds = [line.split()[0].rstrip(";") for line in handler]
    assert kinds.index("StopMove") < kinds.index("ClearPath") < kinds.index("EGMReset") < kinds.index(
        "MoveL") < kinds.index("EXIT")
    lift = next(line for line in handler if line.startswith("MoveL "))
    assert lift.startswith("MoveL Offs(CRobT(\\Tool:=tIsf\\WObj:=wSheet),0,0,nLift),")
    n_lift = program.value(program.main, "nLift")
    assert isinstance(n_lift, int | float) and n_lift >= path.points_mm[-1, 2] - path.points_mm[1:-1, 2].min() - 1e-3
    moves = [program.steps[i] for i in program.kinds(*MOVES)]
    n = len(path.points_mm)
    assert [s.kind for s in moves] == ["MoveJ"] + ["EGMMoveL"] * (n - 2) + ["MoveL"]
    np.testing.assert_allclose([s.point for s in moves], path.points_mm, atol=POSITION_TOL_MM)
    np.testing.assert_allclose([s.speed for s in moves[1:]], path.feed_mm_s[1:], atol=0.5e-3 + 1e-9)
    stop = corners(path.points_mm)[1:-1]
    stop[-1] = True  # the offline program's corners (the plunge among them) and the end at rest
    assert stop[0] and [s.zone for s in moves[1:-1]] == ["fine" if k else "z0" for k in stop]
    assert moves[-1].zone == "fine"
    return program


@pytest.fixture(scope="module")
def path_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2-pass groove, 279 points."""
    return write_path_csv(groove_path(GrooveSpec(passes=2, bottom_length_m=0.066)),
                          tmp_path_factory.mktemp("egm") / "short.csv")


@pytest.fixture(scope="module")
def cell() -> CellSetup:
    """The IRB 6640's cell (sheet and tool from its scene)."""
    return default_cell(robot=ROBOT)


def _export(path_csv: Path, out: Path, cell: CellSetup, max_points: int = 0) -> tuple[ProgramPath, dict[str, str]]:
    """The EGM program written for the path: the program exported and its files' texts by name."""
    exported = export_path(path_csv, "rapid-egm", out, cell=cell, max_points=max_points)
    return exported.path, {f.name: f.read_text() for f in exported.files}


def test_egm_corrects_every_point_of_the_path_and_nothing_else(path_csv: Path, cell: CellSetup, tmp_path: Path) -> None:
    path, files = _export(path_csv, tmp_path / "ISF.mod", cell)
    assert sorted(files) == ["ISF.mod", "ISF.pgf", "ISF_egm_moc.cfg", "ISF_egm_sio.cfg"]
    assert len(path.points_mm) == 281 and path.approach
    program = check_egm_program(files, path)
    assert program.steps[0].kind == "ConfJ" and program.steps[1].kind == "ConfL"
    assert all(s.module == "ISF" for s in program.steps)
    reset, get = program.kinds("EGMReset"), program.kinds("EGMGetId")
    assert len(reset) == 1 and reset[0] < get[0]  # a fresh identity, whatever an aborted run left


def test_a_split_program_keeps_egm_in_main_and_the_corrected_moves_in_the_parts(
    path_csv: Path, cell: CellSetup, tmp_path: Path
) -> None:
    """279 path points with 100 per module: parts of 100, 100, 79 between the main module's approach and retract."""
    path, files = _export(path_csv, tmp_path / "ISF.mod", cell, max_points=100)
    assert sorted(f for f in files if f.endswith(".mod")) == ["ISF.mod", "ISF_1.mod", "ISF_2.mod", "ISF_3.mod"]
    program = check_egm_program(files, path)
    calls = [line.strip() for line in program.main.procs[program.entry] if re.fullmatch(r"isf_ISF_\d;", line.strip())]
    assert calls == ["isf_ISF_1;", "isf_ISF_2;", "isf_ISF_3;"]
    by_module = {m: [s for s in program.steps if s.module == m] for m in ("ISF", "ISF_1", "ISF_2", "ISF_3")}
    assert not any(s.kind == "EGMMoveL" for s in by_module["ISF"])
    for k, part in enumerate(("ISF_1", "ISF_2", "ISF_3")):
        steps = by_module[part]
        assert {s.kind for s in steps} == {"EGMMoveL"}, part  # no set-up, stop or uncorrected move in a part
        assert len(steps) == [100, 100, 79][k] and (k < 2 or steps[-1].zone == "fine")
        module = next(m for m in program.modules if m.name == part)
        assert module.local == {"nPath", "pPath", "vPath"} and not module.idents


def test_the_configurations_are_the_device_and_profile_the_program_names(
    path_csv: Path, cell: CellSetup, tmp_path: Path
) -> None:
    _, files = _export(path_csv, tmp_path / "ISF.mod", cell)
    setup = next(s for s in Program(files).steps if s.kind == "EGMSetupUC")
    profile, device = (a.strip('"') for a in (setup.args[2], setup.args[3].split("\\")[0]))
    sio = files["ISF_egm_sio.cfg"].replace("\\\n", " ")
    assert sio.splitlines()[0].startswith("SIO:CFG_1.0:") and "\nCOM_TRP:\n" in sio
    assert re.search(rf'-Name "{device}" -Type "UDPUC" ', sio)
    port = re.search(r"-RemotePortNumber (\d+)", sio)
    assert port and int(port.group(1)) == rapid_egm.DEFAULT_PORT == 6510
    moc = files["ISF_egm_moc.cfg"].replace("\\\n", " ")
    assert moc.splitlines()[0].startswith("MOC:CFG_1.0:") and "\nEXT_MOTION_DATA:\n" in moc
    level = re.search(rf'-name "{profile}" -ext_motion_level (\d+)', moc)
    assert level and int(level.group(1)) == 2  # path correction
    assert "filter" not in moc  # no controller filter is claimed: the profile keeps the controller's default
    assert rapid_egm.sio_config("127.0.0.7", 7000).count('"127.0.0.7"') == 1 and "7000" in rapid_egm.sio_config(
        "127.0.0.7", 7000)


def test_export_online_for_an_abb_robot_writes_rapid_with_egm(
    path_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert online_format(load_robot(ROBOT)) == "rapid-egm" and EXPORT_FORMATS["rapid-egm"].online
    assert main(["export", str(path_csv), "--robot", ROBOT, "--online", "--egm-mode", "path", "--out",
                 str(tmp_path / "ISF.mod")]) == 0  # --online's ABB default is position guidance (#50)
    said = capsys.readouterr()
    assert "rapid-egm" in said.out and "along-path part" in said.out + said.err  # what EGM does not correct
    files = {f.name: f.read_text() for f in tmp_path.iterdir()}
    assert sorted(files) == ["ISF.mod", "ISF.pgf", "ISF_egm_moc.cfg", "ISF_egm_sio.cfg"]
    path = export_path(path_csv, "rapid", tmp_path / "plain" / "ISF.mod", cell=default_cell(robot=ROBOT)).path
    check_egm_program(files, path)
    assert online_format(load_robot("kr210")) == "krl-rsi"  # KUKA keeps RSI
    with pytest.raises(InputError, match=r"RAPID \(rapid-egm\)"):  # a language without one lists RAPID's
        online_format(replace(load_robot(ROBOT), language="KAREL"))


def test_rapid_without_online_is_still_plain_rapid_on_the_same_data(path_csv: Path, cell: CellSetup, tmp_path: Path) -> None:
    assert robot_format(load_robot(ROBOT)) == "rapid"
    plain = export_path(path_csv, "rapid", tmp_path / "ISF.mod", cell=cell)
    assert [f.name for f in plain.files] == ["ISF.mod", "ISF.pgf"]
    text = plain.files[0].read_text()
    assert "EGM" not in text and "egmident" not in text
    program = Program({"ISF.mod": text})
    n = len(plain.path.points_mm)
    assert [s.kind for s in program.steps if s.kind in MOVES] == ["MoveJ"] + ["MoveL"] * (n - 1)
    np.testing.assert_allclose([s.point for s in program.steps if s.point is not None], plain.path.points_mm,
                               atol=POSITION_TOL_MM)
    egm = rapid_egm.program_files(plain.path)["ISF.mod"]
    plain_rows = rapid.robtargets(plain.path)
    assert all(row in egm for row in plain_rows[1:-1])  # the same robtargets, configurations included


def test_a_program_without_approach_and_retract_is_refused(path_csv: Path, cell: CellSetup, tmp_path: Path) -> None:
    path, _ = _export(path_csv, tmp_path / "ISF.mod", cell)
    with pytest.raises(InputError, match=r"approach=False.*expects a program with its approach and retract"):
        rapid_egm.program_files(replace(path, approach=False))


@pytest.mark.parametrize("fmt", ["rapid", "rapid-egm"])
def test_out_without_extension_writes_the_module_named_as_the_program(path_csv: Path, cell: CellSetup, fmt: str,
                                                                       tmp_path: Path) -> None:
    """`--out ISF` writes `ISF.mod` and `ISF.pgf` (never a module file without its extension), as `--out ISF.mod`."""
    bare = {f.name for f in export_path(path_csv, fmt, tmp_path / "a" / "ISF", cell=cell).files}
    named = {f.name for f in export_path(path_csv, fmt, tmp_path / "b" / "ISF.mod", cell=cell).files}
    assert bare == named and {"ISF.mod", "ISF.pgf"} <= bare and "ISF" not in bare
    text = (tmp_path / "a" / "ISF.mod").read_text()
    assert "PROC isf_ISF()" in text and "call isf_ISF; from the task's main" in text and "PROC main()" not in text
