"""The programs of a G-code file: the main program and its `O<n> ... M99` subprograms, split by line before any
block is read, and the words a block is made of (`twin.process.toolpath.gcode` reads the blocks).

A subprogram is `O<n>` alone on its line, its blocks and `M99`; `M98 P<n> [L<k>]` runs it k times (1..9999, default
1). The main program is the blocks before the first `O` line, else the first `O<n>` program that does not end with
`M99`; it ends at `M2`/`M30` (only subprograms may follow).
"""

from __future__ import annotations

import re
from pathlib import Path

from twin.errors import DataFileError

#: A word: its letter and its number.
WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
#: A comment: in parentheses, or after `;`.
COMMENT = re.compile(r"\([^)]*\)|;.*$")
#: A program's first line: `O<n>` alone on its line.
PROGRAM_LINE = re.compile(r"^[Oo]\s*(\d+)$")
#: A program's lines: (1-based line number in the file, raw text).
Lines = list[tuple[int, str]]
#: Deepest nesting of `M98` subprogram calls (a Fanuc controller allows 4 levels; deeper is a recursive program).
MAX_CALL_DEPTH = 8
#: Most repetitions of one `M98 ... L<k>` call (the controllers' 4-digit limit).
MAX_REPEATS = 9999


def split_programs(text: str, source: str | Path) -> tuple[Lines, dict[int, Lines]]:
    """The main program's lines and the subprograms' (by number) of a file (the module docstring's rules).

    Raises:
        DataFileError: A program number twice, blocks after a subprogram's M99, two main programs, or none.
    """
    leading: Lines = []
    numbered: list[tuple[int, int, Lines]] = []  # (number, line of its O word, its lines)
    for lineno, raw in enumerate(text.splitlines(), start=1):
        head = PROGRAM_LINE.match(COMMENT.sub(" ", raw).strip())
        if head:
            number = int(head.group(1))
            if any(n == number for n, _, _ in numbered):
                raise DataFileError(source, f"line {lineno}: program O{number} defined twice: expected one O{number}")
            numbered.append((number, lineno, []))
        else:
            (numbered[-1][2] if numbered else leading).append((lineno, raw))
    holds_blocks = any(COMMENT.sub(" ", r).strip().lstrip("%").strip() for _, r in leading)
    main: Lines | None = leading if holds_blocks or not numbered else None
    programs: dict[int, Lines] = {}
    for number, at, lines in numbered:
        blocks = [(n, r) for n, r in lines if COMMENT.sub(" ", r).strip().lstrip("%").strip()]
        ends = [k for k, (_, r) in enumerate(blocks) if 99.0 in m_codes(r)]
        if ends:
            if ends[0] != len(blocks) - 1:
                later = blocks[ends[0] + 1][0]
                raise DataFileError(source, f"line {later}: block after the M99 that ends subprogram O{number} "
                                    f"(line {blocks[ends[0]][0]}): expected the next O<n> or the end of the file")
            programs[number] = lines
        elif main is None:
            main = lines
        else:
            raise DataFileError(source, f"line {at}: program O{number} does not end with M99 and the main program "
                                "came before it: expected subprograms (O<n> ... M99) after the main program")
    if main is None:
        raise DataFileError(source, "no main program: every program in the file ends with M99 (expected blocks "
                            "before the first O<n>, or one O<n> program ending with M30)")
    return main, programs


def m_codes(raw: str) -> set[float]:
    """The M code values of a line (0 if a value does not parse; the block reader names it later)."""
    return {float(n) for letter, n in WORD.findall(COMMENT.sub(" ", raw)) if letter.upper() == "M"}
