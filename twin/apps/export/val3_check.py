"""A syntax check of the VAL3 we emit, written from the VAL3 reference manual's grammar for those parts.

Covered (VAL3 reference manual: "Applications", "Programs", "Data", "Movement instructions"):

- files: `.pjx` project naming its `.pgx` programs and `.dtx` data, well-formed XML in the Stäubli
  namespaces; programs `start` and `stop` present;
- data: identifiers (a letter, then letters, digits or `_`, at most 15 characters), the simple and
  structured types we use (`num`, `frame`, `tool`, `mdesc`, `pointRx`), arrays of `size` values with keys
  0..size-1, every field of the type present and numeric, configurations (`shoulder`, `elbow`, `wrist`) from
  their sets, `fatherId` naming `world[0]`, `flange[0]` or an existing frame/tool element of the right type;
- code: `begin ... end`, one instruction per line, `//` comments, `for v = e to e [step e] ... endFor`,
  `while e ... endWhile`, `if e ... [else ...] endIf`, assignments, calls; expressions with numbers,
  variables, `a[i]`, `size(a)`, + - * /, comparisons and parentheses; every name declared (data or local);
  `movej`/`movel(point, tool, mdesc)` with a point (`pointRx`), a tool and a motion descriptor, and
  `waitEndMove()` without arguments. Keywords are case-sensitive.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping

from twin.errors import InputError

IDENT = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,14}$")
FIELDS = {
    "frame": ("x", "y", "z", "rx", "ry", "rz"),
    "tool": ("x", "y", "z", "rx", "ry", "rz"),
    "pointRx": ("x", "y", "z", "rx", "ry", "rz"),
    "mdesc": ("accel", "vel", "decel", "tmax", "rmax", "leave", "reach"),
    "num": ("value",),
}
CONFIG = {
    "shoulder": {"lefty", "righty", "ssame", "sfree"},
    "elbow": {"epositive", "enegative", "esame", "efree"},
    "wrist": {"wpositive", "wnegative", "wsame", "wfree"},
}
BLENDS = {"off", "joint", "Cartesian"}
TOKEN = re.compile(r"\s*(?:(\d+\.\d*|\.\d+|\d+)|([A-Za-z_][A-Za-z0-9_]*)|(<=|>=|!=|==|[-+*/()\[\],=<>]))")
MOVES = {"movej": ("pointRx", "tool", "mdesc"), "movel": ("pointRx", "tool", "mdesc")}
PROCEDURES = {"waitEndMove": 0, "resetMotion": 0, "stopMove": 0, "restartMove": 0}
FUNCTIONS = {"size": 1, "abs": 1, "sqrt": 1}


def _fail(where: str, message: str) -> InputError:
    return InputError(f"VAL3 {where}: {message}")


def _local(tag: str) -> str:
    return tag.split("}", 1)[-1]


def check_data(name: str, text: str) -> dict[str, tuple[str, int]]:
    """Check a `.dtx` file; returns data name -> (type, size)."""
    root = ET.fromstring(text)
    if _local(root.tag) != "Database" or not root.tag.startswith(
        "{http://www.staubli.com/robotics/VAL3/Data/"
    ):
        raise _fail(name, f"root element is {root.tag}, expected Database in the VAL3 Data namespace")
    declared: dict[str, tuple[str, int]] = {"world": ("frame", 1), "flange": ("tool", 1)}
    fathers: list[tuple[str, str, str]] = []
    for data in root.iter():
        if _local(data.tag) != "Data":
            continue
        dname, kind, size = data.get("name", ""), data.get("type", ""), data.get("size", "")
        if not IDENT.match(dname) or dname in declared:
            raise _fail(
                name, f"data name {dname!r} is not a new identifier (letter, then letters/digits/_, <= 15)"
            )
        if kind not in FIELDS:
            raise _fail(name, f"{dname}: type {kind!r} is not one we emit ({sorted(FIELDS)})")
        if not size.isdigit() or int(size) < 1:
            raise _fail(name, f"{dname}: size {size!r}, expected a positive integer")
        values = [v for v in data if _local(v.tag) == "Value"]
        keys = sorted(int(v.get("key", "-1")) for v in values)
        if keys != list(range(int(size))):
            raise _fail(name, f"{dname}: value keys {keys[:5]}..., expected 0..{int(size) - 1}")
        for value in values:
            where = f"{dname}[{value.get('key')}]"
            for field in FIELDS[kind]:
                try:
                    float(value.get(field, ""))
                except ValueError:
                    raise _fail(
                        name, f"{where}: field {field}={value.get(field)!r}, expected a number"
                    ) from None
            for field, allowed in CONFIG.items():
                if kind == "pointRx" and value.get(field) not in allowed:
                    raise _fail(
                        name, f"{where}: {field}={value.get(field)!r}, expected one of {sorted(allowed)}"
                    )
            if kind == "mdesc" and value.get("blend") not in BLENDS:
                raise _fail(name, f"{where}: blend={value.get('blend')!r}, expected one of {sorted(BLENDS)}")
            if kind in ("frame", "tool", "pointRx"):
                fathers.append((where, kind, value.get("fatherId", "")))
        declared[dname] = (kind, int(size))
    for where, kind, father in fathers:
        match = re.fullmatch(r"([A-Za-z][A-Za-z0-9_]*)\[(\d+)\]", father)
        want = "tool" if kind == "tool" else "frame"
        if not match or declared.get(match.group(1), ("", 0))[0] != want:
            raise _fail(name, f"{where}: fatherId {father!r} is not an element of a declared {want}")
        if int(match.group(2)) >= declared[match.group(1)][1]:
            raise _fail(name, f"{where}: fatherId {father!r} is out of range")
    return declared


class _Code:
    """Recursive-descent parser of the program subset; raises on the first error with its line."""

    def __init__(self, program: str, code: str, names: Mapping[str, tuple[str, int]]) -> None:
        self.program, self.names = program, names
        self.lines = [(n, line.split("//", 1)[0].strip()) for n, line in enumerate(code.splitlines(), 1)]
        self.lines = [(n, line) for n, line in self.lines if line]
        self.pos = 0

    def error(self, line: int, message: str) -> InputError:
        return _fail(f"program {self.program}, line {line}", message)

    def parse(self) -> None:
        if not self.lines or self.lines[0][1] != "begin":
            raise self.error(self.lines[0][0] if self.lines else 1, "a program starts with 'begin'")
        self.pos = 1
        end = self.block(("end",))
        if end != "end" or self.pos != len(self.lines):
            raise self.error(self.lines[-1][0], "a program ends with 'end' and nothing after it")

    def block(self, closers: tuple[str, ...]) -> str:
        while self.pos < len(self.lines):
            number, line = self.lines[self.pos]
            self.pos += 1
            word = line.split()[0]
            if word in closers and line == word:
                return word
            self.statement(number, line)
        raise self.error(self.lines[-1][0], f"missing {' or '.join(closers)}")

    def statement(self, number: int, line: str) -> None:
        tokens = self.tokens(number, line)
        head = tokens[0]
        if head == "for":
            rest = " ".join(tokens[1:])
            m = re.fullmatch(r"(\w+) = (.+) to (.+?)(?: step (.+))?", rest)
            if not m or self.names.get(m.group(1), ("",))[0] != "num":
                raise self.error(number, "expected 'for <num variable> = <expr> to <expr> [step <expr>]'")
            for part in m.groups()[1:]:
                if part is not None:
                    self.expression(number, part.split())
            if self.block(("endFor",)) != "endFor":
                raise self.error(number, "for without endFor")
        elif head in ("while", "if"):
            self.expression(number, tokens[1:])
            closer = "endWhile" if head == "while" else "endIf"
            ended = self.block(("else", closer) if head == "if" else (closer,))
            if ended == "else":
                self.block((closer,))
        elif head in MOVES or head in PROCEDURES:
            self.call(number, tokens)
        elif "=" in tokens:
            eq = tokens.index("=")
            self.operand(number, tokens[:eq])
            self.expression(number, tokens[eq + 1 :])
        else:
            raise self.error(number, f"{line!r} is not an instruction (keywords are case-sensitive)")

    def tokens(self, number: int, text: str) -> list[str]:
        found, pos = [], 0
        while pos < len(text):
            m = TOKEN.match(text, pos)
            if not m or m.end() == pos:
                raise self.error(number, f"unexpected character {text[pos:].strip()[:1]!r}")
            found.append(next(g for g in m.groups() if g is not None))
            pos = m.end()
            if not text[pos:].strip():
                break
        return found

    def call(self, number: int, tokens: list[str]) -> None:
        name = tokens[0]
        if tokens[1:2] != ["("] or tokens[-1] != ")":
            raise self.error(number, f"{name} needs (arguments)")
        args = self.split_args(tokens[2:-1])
        want = MOVES.get(name)
        count = len(want) if want else PROCEDURES[name]
        if len(args) != count:
            raise self.error(number, f"{name} takes {count} argument(s), got {len(args)}")
        for arg, kind in zip(args, want or (), strict=False):
            if self.operand(number, arg) != kind:
                raise self.error(number, f"{name}: argument {' '.join(arg)!r} is not a {kind}")

    @staticmethod
    def split_args(tokens: list[str]) -> list[list[str]]:
        args: list[list[str]] = [[]] if tokens else []
        depth = 0
        for token in tokens:
            depth += token in ("(", "[")
            depth -= token in (")", "]")
            if token == "," and depth == 0:
                args.append([])
            else:
                args[-1].append(token)
        return args

    def operand(self, number: int, tokens: list[str]) -> str:
        """A variable or an array element; returns its type."""
        if not tokens or tokens[0] not in self.names:
            raise self.error(number, f"{' '.join(tokens)!r} is not a declared variable")
        if len(tokens) > 1:
            if tokens[1] != "[" or tokens[-1] != "]":
                raise self.error(number, f"expected {tokens[0]}[index]")
            self.expression(number, tokens[2:-1])
        return self.names[tokens[0]][0]

    def expression(self, number: int, tokens: list[str]) -> None:
        rest = self.sum(number, tokens)
        if rest and rest[0] in ("<", ">", "<=", ">=", "==", "!="):
            rest = self.sum(number, rest[1:])
        if rest:
            raise self.error(number, f"unexpected {' '.join(rest)!r} in an expression")

    def sum(self, number: int, tokens: list[str]) -> list[str]:
        rest = self.factor(number, tokens)
        while rest and rest[0] in ("+", "-", "*", "/"):
            rest = self.factor(number, rest[1:])
        return rest

    def factor(self, number: int, tokens: list[str]) -> list[str]:
        if not tokens:
            raise self.error(number, "expression ends too early")
        head, rest = tokens[0], tokens[1:]
        if re.fullmatch(r"\d+\.?\d*|\.\d+", head) or head in ("true", "false"):
            return rest
        if head == "-":
            return self.factor(number, rest)
        if head in ("(", "[") or head in FUNCTIONS or head in self.names:
            close = ")" if head == "(" or head in FUNCTIONS else "]"
            if head in self.names and (not rest or rest[0] != "["):
                return rest
            start = 0 if head == "(" else 1
            depth, k = 0, start
            for k in range(start, len(tokens)):
                depth += tokens[k] in ("(", "[")
                depth -= tokens[k] in (")", "]")
                if depth == 0:
                    break
            if depth != 0 or tokens[k] != close:
                raise self.error(number, f"unbalanced brackets in {' '.join(tokens)!r}")
            inner = self.split_args(tokens[start + 1 : k])
            if head in FUNCTIONS and len(inner) != FUNCTIONS[head]:
                raise self.error(number, f"{head} takes {FUNCTIONS[head]} argument(s)")
            for arg in inner:
                if head == "size":
                    self.operand(number, arg)
                else:
                    self.expression(number, arg)
            return tokens[k + 1 :]
        raise self.error(number, f"unexpected {head!r} in an expression")


def check_application(files: Mapping[str, str]) -> None:
    """Check a VAL3 application given as file name -> text; raises InputError naming file, line and rule."""
    pjx = [name for name in files if name.endswith(".pjx")]
    if len(pjx) != 1:
        raise _fail("application", f"expected one .pjx project file, got {pjx}")
    project = ET.fromstring(files[pjx[0]])
    if _local(project.tag) != "Project":
        raise _fail(pjx[0], f"root element is {project.tag}, expected Project")
    refs = [e.get("file", "") for e in project.iter() if _local(e.tag) in ("Program", "Data")]
    missing = [ref for ref in refs if ref not in files]
    if missing:
        raise _fail(pjx[0], f"names files that are not in the application: {missing}")
    names: dict[str, tuple[str, int]] = {}
    for ref in refs:
        if ref.endswith(".dtx"):
            names |= check_data(ref, files[ref])
    programs: set[str] = set()
    for ref in refs:
        if not ref.endswith(".pgx"):
            continue
        root = ET.fromstring(files[ref])
        for program in (e for e in root.iter() if _local(e.tag) == "Program"):
            pname = program.get("name", "")
            if not IDENT.match(pname):
                raise _fail(ref, f"program name {pname!r} is not an identifier")
            programs.add(pname)
            local = {
                e.get("name", ""): (e.get("type", ""), int(e.get("size", "1")))
                for e in program.iter()
                if _local(e.tag) in ("Local", "Parameter")
            }
            code = next((e.text or "" for e in program.iter() if _local(e.tag) == "Code"), "")
            _Code(pname, code, {**names, **local}).parse()
    if not {"start", "stop"} <= programs:
        raise _fail("application", f"programs {sorted(programs)}; an application needs start and stop")
