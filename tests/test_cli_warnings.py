"""A command that meets a warning of another kind (numpy's empty-input one, say) ends, and shows it once."""

from __future__ import annotations

import threading
import warnings
from argparse import ArgumentParser, Namespace
from collections.abc import Callable

import pytest

import twin.cli
from twin.cli import main


def _parser_running(run: Callable[[Namespace], int]) -> Callable[[], ArgumentParser]:
    """The CLI's parser, whose parsed arguments run `run` instead of their command."""
    build = twin.cli.build_parser

    def parser() -> ArgumentParser:
        built = build()
        parse = built.parse_args

        def parse_args(argv=None):  # type: ignore[no-untyped-def]
            args = parse(argv)
            args._run = run
            return args

        built.parse_args = parse_args  # type: ignore[method-assign]
        return built

    return parser


def test_a_command_with_another_warning_ends_and_shows_it(monkeypatch: pytest.MonkeyPatch) -> None:
    def warn_then_end(args: Namespace) -> int:
        warnings.warn("input contained no data", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(twin.cli, "build_parser", _parser_running(warn_then_end))
    result: list[int] = []
    with warnings.catch_warnings(record=True) as shown:  # where the command shows it, once its own recording ended
        warnings.simplefilter("always")
        worker = threading.Thread(target=lambda: result.append(main(["info"])), daemon=True)
        worker.start()
        worker.join(timeout=30.0)
    assert not worker.is_alive(), "the command never ended"
    assert result == [0]
    assert [str(w.message) for w in shown] == ["input contained no data"]
