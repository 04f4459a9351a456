"""`tx200-twin path`: write an ideal tool path U_ID as CSV — the thesis groove (§1.2.3, Table 2.3), a cone,
pyramid or variable-wall-angle cone (`twin.process.toolpath.shapes`), or a G-code program (`twin.process.toolpath.gcode`) —
after checking that the robot reaches every sample at the given placement (`twin.process.toolpath.placement`). The declared
process (`--process`, `--material`, `--thickness-mm`, `--tool-radius-mm`) is reported, shapes the target part of
`--stl-out` (the tool's radius, the sheet's springback) and the design part of `--design-stl` (the tool's radius,
no springback) and, for a cone, pyramid or variable-wall-angle cone, gives
the predicted steady axial force of the ISF model (`twin.process.force.isf_params.steady_fz_n`, Aerens et al.'s formula;
a warning where the process or the part lies outside the formula's experiments)."""

from __future__ import annotations

import argparse
import math
import re
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.base.csvio import write_bytes
from twin.base.jsonio import emit_json
from twin.cli._common import (
    add_json_argument,
    add_placement_arguments,
    add_process_arguments,
    add_robot_argument,
    command_robot,
    placement_from,
    process_declaration,
)
from twin.cli._types import count, feed_mm_s, finite, length_mm
from twin.errors import ExtrapolationWarning, InputError
from twin.process.description import Process
from twin.process.force.aerens import validity_warnings
from twin.process.force.isf_params import params_for, steady_fz_n
from twin.process.process_file import process_record
from twin.process.toolpath.gcode import read_gcode, write_gcode
from twin.process.toolpath.groove import GrooveSpec, ToolPath, groove_path, write_path_csv
from twin.process.toolpath.placement import check_reach
from twin.process.toolpath.shapes import MODES, SHAPES, PartSpec, part_path

if TYPE_CHECKING:  # trimesh, MuJoCo and the part surfaces load only where the command uses them
    import trimesh

HELP = (
    "Write an ideal tool path (sheet frame) as CSV t_s, x_mm, y_mm, z_mm, pass, direction: the groove, a cone, "
    "pyramid, variable-wall-angle cone, or an imported G-code program; checks reach along the whole path."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the command's options."""
    d = GrooveSpec()
    p = PartSpec()
    parser.add_argument("--out", type=Path, required=True, help="output CSV file")
    parser.add_argument("--shape", choices=("groove", *SHAPES), default="groove", help="part (default groove)")
    parser.add_argument("--gcode", type=Path, metavar="FILE", help="import this G-code program instead of --shape")
    parser.add_argument("--gcode-out", type=Path, metavar="FILE", help="also write the path as G-code (G1, mm)")
    parser.add_argument(
        "--stl-out",
        type=Path,
        metavar="FILE",
        help="also write the target part as a binary STL [mm]: the surface a rigid machine forms along the path "
        "(height-map ISF model, after elastic recovery), for `check --target-stl`",
    )
    parser.add_argument(
        "--design-stl",
        type=Path,
        metavar="FILE",
        help="also write the design part as a binary STL [mm]: the sheet's tool-side surface a rigid machine forms "
        "with no springback (the tool sphere's envelope, the bottom lowered), for `check --target-stl --scan`",
    )
    parser.add_argument("--depth-mm", type=length_mm, help="final depth H (default: groove 10, other parts 40)")
    parser.add_argument("--feed-mm-s", type=feed_mm_s, default=d.feed_m_per_s * 1e3, help="constant feed [mm/s]")
    parser.add_argument(
        "--spacing-mm", type=length_mm, default=d.spacing_m * 1e3, help="largest sample spacing (G-code: the chords of arcs and the pieces of lines)"
    )
    groove = parser.add_argument_group("groove")
    groove.add_argument("--passes", type=count, default=d.passes, help=f"number of passes N (default {d.passes})")
    groove.add_argument(
        "--top-length-mm", type=length_mm, default=d.top_length_m * 1e3, help="groove length L at the surface"
    )
    groove.add_argument(
        "--bottom-length-mm", type=length_mm, default=d.bottom_length_m * 1e3, help="groove length B at full depth"
    )
    part = parser.add_argument_group("cone, pyramid, vwa-cone")
    part.add_argument("--mode", choices=MODES, default=p.mode, help="descent (default spiral)")
    part.add_argument(
        "--top-width-mm",
        type=length_mm,
        default=2e3 * p.top_half_width_m,
        help="tool-tip contour at the surface: cone diameter or pyramid side (default 120)",
    )
    part.add_argument("--wall-angle-deg", type=finite, default=p.wall_angle_deg, help="wall angle (vwa-cone: top)")
    part.add_argument(
        "--wall-angle-end-deg", type=finite, default=p.wall_angle_end_deg, help="vwa-cone: wall angle at the bottom"
    )
    part.add_argument("--step-down-mm", type=length_mm, default=p.step_down_m * 1e3, help="largest step-down")
    add_process_arguments(parser)
    place = add_placement_arguments(parser, "placement and reach check")
    add_robot_argument(place)
    place.add_argument("--no-reach-check", action="store_true", help="skip the IK check along the path")
    add_json_argument(parser, "the summary")


# the spec fields the path options set, for messages that name the option the user typed
_FIELD_OPTIONS = {"top_length_m": "--top-length-mm", "bottom_length_m": "--bottom-length-mm", "depth_m": "--depth-mm",
                  "passes": "--passes", "feed_m_per_s": "--feed-mm-s", "spacing_m": "--spacing-mm",
                  "top_half_width_m": "--top-width-mm (half of it)", "step_down_m": "--step-down-mm",
                  "wall_angle_deg": "--wall-angle-deg", "wall_angle_end_deg": "--wall-angle-end-deg"}


def _check_options(args: argparse.Namespace) -> None:
    """The options' ranges that involve more than one of them, named as typed (before any SI field sees them)."""
    if args.gcode is not None:
        return
    if args.shape == "groove":
        if args.passes < 2:
            raise InputError(f"--passes {args.passes}: expected an integer >= 2")
        if args.bottom_length_mm >= args.top_length_mm:
            raise InputError(f"--bottom-length-mm {args.bottom_length_mm:g} must be shorter than --top-length-mm "
                             f"{args.top_length_mm:g} (the strokes shrink every pass)")
        if args.spacing_mm > args.bottom_length_mm:
            raise InputError(f"--spacing-mm {args.spacing_mm:g} exceeds --bottom-length-mm {args.bottom_length_mm:g}; "
                             "expected a spacing shorter than the last stroke")
        return
    for option in ("--wall-angle-deg", "--wall-angle-end-deg"):
        value = getattr(args, option[2:].replace("-", "_"))
        if not 0.0 < value < 90.0:
            raise InputError(f"{option} {value:g}: expected a wall angle in (0, 90) deg")


def _option_error(exc: InputError) -> InputError:
    """A spec's error with its SI field names replaced by the options that set them."""
    text = str(exc)
    for field, option in _FIELD_OPTIONS.items():
        text = re.sub(rf"\b(GrooveSpec\.|PartSpec\.)?{field}\b", option, text)
    return InputError(text.replace("PartSpec: ", "").replace("GrooveSpec: ", ""))


def _build(args: argparse.Namespace) -> tuple[ToolPath, dict[str, Any], str]:
    """The path, its summary and one human line about its geometry."""
    _check_options(args)
    try:
        return _build_checked(args)
    except InputError as exc:
        raise _option_error(exc) from None


def _build_checked(args: argparse.Namespace) -> tuple[ToolPath, dict[str, Any], str]:
    if args.gcode is not None:
        path = read_gcode(args.gcode, spacing_m=args.spacing_mm / 1e3)
        return path, {"source": str(args.gcode)}, f"from G-code {args.gcode}"
    if args.shape == "groove":
        spec = GrooveSpec(
            top_length_m=args.top_length_mm / 1e3,
            bottom_length_m=args.bottom_length_mm / 1e3,
            depth_m=(10.0 if args.depth_mm is None else args.depth_mm) / 1e3,
            passes=args.passes,
            feed_m_per_s=args.feed_mm_s / 1e3,
            spacing_m=args.spacing_mm / 1e3,
        )
        path = groove_path(spec)
        strokes = [spec.stroke_m(k) * 1e3 for k in range(1, spec.passes + 1)]
        payload = {
            "passes": spec.passes,
            "strokes_mm": strokes,
            "rpp_mm": spec.rpp_m * 1e3,
            "wall_angle_deg": math.degrees(spec.wall_angle_rad),
        }
        line = (
            f"strokes {strokes[0]:.2f} .. {strokes[-1]:.2f} mm (RpP {spec.rpp_m * 1e3:.3f} mm), "
            f"wall angle {math.degrees(spec.wall_angle_rad):.2f} deg"
        )
        return path, payload, line
    part = PartSpec(
        shape=args.shape,
        top_half_width_m=args.top_width_mm / 2e3,
        depth_m=(40.0 if args.depth_mm is None else args.depth_mm) / 1e3,
        wall_angle_deg=args.wall_angle_deg,
        wall_angle_end_deg=args.wall_angle_end_deg,
        step_down_m=args.step_down_mm / 1e3,
        mode=args.mode,
        feed_m_per_s=args.feed_mm_s / 1e3,
        spacing_m=args.spacing_mm / 1e3,
    )
    path = part_path(part)
    angles = np.degrees(part.wall_angle_rad(np.array([0.0, part.depth_m])))
    payload = {
        "shape": part.shape,
        "mode": part.mode,
        "passes": part.levels,
        "step_down_mm": part.depth_m / part.levels * 1e3,
        "wall_angle_deg": [float(angles[0]), float(angles[1])],
        "bottom_width_mm": float(2e3 * part.half_width_m(part.depth_m)),
    }
    line = (
        f"{part.shape} ({part.mode}), {part.levels} levels of {part.depth_m / part.levels * 1e3:.3f} mm, "
        f"wall angle {angles[0]:.2f} .. {angles[1]:.2f} deg"
    )
    return path, payload, line


def run(args: argparse.Namespace) -> int:
    """Build or import the path, check its reach, write it and print a summary."""
    process = process_declaration(args).applied_to(Process())
    path, payload, line = _build(args)
    if "step_down_mm" in payload:  # a cone, pyramid or variable-wall-angle cone: its steady axial force
        line += _steady_force(process, payload)
    if not args.no_reach_check:
        from twin.robot.kinematics import Kinematics

        robot = command_robot(args)
        reach = check_reach(path, placement_from(args), Kinematics(robot=robot))
        payload["reach"] = {
            "robot": robot.name,
            "min_abs_det_j_m3": reach.min_abs_det_j,
            "min_det_sample": reach.min_det_sample,
            "joint_margin_deg": np.degrees(reach.joint_margin_rad).tolist(),
        }
        line += f"; reachable by {robot.name}, min |det J| {reach.min_abs_det_j:.3f} m^3"
    write_path_csv(path, args.out)
    params = params_for(process)
    if args.gcode_out is not None:
        write_gcode(path, args.gcode_out)
    if args.stl_out is not None or args.design_stl is not None:
        from twin.process.part.surface import (
            DESIGN_MARGIN_M,
            cropped_surface,
            design_part_surface,
            heightmap_mesh,
            target_part_surface,
        )
    if args.stl_out is not None:
        payload["stl_faces"] = _write_stl(args, heightmap_mesh(*cropped_surface(*target_part_surface(path, params))))
        payload["stl_out"] = str(args.stl_out)
    if args.design_stl is not None:
        design = cropped_surface(*design_part_surface(path, params), DESIGN_MARGIN_M)
        payload["design_stl_faces"] = _write_stl(args, heightmap_mesh(*design), args.design_stl)
        payload["design_stl"] = str(args.design_stl)
    payload.update(
        {
            "out": str(args.out),
            "samples": len(path),
            "length_mm": float(path.s_m[-1] * 1e3),
            "duration_s": float(path.t_s[-1]),
            "final_depth_mm": float(-path.p_sheet_m[-1, 2] * 1e3),
            "process": process_record(process),
        }
    )
    emit_json(args.json, payload, protect=[args.out])
    out = sys.stderr if args.json == "-" else sys.stdout
    print(
        f"wrote {args.out}: {len(path)} samples, {path.s_m[-1] * 1e3:.2f} mm in {path.t_s[-1]:.2f} s, "
        f"final depth {-path.p_sheet_m[-1, 2] * 1e3:.3f} mm\n{line}\nprocess: {process.material} "
        f"(R_m {process.tensile_strength_mpa:g} MPa), {1e3 * process.thickness_m:g} mm sheet, "
        f"tool radius {1e3 * process.tool_radius_m:g} mm",
        file=out,
    )
    return 0


def _write_stl(args: argparse.Namespace, mesh: trimesh.Trimesh, file: Path | None = None) -> int:
    """Write a mesh in metres as a binary STL in millimetres, as CAD writes it (never over the path); its faces."""
    mesh.apply_scale(1e3)
    stl = mesh.export(file_type="stl")
    assert isinstance(stl, bytes)  # binary STL
    write_bytes(args.stl_out if file is None else file, stl, protect=[args.out])
    return len(mesh.faces)


def _steady_force(process: Process, payload: dict[str, Any]) -> str:
    """Add the ISF model's steady axial force at the part's top and bottom wall angles to `payload`
    (`steady_fz_n` [N]), warn outside the formula's declared range, and say it in one line."""
    step_m = 1e-3 * payload["step_down_mm"]
    angles = payload["wall_angle_deg"]
    forces = [steady_fz_n(process, step_m, angle) for angle in angles]
    payload["steady_fz_n"] = forces
    for angle in dict.fromkeys(angles):
        for sentence in validity_warnings(process.thickness_m, process.tool_radius_m, step_m, angle):
            warnings.warn(sentence, ExtrapolationWarning, stacklevel=2)
    at = f"{forces[0]:.0f} N" if forces[0] == forces[1] else f"{forces[0]:.0f} .. {forces[1]:.0f} N"
    return f"\npredicted steady axial force (ISF model, Aerens et al.): {at}"
