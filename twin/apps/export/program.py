"""What every robot-program exporter needs: the path as points and feeds, the tool and the sheet frame.

The path CSV (`t_s, x_mm, y_mm, z_mm, ...`, sheet frame: `tx200-twin path` or `compensate` output) is read
with the run format's reader. Each point's feed is the speed of the straight move that reaches it
(|Δp| / Δt of the path's own time stamps). The tool is the robot's ISF tool (`RobotDescription`): straight,
`tool_length_mm` along the flange z axis, pointing down while forming; the sheet frame's origin in the robot
base frame comes from the cell model (`Kinematics.p_base_sheet_origin`, axes parallel to the base) or from a placement
(`twin.process.toolpath.placement.Placement`: an origin and a yaw about the base z axis, which each format writes as the
sheet frame's rotation rz / A / quaternion / G68). The tool length is the robot's, or a run's (`CellSetup`).

A robot program also carries the arm configuration (`with_configuration`): the robot's IK along the path in the
base frame, tool down, one `twin.apps.export.configuration.RobotConfiguration` per point; the path must keep one.

Rotation conventions (for the orientation of a frame R):
- Stäubli VAL3 (rx, ry, rz): R = Rx(rx) · Ry(ry) · Rz(rz).
- KUKA KRL (A, B, C): R = Rz(A) · Ry(B) · Rx(C).
- ABB RAPID: unit quaternion [q1, q2, q3, q4] = [w, x, y, z].
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from twin.apps.export.configuration import RobotConfiguration, path_configurations
from twin.apps.export.reach import path_joint_angles
from twin.errors import InputError
from twin.process.toolpath.placement import Placement
from twin.robot.controller import DEFAULT_BASE_NUMBER, DEFAULT_TOOL_NUMBER
from twin.robot.description import DEFAULT_ROBOT, load_robot, robot_record
from twin.robot.facts import RobotDescription
from twin.robot.tool import INERTIA_RADIUS_M
from twin.runs.read import read_commanded_csv
from twin.sim.online_settings import OnlineSettings

POSITION_DECIMALS = 4  # mm: 0.1 µm, below the tracker's 0.02 mm noise
MIN_FEED_MM_S = 1e-3
#: Program names: KRL's 24 characters (the shortest of the three controllers' limits).
MAX_NAME = 24


@dataclass(frozen=True)
class CellSetup:
    """Where the program's frame and tool are.

    Attributes:
        p_base_sheet_mm: Sheet frame origin in the robot base frame [mm].
        R_sheet_tool: Tool axes in the sheet frame (z along the tool, pointing down for ISF).
        tool_length_mm: Flange to tool tip along the flange z axis [mm].
        tool_mass_kg: Tool mass for controllers that need load data [kg].
        yaw_deg: Rotation of the sheet frame about the base z axis [deg] (0: axes parallel to the base).
        robot: The robot the program is for (a shipped robot's name or a description file).
        configuration: The arm configuration at the program's first point (`with_configuration`), or None.
        cog_mm: The tool's centre of gravity in the flange frame [mm] as declared (a `--cell` file's), or None.
        sources: Where the sheet origin, its yaw, the tool length and the tool mass came from, in words (keys
            "origin", "yaw", "tool_length", "tool_mass"; `twin.analysis.resolve.PRECEDENCE`), or None.
    """

    p_base_sheet_mm: np.ndarray
    R_sheet_tool: np.ndarray
    tool_length_mm: float
    tool_mass_kg: float = 2.0
    yaw_deg: float = 0.0
    robot: str = DEFAULT_ROBOT
    configuration: RobotConfiguration | None = None
    cog_mm: tuple[float, float, float] | None = None
    sources: Mapping[str, str] | None = None

    def __post_init__(self) -> None:
        for name, option in (("tool_length_mm", "--tool-length-mm"), ("tool_mass_kg", "--tool-mass-kg")):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(f"{option} {value!r} ({name}): expected a finite number > 0")

    @property
    def R_base_sheet(self) -> np.ndarray:
        """The sheet frame's axes in the robot base (the yaw about the base z axis)."""
        return Placement(yaw_rad=math.radians(self.yaw_deg)).R_base_sheet

    @property
    def tool_cog_mm(self) -> np.ndarray:
        """The tool's centre of gravity in the flange frame [mm]: as declared (`cog_mm`), else half way down the
        tool along the flange z.

        Without a declaration the twin knows the tool's length and mass but not how the mass is spread; a straight
        ISF tool of uniform section has its centre of gravity half way along it. Every program's load data (RAPID
        `tooldata`, KRL `LOAD_DATA`) takes it from here, so that the formats agree.
        """
        if self.cog_mm is not None:
            return np.array(self.cog_mm, dtype=float)
        return np.array([0.0, 0.0, self.tool_length_mm / 2.0])

    @property
    def tool_inertia_kgm2(self) -> np.ndarray:
        """The tool's principal moments of inertia about its centre of gravity, flange axes x, y, z [kg m²]: a
        uniform solid cylinder of the tool's length and `twin.robot.tool.INERTIA_RADIUS_M` about the flange z, as
        the twin's model carries the declared mass (`twin.robot.tool`); RAPID `tooldata` ix iy iz, KRL `J`."""
        m, length, r = self.tool_mass_kg, self.tool_length_mm / 1000.0, INERTIA_RADIUS_M
        transverse = m * (3.0 * r * r + length * length) / 12.0
        return np.array([transverse, transverse, m * r * r / 2.0])


@dataclass(frozen=True)
class ProgramPath:
    """A path ready to export.

    Attributes:
        name: Program name (letters, digits and `_`, starting with a letter).
        points_mm: Tool-tip points in the sheet frame, shape (n, 3) [mm].
        feed_mm_s: Feed of the move that reaches each point, shape (n,) [mm/s] (the first copies the second).
        cell: Frame and tool.
        source: The path CSV it came from.
        configurations: The arm configuration at each point (`with_configuration`), or () when not solved.
        approach: The first point is an approach above the path and the last a retract (`motion.with_moves`);
            the path CSV's data row r is then point r (else point r - 1).
        joint_start: The first point is reached by a joint move (False: a later part of a split program).
        max_points: Points per file or module before a program is split (`parts`); 0: the format's limit.
        process_feed_mm_s: The process feed (`motion.with_moves`) [mm/s]; 0: not given, the median of the feeds
            (`process_feed`).
        tool_number: The controller's tool (and load) slot the program writes and uses (KRL `TOOL_DATA[n]`,
            `LOAD_DATA[n]`; `slots.TOOL_NUMBERS`), not the cell's calibrated tool 1.
        base_number: The controller's base slot the program writes and uses (KRL `BASE_DATA[n]`; `slots.BASE_NUMBERS`).
        max_correction_mm: An online program's limit on the correction [mm] (RSI's POSCORR limits and monitor, EGM
            position guidance's end tolerance): the compensator's `max_correction_mm`, which its server is given.
    """

    name: str
    points_mm: np.ndarray
    feed_mm_s: np.ndarray
    cell: CellSetup
    source: Path
    configurations: tuple[RobotConfiguration, ...] = ()
    approach: bool = False
    joint_start: bool = True
    max_points: int = 0
    process_feed_mm_s: float = 0.0
    tool_number: int = DEFAULT_TOOL_NUMBER
    base_number: int = DEFAULT_BASE_NUMBER
    max_correction_mm: float = OnlineSettings.max_correction_mm

    @property
    def process_feed(self) -> float:
        """The process feed [mm/s]: the one `motion.with_moves` chose, else the median of the point feeds."""
        return self.process_feed_mm_s or float(np.median(self.feed_mm_s))

    def label(self, i: int) -> str:
        """Point `i` as the user knows it: `row R` of the path CSV, or the approach / retract point."""
        if not self.approach:
            return f"row {i + 1}"
        if i == 0:
            return "the approach point (above row 1)"
        if i == len(self.points_mm) - 1:
            return f"the retract point (above row {i - 1})"
        return f"row {i}"


def cell_lines(cell: CellSetup) -> list[str]:
    """What each program states on its first comment lines (its language's comment mark before each): the sheet
    frame in the robot base and the tool the program was written with, and where each came from."""
    sources = dict(cell.sources or {})
    x, y, z = (f"{float(v):.4f}".rstrip("0").rstrip(".") for v in cell.p_base_sheet_mm)
    return [
        f"sheet frame in the base of robot {cell.robot}: origin ({x}, {y}, {z}) mm "
        f"(from {sources.get('origin', 'the placement given')}), yaw {cell.yaw_deg:g} deg "
        f"(from {sources.get('yaw', 'the placement given')})",
        f"tool: {cell.tool_length_mm:g} mm flange to tip (from {sources.get('tool_length', 'the cell given')}), "
        f"{cell.tool_mass_kg:g} kg (from {sources.get('tool_mass', 'the cell given')})",
    ]


def default_cell(
    tool_mass_kg: float | None = None,
    placement: Placement | None = None,
    robot: str | RobotDescription | None = None,
) -> CellSetup:
    """The robot's cell: sheet origin and vertical tool from its MuJoCo scene, its tool length and mass.

    Args:
        tool_mass_kg: Tool mass [kg]; None: the mass of the robot model's tool body (the body of its tool site).
        placement: Where the sheet lies (origin, yaw); None: the scene's sheet site, yaw 0. The tool keeps the
            twin's orientation in the base (`Kinematics.R_tool_down`), written in the turned sheet frame.
        robot: The robot; None: the default robot.
    """
    from twin.robot.kinematics import Kinematics  # MuJoCo: only when a program is made

    kin = Kinematics(robot=robot)
    place = placement or Placement()
    R_base_sheet = place.R_base_sheet
    if tool_mass_kg is None:
        body = kin.model.site(kin.robot.tool_site).bodyid[0]
        tool_mass_kg = float(kin.model.body_subtreemass[body])
        if tool_mass_kg <= 0.0:  # a URDF's tool links often carry no inertial: a program's load data needs one
            raise InputError(f"robot {kin.robot.name}'s model carries no mass at its tool (body "
                             f"{kin.model.body(body).name!r}: 0 kg): declare the tool's mass, --tool-mass-kg M or a "
                             "cell's [tool] mass_kg (the program's load data)")
    return CellSetup(
        place.origin_in(kin) * 1e3,
        R_base_sheet.T @ kin.R_tool_down,
        kin.robot.tool_length_m * 1e3,
        tool_mass_kg,
        math.degrees(place.yaw_rad),
        robot_record(kin.robot),
    )


def with_configuration(path: ProgramPath, language: str = "") -> ProgramPath:
    """`path` with the arm configuration of each point and the first one's in its cell.

    Solves the cell robot's IK for the tool-tip points in the base frame (`configuration.path_configurations`).

    Args:
        path: The path.
        language: The program's language, for messages.

    Raises:
        InputError: The cell's tool is not the twin's tool-down orientation, or the configuration changes along
            the path (the message names the row). UnreachableError, SingularityError: A point out of reach.
    """
    cell = path.cell
    p_base_m = (cell.p_base_sheet_mm + path.points_mm @ cell.R_base_sheet.T) * 1e-3
    configs = path_configurations(
        cell.robot, p_base_m, cell.R_base_sheet @ cell.R_sheet_tool, cell.tool_length_mm * 1e-3, str(path.source),
        language, path.label,
    )
    return replace(path, cell=replace(cell, configuration=configs[0]), configurations=tuple(configs))


def check_reach(path: ProgramPath) -> None:
    """Refuse a program with a point the cell's robot cannot reach (`reach.path_joint_angles` names it).

    Raises:
        InputError: The cell's tool is not the twin's tool-down orientation. UnreachableError, SingularityError:
            A point out of reach (its row or approach / retract point, position and distance from the base).
    """
    cell = path.cell
    p_base_m = (cell.p_base_sheet_mm + path.points_mm @ cell.R_base_sheet.T) * 1e-3
    path_joint_angles(
        cell.robot, p_base_m, cell.R_base_sheet @ cell.R_sheet_tool, cell.tool_length_mm * 1e-3, str(path.source),
        path.label,
    )


def home_axes_deg(cell: CellSetup) -> np.ndarray:
    """The cell robot's home as its controller's axis values A1..A6 / J1..J6 [deg].

    The home keyframe of the robot's model (`RobotDescription.q_home_rad`, the pose the twin starts from and the
    IK is seeded at), turned into the controller's axis values (`RobotDescription.controller_angles`): every
    program starts and ends there with a joint move (KRL `PTP`, RAPID `MoveAbsJ`, VAL3 `movej`).
    """
    robot = load_robot(cell.robot)
    return np.round(np.degrees(robot.controller_angles(robot.q_home)), POSITION_DECIMALS) + 0.0  # + 0.0: no -0.0


def program_name(text: str) -> str:
    """A controller-safe program name from a file name: letters, digits, `_`; starts with a letter; <= 24."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", text)
    if not name or not name[0].isalpha():
        name = "p" + name
    return name[:MAX_NAME]


def load_program_path(path_csv: str | Path, cell: CellSetup, name: str) -> ProgramPath:
    """Read a path CSV and compute the feed of each move.

    Args:
        path_csv: `t_s, x_mm, y_mm, z_mm` in the sheet frame.
        cell: Frame and tool.
        name: Program name (made controller-safe).

    Raises:
        RunFormatError: Bad CSV (file and row named). InputError: repeated points (zero-length moves).
    """
    stream = read_commanded_csv(path_csv)
    points = stream.values * 1e3
    step = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if np.any(step <= 0):
        row = int(np.flatnonzero(step <= 0)[0]) + 2
        raise InputError(f"{path_csv}, row {row}: the point repeats the previous one; expected a move")
    feed = step / np.diff(stream.t_s)
    feed = np.concatenate([feed[:1], feed])
    return ProgramPath(program_name(name), points, np.maximum(feed, MIN_FEED_MM_S), cell, Path(path_csv))


def euler_xyz_deg(R: np.ndarray) -> np.ndarray:
    """Stäubli angles (rx, ry, rz) [deg] with R = Rx(rx) Ry(ry) Rz(rz)."""
    ry = math.asin(max(-1.0, min(1.0, R[0, 2])))
    if abs(R[0, 2]) < 1.0 - 1e-9:
        rx = math.atan2(-R[1, 2], R[2, 2])
        rz = math.atan2(-R[0, 1], R[0, 0])
    else:  # gimbal lock: put everything in rx
        rx = math.atan2(R[2, 1], R[1, 1])
        rz = 0.0
    return np.degrees([rx, ry, rz])


def euler_zyx_deg(R: np.ndarray) -> np.ndarray:
    """KUKA angles (A, B, C) [deg] with R = Rz(A) Ry(B) Rx(C)."""
    b = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    if abs(R[2, 0]) < 1.0 - 1e-9:
        a = math.atan2(R[1, 0], R[0, 0])
        c = math.atan2(R[2, 1], R[2, 2])
    else:
        a = math.atan2(-R[0, 1], R[1, 1])
        c = 0.0
    return np.degrees([a, b, c])


def quaternion_wxyz(R: np.ndarray) -> np.ndarray:
    """Unit quaternion [w, x, y, z] of a rotation matrix (w >= 0)."""
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2.0, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2.0, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2.0, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def fmt(value: float, decimals: int = POSITION_DECIMALS) -> str:
    """Fixed-point text without a negative zero."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text
