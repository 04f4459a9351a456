"""`tx200-twin online`: the twin's online compensator behind a robot's real-time interface
(`twin.apps.tasks.online`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from twin.cli._common import (
    add_json_argument,
    add_placement_arguments,
    add_robot_argument,
    finish,
    note,
    placement_given,
)
from twin.cli._types import finite

HELP = "Serve the online compensator over a robot's real-time interface (KUKA RSI on UDP), for a bounded time."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `online` options."""
    parser.add_argument("--serve", required=True, choices=("rsi",), help="the interface: KUKA RSI (XML over UDP)")
    parser.add_argument("--port", type=int, default=49152, help="UDP port to listen on")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind")
    parser.add_argument("--model", type=Path, help="the compensator's twin: a model file (e.g. from `learn`)")
    parser.add_argument("--cycles", type=int, default=15000, help="most packets to answer (60 s at 4 ms)")
    parser.add_argument("--idle-timeout-s", type=finite, default=5.0, help="stop when no packet came this long [s]")
    add_robot_argument(parser)
    add_placement_arguments(parser)
    add_json_argument(parser, "the session's counts and compute times")


def run(args: argparse.Namespace) -> int:
    """Serve until the bound."""
    from twin.apps.tasks.online import OnlineRequest, online_task

    request = OnlineRequest(args.serve, args.port, args.host, args.model, args.robot, placement_given(args),
                            args.cycles, args.idle_timeout_s)
    return finish(args, online_task(request, note), protect=(args.model,))
