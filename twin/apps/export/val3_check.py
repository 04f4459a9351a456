"""A syntax check of the VAL3 we emit, written from the VAL3 reference manual's grammar for those parts.

Covered (VAL3 reference manual: "Applications", "Programs", "Data", "Movement instructions"; the `alter`, task
and socket instructions as the public VAL3 drivers write them, `twin.apps.export.val3_alter`):

- files: `.pjx` project naming its `.pgx` programs and `.dtx` data, well-formed XML in the Stäubli
  namespaces; programs `start` and `stop` present;
- data: identifiers (a letter, then letters, digits or `_`, at most 15 characters), the simple and
  structured types we use (`num`, `bool`, `frame`, `tool`, `trsf`, `mdesc`, `pointRx`, `jointRx`, `sio`), arrays
  of `size` values with keys 0..size-1, every field of the type present and numeric (a `bool` `true` or `false`, a
  `sio` a `link` to a controller socket `Socket\\name` or `UdpSocket\\name`), configurations (`shoulder`,
  `elbow`, `wrist`) from their sets, `fatherId` naming `world[0]`, `flange[0]` or an existing frame/tool element of
  the right type; locals of those types;
- code: `begin ... end`, one instruction per line, `//` comments, `for v = e to e [step e] ... endFor`,
  `while e ... endWhile`, `if e ... [else ...] endIf`, assignments, calls; expressions with numbers,
  variables, `a[i]`, fields `a.x` of the structured types, `size(a)`, `abs`, `sqrt`, `herej()`, `sioGet`, `sioSet`,
  `fromBinary`, + - * /, comparisons and parentheses; every name declared (data or local);
  `movel`/`alterMovel(point, tool, mdesc)` with a point (`pointRx`), a tool and a motion descriptor, `movej` the
  same or with axis values (`jointRx`: a home) for its point, `waitEndMove()`, `alterEnd()` without arguments,
  `alterBegin(frame, mdesc)`, `alter(trsf)`, `delay(e)`, `clearBuffer(sio)`, `sioCtrl(sio, "parameter", e)`,
  `toBinary(num, e, "format", num)` with a format of the frames we write, and `taskCreateSync "name", e, bool,
  program()` naming a program of the application other than the one it is in. A string literal is taken only where
  one of these takes it. Keywords are case-sensitive.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping

from twin.apps.export.val3_data_check import FIELDS, IDENT, check_data, local_name, val3_error
from twin.errors import InputError

TOKEN = re.compile(
    r'\s*(?:(\d+\.\d*|\.\d+|\d+)|([A-Za-z_][A-Za-z0-9_]*)|("[^"]*")|(<=|>=|!=|==|[-+*/()\[\],=<>.]))'
)
STRING = re.compile(r'"[^"]*"')
#: What a call's argument is: a variable (element, field) of a type or of one of the types joined by `|`, "expr"
#: (any expression), "any" (any variable), "string" (a string literal), "format" (the `fromBinary`/`toBinary`
#: formats of our frames).
_MOVE = ("pointRx", "tool", "mdesc")
#: Instructions (statements) -> their arguments.
PROCEDURES: dict[str, tuple[str, ...]] = {
    "movej": ("pointRx|jointRx", "tool", "mdesc"), "movel": _MOVE, "alterMovel": _MOVE,
    "waitEndMove": (), "resetMotion": (), "stopMove": (), "restartMove": (),
    "alterBegin": ("frame", "mdesc"), "alterEnd": (), "alter": ("trsf",),
    "delay": ("expr",), "clearBuffer": ("sio",), "sioCtrl": ("sio", "string", "expr"),
    "toBinary": ("num", "expr", "format", "num"), "taskKill": ("string",),
}
#: Functions (in expressions) -> their arguments.
FUNCTIONS: dict[str, tuple[str, ...]] = {
    "size": ("any",), "abs": ("expr",), "sqrt": ("expr",), "herej": (),
    "sioGet": ("sio", "num"), "sioSet": ("sio", "num"), "fromBinary": ("num", "expr", "format", "num"),
}
#: `fromBinary`/`toBinary` formats: int32 and float32, little-endian (`twin.apps.online.alter_protocol`).
BINARY_FORMATS = ('"-4l"', '"4.0l"')


class _Code:
    """Recursive-descent parser of the program subset; raises on the first error with its line."""

    def __init__(self, program: str, code: str, names: Mapping[str, tuple[str, int]],
                 programs: frozenset[str] = frozenset()) -> None:
        self.program, self.names, self.programs = program, names, programs
        self.lines = [(n, line.split("//", 1)[0].strip()) for n, line in enumerate(code.splitlines(), 1)]
        self.lines = [(n, line) for n, line in self.lines if line]
        self.pos = 0

    def error(self, line: int, message: str) -> InputError:
        return val3_error(f"program {self.program}, line {line}", message)

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
        elif head == "taskCreateSync":
            self.task(number, tokens)
        elif head in PROCEDURES:
            self.call(number, tokens, PROCEDURES[head])
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

    def task(self, number: int, tokens: list[str]) -> None:
        """`taskCreateSync "name", period, bOverrun, program()`: a program of the application, not this one."""
        args = self.split_args(tokens[1:])
        if len(args) != 4 or len(args[0]) != 1 or not STRING.fullmatch(args[0][0]):
            raise self.error(number, 'expected taskCreateSync "<name>", <period>, <bool variable>, <program>()')
        self.expression(number, args[1])
        if self.operand(number, args[2]) != "bool":
            raise self.error(number, f"taskCreateSync: {' '.join(args[2])!r} is not a bool (the overrun flag)")
        if args[3][1:] != ["(", ")"] or args[3][0] not in self.programs or args[3][0] == self.program:
            raise self.error(number, f"taskCreateSync: {' '.join(args[3])!r} is not another program of the "
                             f"application called without arguments ({sorted(self.programs)})")

    def call(self, number: int, tokens: list[str], want: tuple[str, ...]) -> None:
        name = tokens[0]
        if tokens[1:2] != ["("] or tokens[-1] != ")":
            raise self.error(number, f"{name} needs (arguments)")
        self.arguments(number, name, self.split_args(tokens[2:-1]), want)

    def arguments(self, number: int, name: str, args: list[list[str]], want: tuple[str, ...]) -> None:
        """Check a call's arguments against what it takes (`PROCEDURES`, `FUNCTIONS`)."""
        if len(args) != len(want):
            raise self.error(number, f"{name} takes {len(want)} argument(s), got {len(args)}")
        for arg, kind in zip(args, want, strict=True):
            text = " ".join(arg)
            if kind in ("string", "format"):
                if len(arg) != 1 or not STRING.fullmatch(arg[0]):
                    raise self.error(number, f"{name}: argument {text!r} is not a string literal")
                if kind == "format" and arg[0] not in BINARY_FORMATS:
                    raise self.error(number, f"{name}: format {text} is not one of {', '.join(BINARY_FORMATS)}")
            elif kind == "expr":
                self.expression(number, arg)
            elif kind == "any":
                self.operand(number, arg)
            elif self.operand(number, arg) not in kind.split("|"):
                raise self.error(number, f"{name}: argument {text!r} is not a {' or '.join(kind.split('|'))}")

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
        """A variable, an array element or a field of either; returns its type (a field's: num)."""
        field = None
        if len(tokens) > 2 and tokens[-2] == ".":
            tokens, field = tokens[:-2], tokens[-1]
        if not tokens or tokens[0] not in self.names:
            raise self.error(number, f"{' '.join(tokens)!r} is not a declared variable")
        if len(tokens) > 1:
            if tokens[1] != "[" or tokens[-1] != "]":
                raise self.error(number, f"expected {tokens[0]}[index]")
            self.expression(number, tokens[2:-1])
        kind = self.names[tokens[0]][0]
        if field is None:
            return kind
        if field not in FIELDS.get(kind, ()):
            raise self.error(number, f"{tokens[0]} ({kind}) has no field {field!r}")
        return "num"

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

    @staticmethod
    def closing(tokens: list[str], start: int) -> int:
        """The index of the bracket that closes the one at `start`, or -1."""
        depth = 0
        for k in range(start, len(tokens)):
            depth += tokens[k] in ("(", "[")
            depth -= tokens[k] in (")", "]")
            if depth == 0:
                return k
        return -1

    def factor(self, number: int, tokens: list[str]) -> list[str]:
        if not tokens:
            raise self.error(number, "expression ends too early")
        head, rest = tokens[0], tokens[1:]
        if re.fullmatch(r"\d+\.?\d*|\.\d+", head) or head in ("true", "false"):
            return rest
        if head == "-":
            return self.factor(number, rest)
        if head == "(" or head in FUNCTIONS:
            start = 0 if head == "(" else 1
            k = self.closing(tokens, start) if tokens[start:start + 1] == ["("] else -1
            if k < 0 or tokens[k] != ")":
                raise self.error(number, f"unbalanced brackets in {' '.join(tokens)!r}")
            inner = self.split_args(tokens[start + 1 : k])
            if head == "(":
                if len(inner) != 1:
                    raise self.error(number, f"expected one expression in {' '.join(tokens[: k + 1])!r}")
                self.expression(number, inner[0])
            else:
                self.arguments(number, head, inner, FUNCTIONS[head])
            return tokens[k + 1 :]
        if head in self.names:
            end = 1
            if rest[:1] == ["["]:
                end = self.closing(tokens, 1) + 1
                if end == 0 or tokens[end - 1] != "]":
                    raise self.error(number, f"unbalanced brackets in {' '.join(tokens)!r}")
            if tokens[end : end + 1] == ["."]:
                end += 2
            self.operand(number, tokens[:end])
            return tokens[end:]
        raise self.error(number, f"unexpected {head!r} in an expression")


def check_application(files: Mapping[str, str]) -> None:
    """Check a VAL3 application given as file name -> text; raises InputError naming file, line and rule."""
    pjx = [name for name in files if name.endswith(".pjx")]
    if len(pjx) != 1:
        raise val3_error("application", f"expected one .pjx project file, got {pjx}")
    project = ET.fromstring(files[pjx[0]])
    if local_name(project.tag) != "Project":
        raise val3_error(pjx[0], f"root element is {project.tag}, expected Project")
    refs = [e.get("file", "") for e in project.iter() if local_name(e.tag) in ("Program", "Data")]
    missing = [ref for ref in refs if ref not in files]
    if missing:
        raise val3_error(pjx[0], f"names files that are not in the application: {missing}")
    names: dict[str, tuple[str, int]] = {}
    for ref in refs:
        if ref.endswith(".dtx"):
            names |= check_data(ref, files[ref])
    programs = {
        ref: [e for e in ET.fromstring(files[ref]).iter() if local_name(e.tag) == "Program"]
        for ref in refs
        if ref.endswith(".pgx")
    }
    listed = [p.get("name", "") for found in programs.values() for p in found]
    twice = sorted({n for n in listed if listed.count(n) > 1})
    if twice:
        raise val3_error("application", f"programs {twice} are defined more than once; expected one of each name")
    program_names = frozenset(listed)
    for ref, found in programs.items():
        for program in found:
            pname = program.get("name", "")
            if not IDENT.match(pname):
                raise val3_error(ref, f"program name {pname!r} is not an identifier")
            local: dict[str, tuple[str, int]] = {}
            for e in program.iter():
                if local_name(e.tag) not in ("Local", "Parameter"):
                    continue
                kind = e.get("type", "")
                if kind not in FIELDS:
                    raise val3_error(ref, f"program {pname}: local {e.get('name')!r} of type {kind!r}, expected one "
                                f"of {sorted(FIELDS)}")
                local[e.get("name", "")] = (kind, int(e.get("size", "1")))
            code = next((e.text or "" for e in program.iter() if local_name(e.tag) == "Code"), "")
            _Code(pname, code, {**names, **local}, program_names).parse()
    if not {"start", "stop"} <= program_names:
        raise val3_error("application", f"programs {sorted(program_names)}; an application needs start and stop")
