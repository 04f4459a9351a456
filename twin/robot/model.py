"""Robot-side effects and the compiled MuJoCo model that carries them.

The twin and the virtual lab share one mechanism for physical effects on the robot: a `RobotEffects`
record that `build_model` turns into an augmented MJCF through `mujoco.MjSpec`. The lab switches effects
on as hidden truth; the discrepancy workflow fits them and adds them to the twin the same way.

Effects on the robot:
- `lost_motion_rad`: direction-dependent lost motion (backlash) in joints 2 and 3. MuJoCo's double-hinge
  pattern: each of these joints gets a second, link-side hinge on the same axis (`joint2_lost`,
  `joint3_lost`) with a very stiff spring whose reference angle is switched by the travel direction:
  +/- `lost_motion_rad`, signed so the link gives way in the direction the process (friction and
  ploughing) force pushes it. After a reversal the play is taken up linearly over
  `lost_motion_takeup_m` of travel. The tool therefore lags differently going forward and backward and
  shows a distortion at the start of each stroke, as the thesis saw (sec. 3.3.1).
- `tcp_offset_m`: tool-length error: the real tool tip lies `tcp_offset_m` further along the tool axis
  than the nominal 274.94 mm the path was computed with (the controller still uses the nominal length).
- `force_scale`: the sheet's real forces are `force_scale` times the FE history; the simulator fits its field to
  the scaled history (the field's penetration sensitivity, a property of the sheet, is not scaled).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from twin.base.resources import robot_xml, scene_xml
from twin.errors import InputError, ModelError

ARM_JOINTS: tuple[str, ...] = tuple(f"joint{i}" for i in range(1, 7))
LOST_MOTION_JOINTS: tuple[str, ...] = ("joint2", "joint3")
LOST_MOTION_STIFFNESS_NM_PER_RAD = 1.0e9  # stiff enough that the link-side hinge is a pure offset


@dataclass(frozen=True)
class RobotEffects:
    """Physical effects on the robot and the process, applied on top of the nominal twin.

    Attributes:
        lost_motion_rad: Lost motion of joints 2 and 3, half of the dead band [rad].
        lost_motion_takeup_m: Travel after a reversal over which the play is taken up [m].
        tcp_offset_m: Real tool tip minus nominal, along the tool axis [m].
        force_scale: Real sheet forces divided by the FE history's [-].
    """

    lost_motion_rad: float = 0.0
    lost_motion_takeup_m: float = 0.002
    tcp_offset_m: float = 0.0
    force_scale: float = 1.0

    def __post_init__(self) -> None:
        values = {
            "lost_motion_rad": self.lost_motion_rad,
            "lost_motion_takeup_m": self.lost_motion_takeup_m,
            "tcp_offset_m": self.tcp_offset_m,
            "force_scale": self.force_scale,
        }
        for name, value in values.items():
            if not np.isfinite(value):
                raise InputError(f"RobotEffects.{name} = {value!r}, expected a finite number")
        if self.lost_motion_takeup_m <= 0.0:
            raise InputError(f"lost_motion_takeup_m = {self.lost_motion_takeup_m!r} m, expected > 0")
        if self.force_scale < 0.0:
            raise InputError(f"force_scale = {self.force_scale!r}, expected >= 0")

    @property
    def changes_model(self) -> bool:
        """Whether the compiled robot differs from the nominal one (`force_scale` acts on the field only)."""
        return self.has_lost_motion or self.tcp_offset_m != 0.0

    @property
    def has_lost_motion(self) -> bool:
        """Whether the model needs the link-side hinges of joints 2 and 3."""
        return self.lost_motion_rad != 0.0


def build_model(effects: RobotEffects | None = None, *, scene: bool = True) -> mujoco.MjModel:
    """Compile the TX200 model (scene or robot only) with the robot-side effects added through MjSpec.

    The compiled model depends only on the tool length offset and whether lost-motion hinges are present (the
    other effects act through the field or the springs' references), so each such variant is compiled once
    per process and handed out as a private copy (a copy costs 0.6 ms, a compile 28 ms; the discrepancy search
    builds a twin per replay).

    Args:
        effects: Effects to add; None means the nominal twin.
        scene: Compile `cell/scene.xml` (True) or the robot-only `tx200.xml` (False).

    Returns:
        The compiled model, the caller's own (its springs and friction may be changed). Contacts are disabled:
        the sheet acts through the force field.

    Raises:
        ModelError: If the model file is missing or does not compile.
    """
    effects = effects or RobotEffects()
    path = scene_xml() if scene else robot_xml()
    # a recalibrated model file is recompiled; a missing one reaches the compile, which names it
    stamps = tuple(p.stat().st_mtime_ns if p.is_file() else -1 for p in (path, robot_xml()))
    key = (str(path), stamps, effects.tcp_offset_m, effects.has_lost_motion)
    if key not in _COMPILED:
        _COMPILED[key] = _compile(path, effects)
    return copy.copy(_COMPILED[key])


_COMPILED: dict[tuple[str, tuple[int, ...], float, bool], mujoco.MjModel] = {}


def _compile(path: Path, effects: RobotEffects) -> mujoco.MjModel:
    """Compile `path` with the model-changing effects (`build_model`)."""
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # mujoco raises ValueError with the parser's message
        raise ModelError(f"cannot load {path}: {exc}") from exc
    if effects.tcp_offset_m != 0.0:
        tcp = spec.site("tcp")
        if tcp is None:
            raise ModelError(f"{path} has no site 'tcp'")
        tool_axis = np.array([0.0, 0.0, 1.0])
        tcp.pos = np.asarray(tcp.pos) + effects.tcp_offset_m * tool_axis
    if effects.has_lost_motion:
        for name in LOST_MOTION_JOINTS:
            joint = spec.joint(name)
            if joint is None:
                raise ModelError(f"{path} has no joint {name!r}")
            body = joint.parent
            lost = body.add_joint()
            lost.name = f"{name}_lost"
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
        raise ModelError(f"cannot compile {path} with {effects}: {exc}") from exc


def lost_motion_schedule(
    x_cmd_m: np.ndarray, direction: np.ndarray, dx_dq_sign: np.ndarray, effects: RobotEffects
) -> np.ndarray:
    """Spring reference of the link-side hinges of joints 2 and 3 along a commanded path.

    Args:
        x_cmd_m: Commanded tool x along the path [m], shape (n,).
        direction: Travel direction along x per sample (+1/-1), shape (n,).
        dx_dq_sign: Sign of d x_tcp / d q for joints 2 and 3 at the working pose, shape (2,).
        effects: The effects; only `lost_motion_*` are used.

    Returns:
        Reference angles [rad], shape (n, 2): the link gives way along the process force, which opposes
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
        ramp[i] = min(1.0, travelled / effects.lost_motion_takeup_m)
    # before the first reversal the play was taken up by the approach in the first direction
    first_reversal = np.flatnonzero(np.diff(direction) != 0)
    stop = int(first_reversal[0]) + 1 if first_reversal.size else n
    ramp[:stop] = 1.0
    # the level moves from the previous direction (-d) to the new one (+d) linearly: -d + 2 d ramp
    level = np.where(ramp >= 1.0, direction, direction * (2.0 * ramp - 1.0))
    return -effects.lost_motion_rad * level[:, None] * np.asarray(dx_dq_sign, dtype=float)[None, :]
