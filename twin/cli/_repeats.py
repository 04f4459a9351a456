"""An option given twice: argparse keeps the last of a single-valued option in silence (`--model a.json --model
b.json` runs with b.json, `--yaw-deg 0 ... --yaw-deg 30` with 30); the CLI refuses it by name instead. Options
meant to repeat (`--effect`, `--set`: argparse's append and count actions) may; each of their names once is their
own parser's rule."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from twin.errors import InputError

#: The argparse actions an option may be given more than once for.
_REPEATABLE = (argparse._AppendAction, argparse._AppendConstAction, argparse._CountAction,
               argparse._ExtendAction, argparse._HelpAction, argparse._VersionAction)


def _action(parser: argparse.ArgumentParser, token: str) -> argparse.Action | None:
    """The option `token` (`--name` or `--name=value`, or an unambiguous prefix, as argparse takes it) names."""
    name = token.partition("=")[0]
    exact = parser._option_string_actions.get(name)
    if exact is not None:
        return exact
    found = {action for option, action in parser._option_string_actions.items()
             if option.startswith("--") and option.startswith(name)}
    return found.pop() if len(found) == 1 else None


def check_repeated_options(parser: argparse.ArgumentParser, argv: Sequence[str]) -> None:
    """Refuse a single-valued option of `parser` (a command's) given more than once in `argv` (its arguments).

    Raises:
        InputError: Naming the option and both values as typed.
    """
    seen: dict[argparse.Action, str] = {}
    for i, token in enumerate(argv):
        if token == "--":
            break
        if not token.startswith("--"):
            continue
        action = _action(parser, token)
        if action is None or isinstance(action, _REPEATABLE) or action.nargs == 0:  # a flag twice says it once
            continue
        typed = token if "=" in token or i + 1 >= len(argv) else f"{token} {argv[i + 1]}"
        if action in seen:
            raise InputError(f"{action.option_strings[-1]} given twice ({seen[action]!r} and {typed!r}): give it "
                             "once (the last would win in silence)")
        seen[action] = typed
