"""`tx200-twin robots`: the shipped robots (and a description file of your own), with the source of every number."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import emit_json
from twin.errors import TwinError
from twin.robot.description import RobotDescription, load_robot, shipped_robots
from twin.robot.kinematics import Kinematics

#: The common task point of the compliance comparison [mm, base frame]: in front of every shipped robot, at table
#: height, tool down.
TASK_POINT_MM = (1600.0, 0.0, 500.0)

HELP = "List the robots: name, vendor, language, reach, payload, tool, joint stiffness and where each number comes from."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the `robots` options."""
    parser.add_argument("--file", type=Path, metavar="ROBOT.toml", help="also list a robot description of your own")
    parser.add_argument(
        "--task-point-mm", type=float, nargs=3, default=TASK_POINT_MM, metavar=("X", "Y", "Z"),
        help="the common task point, tool down, where each robot's Cartesian compliance is compared [mm, base "
        f"frame] (default {' '.join(f'{v:g}' for v in TASK_POINT_MM)})",
    )
    parser.add_argument("--json", help="write the robots to FILE ('-' for stdout)")


def compliance_at(robot: RobotDescription, p_base_m: np.ndarray, steps: int = 40) -> np.ndarray:
    """The robot's Cartesian compliance J K_q^-1 J^T at a tool-tip point, tool down [mm/kN] (3, 3): the IK walks
    there in a straight line from the home tool tip, so it stays on home's branch.

    Raises:
        UnreachableError, SingularityError: The point (or the way to it) is out of reach or near-singular.
    """
    kin = Kinematics(robot=robot)
    start, _ = kin.fk(kin.q_home)
    q = kin.q_home
    for s in np.linspace(0.0, 1.0, steps + 1)[1:]:
        q = kin.ik(start + s * (np.asarray(p_base_m) - start), q_seed=q)
    return 1e6 * kin.compliance(q)


def record(robot: RobotDescription, task_point_mm: Any = TASK_POINT_MM) -> dict[str, Any]:
    """One robot as the listing shows it (lengths [mm], angles [deg], stiffness [N·m/rad], compliance [mm/kN])."""
    sheet = robot.datasheet
    try:
        compliance: Any = compliance_at(robot, 1e-3 * np.asarray(task_point_mm, dtype=float)).round(4).tolist()
    except TwinError as exc:
        compliance = f"not reached: {exc}"
    kin = Kinematics(robot=robot)
    return {
        "name": robot.name,
        "vendor": robot.vendor,
        "model": robot.model,
        "controller": robot.controller,
        "language": robot.language,
        "description": str(robot.source),
        "reach_mm": None if sheet is None else 1e3 * sheet.reach_m,
        "payload_kg": None if sheet is None else sheet.payload_kg,
        "joint_speed_deg_s": None if sheet is None or sheet.joint_speed_rad_s is None
        else np.degrees(sheet.joint_speed_rad_s).round(3).tolist(),
        "datasheet_source": None if sheet is None else sheet.source,
        "joint_range_deg": [[round(float(np.degrees(lo)), 3), round(float(np.degrees(hi)), 3)]
                            for lo, hi in zip(robot.q_min_rad, robot.q_max_rad, strict=True)],
        "tool_length_mm": round(1e3 * robot.tool_length_m, 6),
        "kinematics_source": None if robot.dh is None else robot.dh.source,
        "stiffness_priors": [{"joint": p.joint, "k_nm_per_rad": p.k_nm_per_rad, "source": p.source}
                             for p in robot.stiffness_priors],
        "joint_stiffness_nm_per_rad": kin.joint_stiffness.tolist(),
        "compliance_home_mm_per_kn": (1e6 * kin.compliance(kin.q_home)).round(4).tolist(),
        "task_point_mm": [float(v) for v in task_point_mm],
        "compliance_task_point_mm_per_kn": compliance,
    }


def run(args: argparse.Namespace) -> int:
    """List the robots."""
    robots = [load_robot(name) for name in sorted(shipped_robots())]
    if args.file is not None:
        robots.append(load_robot(args.file))
    out = sys.stderr if args.json == "-" else sys.stdout  # keep stdout pure JSON for `--json -`
    records = [record(robot, args.task_point_mm) for robot in robots]
    for r in records:
        reach = "?" if r["reach_mm"] is None else f"{r['reach_mm']:.0f} mm"
        payload = "?" if r["payload_kg"] is None else f"{r['payload_kg']:g} kg"
        print(f"{r['name']}: {r['vendor']} {r['model']} ({r['controller']}, {r['language']}), reach {reach}, "
              f"payload {payload}, tool {r['tool_length_mm']:.2f} mm [{r['description']}]", file=out)
        print(f"  datasheet: {r['datasheet_source'] or 'none given'}", file=out)
        print(f"  kinematics: {r['kinematics_source'] or 'the MJCF only'}", file=out)
        for prior, k in zip(r["stiffness_priors"], r["joint_stiffness_nm_per_rad"], strict=False):
            print(f"  K_q {prior['joint']}: model {k:.3g}, prior {prior['k_nm_per_rad']:.3g} N·m/rad "
                  f"({prior['source']})", file=out)
        c = r["compliance_task_point_mm_per_kn"]
        diag = c if isinstance(c, str) else " ".join(f"{c[i][i]:.3f}" for i in range(3))
        print(f"  compliance at ({' '.join(f'{v:g}' for v in r['task_point_mm'])}) mm, tool down, diagonal x y z "
              f"[mm/kN]: {diag}", file=out)
    emit_json(args.json, {"robots": records}, protect=[] if args.file is None else [args.file])
    return 0
