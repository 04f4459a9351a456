"""What tests ask of the CLI in this process: a refusal (exit 2) that names the problem, never a traceback; or a
run that succeeds, and what it printed."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

from twin.cli import main

#: A four-sample path CSV, the least a command that reads a path takes.
TINY = "t_s,x_mm,y_mm,z_mm\n0,0,0,0\n0.1,1,0,-0.1\n0.2,2,0,-0.2\n0.3,3,0,-0.3\n"


def refused(argv: list[str], capsys: pytest.CaptureFixture[str], *needles: str, never: tuple[Path, ...] = ()) -> str:
    """Run the CLI: exit 2, every needle in stderr, no traceback, none of `never` written; stderr."""
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in err, (needle, err)
    for path in never:
        assert not path.exists(), path
    return err


def cli_out(args: list[str]) -> str:
    """`tx200-twin ARGS` run in this process; asserts it exits 0 and returns what it printed."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(args)
    assert code == 0, (args, out.getvalue()[-2000:])
    return out.getvalue()
