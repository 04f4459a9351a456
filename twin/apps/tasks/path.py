"""`path`: an ideal tool path U_ID written as CSV (the thesis groove, §1.2.3 and Table 2.3, a cone, pyramid or
variable-wall-angle cone of `twin.process.toolpath.shapes`, or an imported G-code program), checked for the robot's
reach along the whole path at the sheet's placement (`twin.process.toolpath.placement`). The declared process is
reported, shapes the target part of `stl_out` (the tool's radius, the sheet's springback) and the design part of
`design_stl` (the tool's radius, no springback) and, for a cone, pyramid or variable-wall-angle cone, gives the ISF
model's predicted steady axial force (`twin.process.force.isf_params.steady_fz_n`, Aerens et al.'s formula; an
`ExtrapolationWarning` where the process or the part lies outside the formula's experiments)."""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.analysis.resolve import resolve_robot
from twin.apps.tasks.base import Note, Report, silent
from twin.base.csvio import write_bytes
from twin.errors import ExtrapolationWarning, InputError
from twin.process.description import Process
from twin.process.force.aerens import validity_warnings
from twin.process.force.isf_params import params_for, steady_fz_n
from twin.process.process_file import ProcessDeclaration, process_record
from twin.process.toolpath.gcode import read_gcode
from twin.process.toolpath.gcode_write import write_gcode
from twin.process.toolpath.groove import (
    MAX_SAMPLES,
    GrooveSpec,
    SampleLimitError,
    ToolPath,
    groove_path,
    min_spacing_m,
)
from twin.process.toolpath.placement import Placement, check_reach
from twin.process.toolpath.shapes import MODES, SHAPES, PartSpec, part_path
from twin.runs.write import write_path_csv

if TYPE_CHECKING:  # trimesh loads only where a part surface is written
    import trimesh

_GROOVE, _PART = GrooveSpec(), PartSpec()

# the spec fields the request's values set, for messages that name the option the user typed
_FIELD_OPTIONS = {"top_length_m": "--top-length-mm", "bottom_length_m": "--bottom-length-mm", "depth_m": "--depth-mm",
                  "passes": "--passes", "feed_m_per_s": "--feed-mm-s", "spacing_m": "--spacing-mm",
                  "top_half_width_m": "--top-width-mm (half of it)", "step_down_m": "--step-down-mm",
                  "wall_angle_deg": "--wall-angle-deg", "wall_angle_end_deg": "--wall-angle-end-deg"}


@dataclass(frozen=True)
class PathRequest:
    """What path to write, as the command's options give it (lengths [mm], the options' units).

    Attributes:
        out: The path CSV to write (t_s, x_mm, y_mm, z_mm, pass, direction; sheet frame).
        shape: "groove" or one of `SHAPES`; ignored when `gcode` is given.
        gcode: A G-code program to import instead of a shape, or None.
        gcode_out: Also write the path as G-code (G1, mm) here, or None.
        stl_out: Also write the target part (after springback) as a binary STL [mm] here, or None.
        design_stl: Also write the design part (no springback) as a binary STL [mm] here, or None.
        depth_mm: Final depth H [mm]; None: groove 10, other parts 40.
        feed_mm_s: Constant feed [mm/s].
        spacing_mm: Largest sample spacing [mm] (G-code: the chords of arcs and the pieces of lines).
        passes: Groove: number of passes N.
        top_length_mm: Groove: length L at the surface [mm].
        bottom_length_mm: Groove: length B at full depth [mm].
        mode: Cone, pyramid, vwa-cone: the descent, one of `MODES`.
        top_width_mm: Cone, pyramid, vwa-cone: tool-tip contour at the surface (diameter or side) [mm].
        wall_angle_deg: Cone, pyramid: the wall angle; vwa-cone: at the top [deg].
        wall_angle_end_deg: vwa-cone: the wall angle at the bottom [deg].
        step_down_mm: Cone, pyramid, vwa-cone: the largest step-down [mm].
        declaration: The declared process (over the thesis's).
        placement: The sheet frame in the robot base, for the reach check.
        robot: A robot name or description file; None: the default robot.
        reach_check: Check the robot's inverse kinematics along the path.
        cell: A `--cell` file's record: the reach is checked with its tool (`resolve_tool_spec`), or None.
    """

    out: Path
    shape: str = "groove"
    gcode: Path | None = None
    gcode_out: Path | None = None
    stl_out: Path | None = None
    design_stl: Path | None = None
    depth_mm: float | None = None
    feed_mm_s: float = _GROOVE.feed_m_per_s * 1e3
    spacing_mm: float = _GROOVE.spacing_m * 1e3
    passes: int = _GROOVE.passes
    top_length_mm: float = _GROOVE.top_length_m * 1e3
    bottom_length_mm: float = _GROOVE.bottom_length_m * 1e3
    mode: str = _PART.mode
    top_width_mm: float = 2e3 * _PART.top_half_width_m
    wall_angle_deg: float = _PART.wall_angle_deg
    wall_angle_end_deg: float = _PART.wall_angle_end_deg
    step_down_mm: float = _PART.step_down_m * 1e3
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    placement: Placement = field(default_factory=Placement)
    robot: str | Path | None = None
    reach_check: bool = True
    cell: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        """The ranges that involve more than one value, named as the options are typed."""
        if self.gcode is not None:
            return
        if self.shape not in ("groove", *SHAPES):
            raise InputError(f"--shape {self.shape!r}: expected one of groove, {', '.join(SHAPES)}")
        if self.shape == "groove":
            if self.passes < 2:
                raise InputError(f"--passes {self.passes}: expected an integer >= 2")
            if self.bottom_length_mm >= self.top_length_mm:
                raise InputError(f"--bottom-length-mm {self.bottom_length_mm:g} must be shorter than --top-length-mm "
                                 f"{self.top_length_mm:g} (the strokes shrink every pass)")
            if self.spacing_mm > self.bottom_length_mm:
                raise InputError(f"--spacing-mm {self.spacing_mm:g} exceeds --bottom-length-mm "
                                 f"{self.bottom_length_mm:g}; expected a spacing shorter than the last stroke")
            return
        if self.mode not in MODES:
            raise InputError(f"--mode {self.mode!r}: expected one of {', '.join(MODES)}")
        for option in ("--wall-angle-deg", "--wall-angle-end-deg"):
            value = getattr(self, option[2:].replace("-", "_"))
            if not 0.0 < value < 90.0:
                raise InputError(f"{option} {value:g}: expected a wall angle in (0, 90) deg")


@dataclass(frozen=True)
class PathReport(Report):
    """The path written and what it says.

    Attributes:
        out: The path CSV written.
        path: The path (sheet frame).
        process: The declared process.
        facts: The geometry's numbers (the groove's strokes, a part's levels and wall angles), the steady axial
            force, the reach and the STL files, in the order of the JSON document.
        geometry: The summary's line about the geometry (and, after a newline, the steady force).
    """

    out: Path
    path: ToolPath
    process: Process
    facts: dict[str, Any]
    geometry: str

    def lines(self) -> list[str]:
        path, process = self.path, self.process
        return [
            f"wrote {self.out}: {len(path)} samples, {path.s_m[-1] * 1e3:.2f} mm in {path.t_s[-1]:.2f} s, "
            f"final depth {-path.p_sheet_m[-1, 2] * 1e3:.3f} mm",
            *self.geometry.split("\n"),
            f"process: {process.material} (R_m {process.tensile_strength_mpa:g} MPa), "
            f"{1e3 * process.thickness_m:g} mm sheet, tool radius {1e3 * process.tool_radius_m:g} mm",
        ]

    def record(self) -> dict[str, Any]:
        path = self.path
        return {
            **self.facts,
            "out": str(self.out),
            "samples": len(path),
            "length_mm": float(path.s_m[-1] * 1e3),
            "duration_s": float(path.t_s[-1]),
            "final_depth_mm": float(-path.p_sheet_m[-1, 2] * 1e3),
            "process": process_record(self.process),
        }


def path_task(request: PathRequest, note: Note = silent) -> PathReport:
    """Build or import the path, check its reach, write it (and its G-code and STL parts where asked).

    Raises:
        InputError: A bad geometry (naming the option), a bad declaration, a G-code program it cannot read.
        UnreachableError, SingularityError: A sample the robot cannot reach at the placement.
    """
    process = request.declaration.applied_to(Process())
    path, facts, geometry = _build(request)
    if "step_down_mm" in facts:  # a cone, pyramid or variable-wall-angle cone: its steady axial force
        geometry += _steady_force(process, facts)
    if request.reach_check:
        from twin.analysis.tool_choice import resolve_tool_spec
        from twin.robot.kinematics import Kinematics
        from twin.robot.model import build_model

        robot = resolve_robot(request.robot)
        kin = Kinematics(build_model(robot, tool=resolve_tool_spec(robot, cell=request.cell)), robot=robot)
        reach = check_reach(path, request.placement, kin)  # the cell's tool reaches, not the model's
        facts["reach"] = {
            "robot": robot.name,
            "min_abs_det_j_m3": reach.min_abs_det_j,
            "min_det_sample": reach.min_det_sample,
            "joint_margin_deg": np.degrees(reach.joint_margin_rad).tolist(),
        }
        geometry += f"; reachable by {robot.name}, min |det J| {reach.min_abs_det_j:.3f} m^3"
    write_path_csv(path, request.out)
    params = params_for(process)
    if request.gcode_out is not None:
        write_gcode(path, request.gcode_out)
    _write_parts(request, path, params, facts)
    return PathReport(request.out, path, process, facts, geometry)


def _write_parts(request: PathRequest, path: ToolPath, params: Any, facts: dict[str, Any]) -> None:
    """Write the target and the design part where asked, their faces and files into `facts`."""
    if request.stl_out is None and request.design_stl is None:
        return
    from twin.process.part.surface import (
        DESIGN_MARGIN_M,
        cropped_surface,
        design_part_surface,
        heightmap_mesh,
        target_part_surface,
    )

    if request.stl_out is not None:
        target = heightmap_mesh(*cropped_surface(*target_part_surface(path, params)))
        facts["stl_faces"] = _write_stl(target, request.stl_out, request.out)
        facts["stl_out"] = str(request.stl_out)
    if request.design_stl is not None:
        design = cropped_surface(*design_part_surface(path, params), DESIGN_MARGIN_M)
        facts["design_stl_faces"] = _write_stl(heightmap_mesh(*design), request.design_stl, request.out)
        facts["design_stl"] = str(request.design_stl)


def _write_stl(mesh: trimesh.Trimesh, file: Path, path_csv: Path) -> int:
    """Write a mesh in metres as a binary STL in millimetres, as CAD writes it (never over the path); its faces."""
    mesh.apply_scale(1e3)
    stl = mesh.export(file_type="stl")
    assert isinstance(stl, bytes)  # binary STL
    write_bytes(file, stl, protect=[path_csv])
    return len(mesh.faces)


def _build(request: PathRequest) -> tuple[ToolPath, dict[str, Any], str]:
    """The path, its geometry's numbers and one human line about its geometry, errors naming the options."""
    try:
        if request.gcode is not None:
            path = read_gcode(request.gcode, spacing_m=request.spacing_mm / 1e3)
            return path, {"source": str(request.gcode)}, f"from G-code {request.gcode}"
        if request.shape == "groove":
            return _groove(request)
        return _part(request)
    except SampleLimitError as exc:
        source = "" if request.gcode is None else f" of G-code {request.gcode}"
        raise InputError(
            f"--spacing-mm {request.spacing_mm:g} would make {exc.samples:.3g} samples or more{source}; expected "
            f"at most {MAX_SAMPLES:,} samples: a spacing of at least "
            f"{1e3 * min_spacing_m(exc.samples, exc.spacing_m):.3g} mm") from None
    except InputError as exc:
        raise _option_error(exc) from None


def _option_error(exc: InputError) -> InputError:
    """A spec's error with its SI field names replaced by the options that set them."""
    text = str(exc)
    for name, option in _FIELD_OPTIONS.items():
        text = re.sub(rf"\b(GrooveSpec\.|PartSpec\.)?{name}\b", option, text)
    return InputError(text.replace("PartSpec: ", "").replace("GrooveSpec: ", ""))


def _groove(request: PathRequest) -> tuple[ToolPath, dict[str, Any], str]:
    """The groove of the request, its strokes and wall angle."""
    spec = GrooveSpec(
        top_length_m=request.top_length_mm / 1e3,
        bottom_length_m=request.bottom_length_mm / 1e3,
        depth_m=(10.0 if request.depth_mm is None else request.depth_mm) / 1e3,
        passes=request.passes,
        feed_m_per_s=request.feed_mm_s / 1e3,
        spacing_m=request.spacing_mm / 1e3,
    )
    strokes = [spec.stroke_m(k) * 1e3 for k in range(1, spec.passes + 1)]
    facts = {
        "passes": spec.passes,
        "strokes_mm": strokes,
        "rpp_mm": spec.rpp_m * 1e3,
        "wall_angle_deg": math.degrees(spec.wall_angle_rad),
    }
    line = (
        f"strokes {strokes[0]:.2f} .. {strokes[-1]:.2f} mm (RpP {spec.rpp_m * 1e3:.3f} mm), "
        f"wall angle {math.degrees(spec.wall_angle_rad):.2f} deg"
    )
    return groove_path(spec), facts, line


def _part(request: PathRequest) -> tuple[ToolPath, dict[str, Any], str]:
    """The cone, pyramid or variable-wall-angle cone of the request, its levels and wall angles."""
    part = PartSpec(
        shape=request.shape,
        top_half_width_m=request.top_width_mm / 2e3,
        depth_m=(40.0 if request.depth_mm is None else request.depth_mm) / 1e3,
        wall_angle_deg=request.wall_angle_deg,
        wall_angle_end_deg=request.wall_angle_end_deg,
        step_down_m=request.step_down_mm / 1e3,
        mode=request.mode,
        feed_m_per_s=request.feed_mm_s / 1e3,
        spacing_m=request.spacing_mm / 1e3,
    )
    path = part_path(part)
    angles = np.degrees(part.wall_angle_rad(np.array([0.0, part.depth_m])))
    facts = {
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
    return path, facts, line


def _steady_force(process: Process, facts: dict[str, Any]) -> str:
    """Add the ISF model's steady axial force at the part's top and bottom wall angles to `facts`
    (`steady_fz_n` [N]), warn outside the formula's declared range, and say it in one line."""
    step_m = 1e-3 * facts["step_down_mm"]
    angles = facts["wall_angle_deg"]
    forces = [steady_fz_n(process, step_m, angle) for angle in angles]
    facts["steady_fz_n"] = forces
    for angle in dict.fromkeys(angles):
        for sentence in validity_warnings(process.thickness_m, process.tool_radius_m, step_m, angle):
            warnings.warn(sentence, ExtrapolationWarning, stacklevel=2)
    at = f"{forces[0]:.0f} N" if forces[0] == forces[1] else f"{forces[0]:.0f} .. {forces[1]:.0f} N"
    return f"\npredicted steady axial force (ISF model, Aerens et al.): {at}"
