"""The result every task returns: what it prints, what its `--json` writes, and how the command exits."""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import Any

Note = Callable[[str], None]
"""Where a task says something while it runs (progress, a choice the user may not expect); the CLI: stderr."""


def silent(text: str) -> None:
    """A `Note` that says nothing (a task's default when called from Python)."""


class Report(abc.ABC):
    """A task's result.

    Subclasses are frozen dataclasses or NamedTuples holding the numbers; `lines` words them for a person,
    `record` for a machine (the document of `--json`, SI or `_mm`/`_n` keys as the command documents).
    """

    @abc.abstractmethod
    def lines(self) -> list[str]:
        """The human summary, one string per printed line."""

    @abc.abstractmethod
    def record(self) -> dict[str, Any]:
        """The JSON document (`--json`)."""

    @property
    def exit_code(self) -> int:
        """0: done; 1: done, and the result failed the check it reports (the CLI's exit code)."""
        return 0

