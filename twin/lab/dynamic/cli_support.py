"""The `tx200-twin lab --plant dynamic` command body: run a scenario, write it, print and emit a summary."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import Any, TextIO

import numpy as np

from twin.base.csvio import write_table
from twin.base.jsonio import emit_json
from twin.base.signals import interp_rows
from twin.lab.dynamic.knobs import Knobs, parse_set_args
from twin.lab.dynamic.run import dynamic_load_test, run_dynamic_lab
from twin.process.description import Process
from twin.process.toolpath.placement import Placement
from twin.robot.description import RobotDescription
from twin.runs.format import Run
from twin.runs.read import lab_commanded
from twin.runs.write import write_run


def _run_load_test(
    args: argparse.Namespace, loads_n: np.ndarray, knobs: Knobs, out: TextIO, robot: RobotDescription | None = None
) -> int:
    """Hold each load at home on the dynamic plant, write the deflections [mm] to `args.out`, report it.

    Args:
        args: Parsed `lab` options (`seed`, `out`, `json`).
        loads_n: Load cases, base frame [N], shape (m, 3).
        knobs: The plant's knobs.
        out: Where the one-line report goes.
        robot: The robot (None: the default robot).
        meta: Entries added to the run's meta (e.g. the command's compensation record, for `check`).

    Returns:
        The exit status (0).
    """
    loads, deflections = dynamic_load_test(loads_n, knobs=knobs, seed=args.seed, robot=robot)
    columns = {"fx_n": loads[:, 0], "fy_n": loads[:, 1], "fz_n": loads[:, 2]}
    columns |= {f"d{a}_mm": 1e3 * deflections[:, i] for i, a in enumerate("xyz")}
    formats = {name: (".1f" if name.startswith("f") else ".5f") for name in columns}
    write_table(args.out, columns, formats=formats)
    print(f"lab loadtest (dynamic plant): {len(loads)} load cases at home -> {args.out}", file=out)
    emit_json(
        args.json, {"scenario": "loadtest", "plant": "dynamic", "out": args.out, "cases": len(loads)}
    )
    return 0


def _run_summary(
    args: argparse.Namespace, knobs: Knobs, run: Run, p_cmd_sheet_m: np.ndarray, wall_s: float
) -> dict[str, Any]:
    """The summary of a dynamic run: sample counts, largest measured deviation [mm], peak force [N].

    Args:
        args: Parsed `lab` options (`scenario`, `out`, `seed`).
        knobs: The plant's knobs.
        run: The measured run, with forces.
        p_cmd_sheet_m: The commanded path at the run's commanded times, sheet frame [m], shape (n, 3).
        wall_s: Wall time of the simulation [s].
    """
    deviation = run.tracker.values - interp_rows(run.tracker.t_s, run.commanded.t_s, p_cmd_sheet_m)
    assert run.forces is not None
    return {
        "scenario": args.scenario,
        "plant": "dynamic",
        "out": args.out,
        "seed": args.seed,
        "knobs_changed_from_neutral": knobs.changed(),
        "tracker_samples": len(run.tracker.t_s),
        "force_samples": len(run.forces.t_s),
        "measured_deviation_max_mm": 1e3 * float(np.max(np.linalg.norm(deviation, axis=1))),
        "peak_force_n": float(np.max(np.linalg.norm(run.forces.values, axis=1))),
        "simulation_wall_s": wall_s,
    }


def run_dynamic_command(
    args: argparse.Namespace,
    *,
    loads_n: np.ndarray,
    process: Process | None = None,
    placement: Placement | None = None,
    robot: RobotDescription | None = None,
    meta: dict[str, Any] | None = None,
) -> int:
    """Run `args.scenario` (nominal, compensated or loadtest) on the dynamic plant.

    Args:
        args: Parsed `lab` options (`scenario`, `commanded`, `set`, `neutral`, `seed`, `out`, `overwrite`, `json`).
        loads_n: Load cases of the load test, base frame [N], shape (m, 3).
        process: The sheet, tool and force model for the commanded path (None: the thesis's, the table field).
        placement: Where the sheet lies in the cell (None: the cell's `sheet_origin`, yaw 0).
        robot: The robot (None: the default robot).
        meta: Entries added to the run's meta (e.g. the command's compensation record, for `check`).

    Returns:
        The exit status (0).
    """
    knobs = parse_set_args(args.set, neutral=args.neutral)
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    if args.scenario == "loadtest":
        return _run_load_test(args, loads_n, knobs, out, robot)
    commanded, protect = lab_commanded(args.scenario, args.commanded)
    p_cmd = commanded.values
    run, truth, log = run_dynamic_lab(
        commanded.t_s,
        p_cmd,
        scenario=args.scenario,
        knobs=knobs,
        seed=args.seed,
        progress=sys.stderr,
        process=process,
        placement=placement,
        robot=robot,
    )
    truth["force_model"] = (process or Process()).force_model
    if meta:
        run = replace(run, meta={**run.meta, **meta})
    write_run(args.out, run, truth=truth, overwrite=args.overwrite, protect=protect)
    summary = _run_summary(args, knobs, run, p_cmd, log.wall_s)
    print(
        f"lab {args.scenario} (dynamic plant, {log.t_s.size} steps in {log.wall_s:.1f} s): "
        f"{summary['tracker_samples']} tracker / {summary['force_samples']} force samples, "
        f"max |measured - commanded| {summary['measured_deviation_max_mm']:.2f} mm, "
        f"peak |F| {summary['peak_force_n']:.0f} N -> {args.out}",
        file=out,
    )
    emit_json(args.json, summary)
    return 0
