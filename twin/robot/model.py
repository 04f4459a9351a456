"""The compiled MuJoCo model of a robot, with the robot-side effects built in through `mujoco.MjSpec`.

The twin and the virtual lab share one mechanism for physical effects on the robot: `build_model` turns the
effects that change the compiled robot into an augmented MJCF (the effect vocabulary is `twin.sim.effects`):

- lost motion (backlash) in the robot's lost-motion joints (`RobotDescription.lost_motion_joints`). MuJoCo's
  double-hinge pattern: each gets a second, link-side hinge on the same axis (`lost_joint_name`) with a very
  stiff spring whose reference angle is switched by the travel direction (`lost_motion_schedule`): the link
  gives way in the direction the process (friction and ploughing) force pushes it. After a reversal the play
  is taken up linearly over a take-up travel. The tool therefore lags differently going forward and backward
  and shows a distortion at the start of each stroke, as the thesis saw (sec. 3.3.1);
- a tool-length error: the real tool tip lies `tool_offset_m` further along the tool axis than the nominal
  tool the path was computed with (the controller still uses the nominal length).
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import mujoco
import numpy as np

from twin.errors import ModelError
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription
from twin.robot.tool import ToolSpec, apply_tool

LOST_MOTION_STIFFNESS_NM_PER_RAD = 1.0e9  # stiff enough that the link-side hinge is a pure offset


def lost_joint_name(joint: str) -> str:
    """Name of the link-side hinge that carries `joint`'s lost motion."""
    return f"{joint}_lost"


def build_model(
    robot: str | Path | RobotDescription | None = None,
    *,
    tool_offset_m: float = 0.0,
    lost_motion: bool = False,
    scene: bool = True,
    tool: ToolSpec | None = None,
) -> mujoco.MjModel:
    """Compile a robot's model (scene or robot only) with the robot-side effects added through MjSpec.

    The compiled model depends only on the declared tool, the tool-length offset and whether lost-motion hinges are present (the
    other effects act through the field or the springs' references), so each such variant is compiled once
    per process and handed out as a private copy (a copy costs 0.6 ms, a compile 28 ms; the discrepancy search
    builds a twin per replay).

    Args:
        robot: The robot; None: the default robot.
        tool_offset_m: Real tool tip minus nominal, along the tool axis [m].
        lost_motion: Add the link-side hinges of the robot's lost-motion joints.
        scene: Compile the robot's scene (True) or its robot-only MJCF (False).
        tool: A declared tool in place of the MJCF's own (`twin.robot.tool.apply_tool`); None: the MJCF's.

    Returns:
        The compiled model, the caller's own (its springs and friction may be changed). Contacts are disabled:
        the sheet acts through the force field.

    Raises:
        ModelError: If the model file is missing or does not compile.
    """
    description = load_robot(robot)
    path = description.model_path(scene)
    # a recalibrated model file is recompiled; a missing one reaches the compile, which names it
    stamps = tuple(p.stat().st_mtime_ns if p.is_file() else -1 for p in (path, description.mjcf, description.source))
    # the description is in the key: two robot files may share an MJCF and set its geometry differently
    key = (str(path), str(description.source), stamps, float(tool_offset_m),
           bool(lost_motion) and bool(description.lost_motion_joints), tool)
    if key not in _COMPILED:
        _COMPILED[key] = _compile(path, description, float(tool_offset_m), key[4], tool)
    return copy.copy(_COMPILED[key])


_COMPILED: dict[tuple[str, str, tuple[int, ...], float, bool, ToolSpec | None], mujoco.MjModel] = {}


def robot_spec(path: Path, robot: RobotDescription) -> mujoco.MjSpec:
    """The MJCF `path` of `robot` as an editable spec, its link offsets set from the robot file's DH table where
    the file says the table is the geometry (`dh_geometry`).

    Raises:
        ModelError: The file does not parse, or lacks a joint or site the robot file names.
    """
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # mujoco raises ValueError with the parser's message
        raise ModelError(f"cannot load {path}: {exc}") from exc
    if robot.dh is not None and robot.dh.geometry:
        dh_geometry(spec, robot)
    return spec


def compile_mjcf(path: Path, robot: RobotDescription | None = None) -> mujoco.MjModel:
    """Compile an MJCF file as it is, or as `robot`'s file sets its geometry (`robot_spec`).

    Raises:
        ValueError: MuJoCo's, when the file does not compile. ModelError: a joint or site the robot names is missing.
    """
    if robot is not None and robot.dh is not None and robot.dh.geometry:
        return robot_spec(path, robot).compile()
    return mujoco.MjModel.from_xml_path(str(path))


def dh_geometry(spec: mujoco.MjSpec, robot: RobotDescription) -> None:
    """Set the MJCF's link offsets from the robot file's DH table (its `[dh] geometry = true`).

    The MJCF follows the convention of models/README.md: body link_i is DH frame i-1 turned by Rot_z(offset_i),
    so its pose in link_{i-1} is Trans_z(d_{i-1}) Trans_x(a_{i-1}) Rot_x(alpha_{i-1}) Rot_z(offset_i), and the
    flange site sits at (a_n, 0, d_n) on the last link. What hangs at the flange (the F/T sensor and tool bodies,
    sites at the flange) moves with it. So one MJCF serves two published tables of the same arm (the TX200's
    thesis table and the community description differ in a1, d1 and d6).

    Raises:
        ModelError: The MJCF lacks a joint or the flange site the robot file names.
    """
    assert robot.dh is not None
    dh = robot.dh
    links = []
    for name in robot.joints:
        joint = spec.joint(name)
        if joint is None:
            raise ModelError(f"{robot.mjcf} has no joint {name!r}, which {robot.source} names")
        links.append(joint.parent)
    for i in range(1, len(links)):
        links[i].pos = [dh.a_m[i - 1], 0.0, dh.d_m[i - 1]]
        links[i].quat = _quat_x_then_z(dh.alpha_rad[i - 1], dh.offset_rad[i])
    flange = spec.site(robot.flange_site)
    if flange is None:
        raise ModelError(f"{robot.mjcf} has no site {robot.flange_site!r}, which {robot.source} names")
    old = np.array(flange.pos, dtype=float)
    new = np.array([dh.a_m[-1], 0.0, dh.d_m[-1]])
    for element in [*links[-1].sites, *links[-1].bodies]:
        if np.allclose(element.pos, old, atol=1e-12):
            element.pos = element.pos + (new - old)


def _quat_x_then_z(alpha_rad: float, theta_rad: float) -> list[float]:
    """Quaternion (w, x, y, z) of Rot_x(alpha) Rot_z(theta)."""
    ca, sa = math.cos(alpha_rad / 2), math.sin(alpha_rad / 2)
    ct, st = math.cos(theta_rad / 2), math.sin(theta_rad / 2)
    return [ca * ct, sa * ct, -sa * st, ca * st]


def _compile(path: Path, robot: RobotDescription, tool_offset_m: float, lost_motion: bool,
             tool: ToolSpec | None = None) -> mujoco.MjModel:
    """Compile `path` with the declared tool and the model-changing effects (`build_model`)."""
    spec = robot_spec(path, robot)
    if tool is not None:  # before the offset: the tool-length error is of the declared tool
        apply_tool(spec, tool, flange_site=robot.flange_site, tool_site=robot.tool_site)
    if tool_offset_m != 0.0:
        tcp = spec.site(robot.tool_site)
        if tcp is None:
            raise ModelError(f"{path} has no site {robot.tool_site!r}")
        tool_axis = np.array([0.0, 0.0, 1.0])
        tcp.pos = np.asarray(tcp.pos) + tool_offset_m * tool_axis
    if lost_motion:
        for name in robot.lost_motion_joints:
            joint = spec.joint(name)
            if joint is None:
                raise ModelError(f"{path} has no joint {name!r}")
            body = joint.parent
            lost = body.add_joint()
            lost.name = lost_joint_name(name)
            lost.type = mujoco.mjtJoint.mjJNT_HINGE
            lost.axis = joint.axis
            lost.pos = joint.pos
            # mujoco 4: joint stiffness/damping are [linear, quadratic, cubic] coefficients
            lost.stiffness = [LOST_MOTION_STIFFNESS_NM_PER_RAD, 0.0, 0.0]
            lost.damping = [1.0e-3 * LOST_MOTION_STIFFNESS_NM_PER_RAD, 0.0, 0.0]
            lost.armature = 1.0
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    try:
        return spec.compile()
    except Exception as exc:
        raise ModelError(
            f"cannot compile {path} with tool offset {tool_offset_m} m, lost motion {lost_motion}, tool {tool}: {exc}"
        ) from exc


def lost_motion_schedule(
    x_cmd_m: np.ndarray, direction: np.ndarray, dx_dq_sign: np.ndarray, lost_motion_rad: float, takeup_m: float
) -> np.ndarray:
    """Spring reference of the link-side hinges of the lost-motion joints along a commanded path.

    Args:
        x_cmd_m: Commanded tool x along the path [m], shape (n,).
        direction: Travel direction along x per sample (+1/-1), shape (n,).
        dx_dq_sign: Sign of d x_tcp / d q for each lost-motion joint at the working pose, shape (k,).
        lost_motion_rad: Half of the dead band [rad].
        takeup_m: Travel after a reversal over which the play is taken up [m].

    Returns:
        Reference angles [rad], shape (n, k): the link gives way along the process force, which opposes
        the travel direction, so the offset is -lost_motion * direction * sign(dx/dq), ramped over the
        take-up travel after each reversal.
    """
    n = len(x_cmd_m)
    ramp = np.ones(n)
    travelled = 0.0
    for i in range(1, n):
        if direction[i] != direction[i - 1]:
            travelled = 0.0
        travelled += abs(x_cmd_m[i] - x_cmd_m[i - 1])
        ramp[i] = min(1.0, travelled / takeup_m)
    # before the first reversal the play was taken up by the approach in the first direction
    first_reversal = np.flatnonzero(np.diff(direction) != 0)
    stop = int(first_reversal[0]) + 1 if first_reversal.size else n
    ramp[:stop] = 1.0
    # the level moves from the previous direction (-d) to the new one (+d) linearly: -d + 2 d ramp
    level = np.where(ramp >= 1.0, direction, direction * (2.0 * ramp - 1.0))
    return -lost_motion_rad * level[:, None] * np.asarray(dx_dq_sign, dtype=float)[None, :]


def load_model(
    scene: bool = True, path: str | Path | None = None, robot: str | Path | RobotDescription | None = None
) -> mujoco.MjModel:
    """Load a robot's cell scene (default) or its robot-only MJCF.

    Args:
        scene: True for the robot's scene (`cell/scene.xml`), False for its robot-only MJCF.
        path: Explicit MJCF file; overrides `scene`.
        robot: The robot (`twin.robot.description.load_robot`); None: the default robot.

    Raises:
        ModelError: If the file is missing or does not compile.
    """
    description = load_robot(robot) if path is None else None
    xml = Path(path) if path is not None else description.model_path(scene)  # type: ignore[union-attr]
    if not xml.is_file():
        raise ModelError(f"model file not found: {xml} (expected an MJCF file such as models/tx200.xml)")
    try:
        return compile_mjcf(xml, description)
    except ValueError as exc:
        raise ModelError(f"model {xml} does not compile: {exc}") from exc
