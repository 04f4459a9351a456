"""`--help` of every command shows every default and uses one metavar scheme (issue #29)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from twin.cli import build_parser

SPECIFIC = {"FILE", "DIR", "RUN", "FILE.toml", "ROBOT.toml", "PNG", "RRD", "DESIGN"}  # what a path option may show


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _written(value: object) -> set[str]:
    """Ways a default may be written in a help text."""
    if isinstance(value, list | tuple):
        return {" ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)}
    return {str(value), f"{value:g}"} if isinstance(value, float) else {str(value)}


@pytest.mark.parametrize("command", sorted(_commands()))
def test_every_option_with_a_default_shows_it_and_no_none(command: str) -> None:
    parser = _commands()[command]
    formatter = parser._get_formatter()
    for action in parser._actions:
        if action.default in (None, False, argparse.SUPPRESS) or action.nargs == 0:
            continue
        text = formatter._expand_help(action)
        assert any(w in text for w in _written(action.default)), (command, action.option_strings, text)
    assert "None" not in parser.format_help()


@pytest.mark.parametrize("command", sorted(_commands()))
def test_path_options_use_the_metavar_scheme(command: str) -> None:
    for action in _commands()[command]._actions:
        if action.type is Path or action.dest in ("json", "run_dir"):
            assert action.metavar in SPECIFIC, (command, action.option_strings, action.metavar)
        if action.dest == "run_dir" or "--run" in action.option_strings:
            assert action.metavar == "RUN"
