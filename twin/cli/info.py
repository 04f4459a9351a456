"""`tx200-twin info`: the model's joint stiffness, tool tip at home, home compliance and sheet origin (a `--cell`'s,
else the robot's default: `twin.analysis.resolve.resolve_placement`)."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from twin.base.jsonio import emit_json
from twin.cli._common import add_json_argument, add_robot_argument

HELP = "Show the model: joint stiffness K_q, tool tip and compliance at home, sheet origin."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--robot` and `--json FILE` (`-` for stdout)."""
    add_robot_argument(parser)
    add_json_argument(parser, "the numbers")


def _kinematics(args: argparse.Namespace) -> tuple[Any, Any]:
    """The robot's kinematics with a `--cell`'s tool (`twin.analysis.tool_choice`), and that tool (None: the model's)."""
    from twin.analysis.resolve import resolve_robot
    from twin.analysis.tool_choice import resolve_tool_spec
    from twin.robot.kinematics import Kinematics  # MuJoCo: only when the command runs
    from twin.robot.model import build_model

    robot = resolve_robot(args.robot)
    tool = resolve_tool_spec(robot, cell=getattr(args, "cell_record", None))
    return (Kinematics(robot=robot) if tool is None else Kinematics(build_model(robot, tool=tool.rigid), robot=robot)), \
        tool


def _bending_compliance(kin: Any, tool: Any) -> np.ndarray:
    """The tool's own bending compliance at the tip at home [m/N] (`twin.robot.tool_bending`; zeros: rigid)."""
    from twin.robot.model import build_model
    from twin.robot.tool_bending import bending_compliance_at

    if tool is None or tool.bending_stiffness_n_per_m is None:
        return np.zeros((3, 3))
    return bending_compliance_at(build_model(kin.robot, tool=tool), kin.robot, kin.q_home)


def _tool_record(kin: Any, tool: Any) -> dict[str, Any]:
    """The tool `info` shows: length [mm], mass [kg], bending stiffness at the tip [N/mm] (declared only)."""
    bending = None if tool is None else tool.bending_stiffness_n_per_m
    return {"length_mm": 1e3 * (kin.robot.tool_length_m if tool is None else tool.length_m),
            "mass_kg": None if tool is None else tool.mass_kg,
            **({} if bending is None else {"bending_stiffness_n_per_mm": bending / 1e3}),
            "from": "the robot model" if tool is None else "the cell"}


def _bends(tool: Any) -> str:
    bending = None if tool is None else tool.bending_stiffness_n_per_m
    return "" if bending is None else f", bends {bending / 1e3:.4g} N/mm at the tip"


def run(args: argparse.Namespace) -> int:
    """Print the summary (or JSON to stdout with `--json -`) and return 0."""
    from twin.analysis.resolve import resolve_placement

    kin, tool = _kinematics(args)
    path = kin.robot.model_path()
    p_home, _ = kin.fk(kin.q_home)
    # the joints' J K_q⁻¹ Jᵀ and the tool's own bending [m/N] -> [mm/kN]
    compliance_mm_per_kn = (kin.compliance(kin.q_home) + _bending_compliance(kin, tool)) * 1e6
    place = resolve_placement(cell=getattr(args, "cell_record", None), robot_name=kin.robot.name)  # a --cell's sheet
    origin = place.placement.origin_in(kin)
    payload = {
        "joint_stiffness_nm_per_rad": kin.joint_stiffness.tolist(),
        "tcp_home_m": p_home.tolist(),
        "compliance_home_mm_per_kn": compliance_mm_per_kn.tolist(),
        "sheet_origin_m": origin.tolist(),
        "sheet_yaw_deg": float(np.degrees(place.placement.yaw_rad)),
        "sheet_from": {"origin": place.origin_from, "yaw": place.yaw_from},
        "robot_sheet_origin_m": kin.p_base_sheet_origin.tolist(),
        "model": str(path),
        "robot": kin.robot.name,
        "tool": _tool_record(kin, tool),
    }
    emit_json(args.json, payload)
    if args.json == "-":
        return 0
    with np.printoptions(precision=3, suppress=True):
        print(f"model            {path}")
        print(f"K_q [N m/rad]    {' '.join(f'{k:.4g}' for k in kin.joint_stiffness)}")
        print(f"tool [mm]        {payload['tool']['length_mm']:.2f} from the flange" + ("" if tool is None or
              tool.mass_kg is None else f", {tool.mass_kg:g} kg") + _bends(tool) + f" ({payload['tool']['from']})")
        print(f"tcp at home [m]  {p_home}")
        print(f"sheet origin [m] {origin} (from {place.origin_from}), yaw {np.degrees(place.placement.yaw_rad):g} "
              f"deg (from {place.yaw_from})")
        print("compliance at home J K_q^-1 J^T (+ the tool's bending) [mm/kN]:")
        for row in compliance_mm_per_kn:
            print(f"  {row}")
    return 0
