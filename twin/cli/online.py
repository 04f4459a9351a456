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
from twin.sim.online_settings import MAX_CORRECTION_HELP, MAX_RATE_HELP

HELP = ("Serve the online compensator over a robot's real-time interface (KUKA RSI, ABB EGM, Stäubli VAL3 alter), for a bounded time; "
        "the F/T from the robot's packets or the sensor's RDT stream.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `online` options."""
    from twin.apps.tasks.online import INTERFACES

    parser.add_argument("--serve", required=True, choices=tuple(INTERFACES),
                        help="the interface: rsi (KUKA RSI, XML over UDP), egm (ABB EGM path correction, protobuf "
                             "over UDP), val3 (Stäubli VAL3 alter, binary frames over TCP)")
    parser.add_argument("--port", type=int, help="port to listen on (default: the interface's, as the exported "
                                                 "program's configuration has it: rsi 49152, egm 6510, val3 49153)")
    parser.add_argument("--ft-rdt", metavar="HOST[:PORT]",
                        help="read the F/T from the sensor's own stream (ATI Net F/T RDT, UDP 49152) instead of the "
                             "robot's packets")
    parser.add_argument("--ft-counts-per-n", type=finite, default=1_000_000.0,
                        help="the RDT sensor's force calibration [counts/N]")
    parser.add_argument("--ft-bias", action="store_true", help="zero the RDT sensor first (tool in the air)")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind")
    parser.add_argument("--model", type=Path, help="the compensator's twin: a model file (e.g. from `learn`)")
    parser.add_argument("--cycles", type=int, default=15000, help="most packets to answer (60 s at 4 ms)")
    parser.add_argument("--start-timeout-s", type=finite, default=60.0,
                        help="stop when no first packet was answered this long after the start [s] (the robot's "
                             "program is started after the twin; a session that answered none exits 1)")
    parser.add_argument("--idle-timeout-s", type=finite, default=5.0,
                        help="stop when no packet was answered this long after the last one [s]")
    parser.add_argument("--max-rate-mm-s", type=finite, metavar="MM_S", help=MAX_RATE_HELP)
    parser.add_argument("--max-correction-mm", type=float, metavar="MM", help=MAX_CORRECTION_HELP)
    parser.add_argument("--guidance", type=Path, metavar="FILE", help="--serve egm: stream the path of this table "
                        "(NAME_egm_pose.csv of `export --online`: EGM position guidance); without it, path correction")
    add_robot_argument(parser)
    add_placement_arguments(parser)
    add_json_argument(parser, "the session's counts and compute times")


def run(args: argparse.Namespace) -> int:
    """Serve until the bound."""
    from twin.apps.tasks.online import OnlineRequest, RdtSettings, online_task

    ft = None if args.ft_rdt is None else RdtSettings.parse(args.ft_rdt, args.ft_counts_per_n, args.ft_bias)
    request = OnlineRequest(args.serve, args.port, args.host, args.model, args.robot, placement_given(args),
                            args.cycles, args.idle_timeout_s, ft, cell=getattr(args, "cell_record", None),
                            start_timeout_s=args.start_timeout_s, max_rate_mm_s=args.max_rate_mm_s,
                            guidance=args.guidance, max_correction_mm=args.max_correction_mm)
    return finish(args, online_task(request, note), protect=(args.model, args.guidance))
