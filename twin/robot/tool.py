"""The tool on the flange, as a user declares it (`ToolSpec`), and the MJCF edit that puts it on a robot model.

A robot's MJCF carries its own tool: a body whose site (`RobotDescription.tool_site`) is the tool tip, hanging at
the flange (on the shipped robots through the F/T sensor body). A declared tool replaces it in the compiled model
(`apply_tool`, through `mujoco.MjSpec`):

- the tip site moves to `length_m` along the flange z axis (the direction of the model's own tool tip, which is
  the flange z on every shipped robot), so FK, IK, the Jacobian and the compliance at the tip are the declared
  tool's;
- with a mass, the declared mass is all that hangs below the flange (the cell file's `mass_kg`, F/T sensor
  included): the tool body carries it at the declared centre of gravity (default: half way along the tool), with
  the inertia of a uniform solid cylinder of the tool's length and `INERTIA_RADIUS_M` about the tool axis; the
  bodies between the flange and the tool body (the F/T sensor's) are made massless, so the gravity load on the
  joints is the declared tool's. The F/T sensor keeps its frame (its reading is tared, `twin.sim.ft_sensor`);
- with a bending stiffness, the tool bends as a cantilever clamped at the flange: its mass and tip hang on two
  spring hinges at the flange (`twin.robot.tool_bending`), below the F/T sensor.

None (no tool declared) leaves the model exactly as its MJCF is.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from twin.errors import InputError, ModelError

if TYPE_CHECKING:  # MuJoCo only when a model is built: the CLI's parser imports specs
    import mujoco

#: The radius of the solid cylinder whose inertia a declared tool's mass takes [m]: the shipped tool holder's.
INERTIA_RADIUS_M = 0.03


class ToolSpec(NamedTuple):
    """A tool on the flange, as declared (module docstring); build with `ToolSpec.make` to validate.

    Attributes:
        length_m: Flange to tool tip along the flange z axis [m].
        mass_kg: All the mass hanging below the flange (tool and F/T sensor) [kg]; None: the robot model's bodies.
        cog_m: Its centre of gravity in the flange frame [m]; None: half way along the tool (with a mass).
        bending_stiffness_n_per_m: The tool's own bending stiffness at its tip, across its axis [N/m]
            (`twin.robot.tool_bending`); None: a rigid tool.
    """

    length_m: float
    mass_kg: float | None = None
    cog_m: tuple[float, float, float] | None = None
    bending_stiffness_n_per_m: float | None = None

    @classmethod
    def make(cls, length_m: float, mass_kg: float | None = None,
             cog_m: Sequence[float] | None = None, bending_stiffness_n_per_m: float | None = None) -> ToolSpec:
        """A validated tool: a positive finite length, a non-negative finite mass, a finite 3-vector centre of
        gravity (only with a mass), a positive finite bending stiffness.

        Raises:
            InputError: A value out of these bounds (naming it).
        """
        length = _finite(length_m, "length_m")
        if length <= 0.0:
            raise InputError(f"ToolSpec.length_m = {length_m!r}: expected a positive length [m]")
        mass = None if mass_kg is None else _finite(mass_kg, "mass_kg")
        if mass is not None and mass < 0.0:
            raise InputError(f"ToolSpec.mass_kg = {mass_kg!r}: expected a non-negative mass [kg]")
        cog = None
        if cog_m is not None:
            if mass is None:
                raise InputError("ToolSpec.cog_m without mass_kg: a centre of gravity needs the tool's mass")
            values = [_finite(v, "cog_m") for v in cog_m]
            if len(values) != 3:
                raise InputError(f"ToolSpec.cog_m = {cog_m!r}: expected three numbers [m]")
            cog = (values[0], values[1], values[2])
        bending = None if bending_stiffness_n_per_m is None else _finite(bending_stiffness_n_per_m,
                                                                        "bending_stiffness_n_per_m")
        if bending is not None and bending <= 0.0:
            raise InputError(f"ToolSpec.bending_stiffness_n_per_m = {bending_stiffness_n_per_m!r}: expected a "
                             "positive stiffness [N/m]")
        return cls(length, mass, cog, bending)

    @property
    def rigid(self) -> ToolSpec:
        """This tool without its bending: the controller's and the kinematics' nominal tool."""
        return self._replace(bending_stiffness_n_per_m=None)

    @property
    def cog(self) -> np.ndarray:
        """The centre of gravity in the flange frame [m]: the declared one, else half way along the tool."""
        return np.array(self.cog_m) if self.cog_m is not None else np.array([0.0, 0.0, self.length_m / 2.0])

    def to_json(self) -> dict[str, object]:
        """The tool as a model file records it (millimetres, as the cell file)."""
        out: dict[str, object] = {"length_mm": round(1e3 * self.length_m, 12)}
        if self.mass_kg is not None:
            out["mass_kg"] = self.mass_kg
        if self.cog_m is not None:
            out["cog_mm"] = [round(1e3 * v, 12) for v in self.cog_m]
        if self.bending_stiffness_n_per_m is not None:
            out["bending_stiffness_n_per_mm"] = round(self.bending_stiffness_n_per_m / 1e3, 12)
        return out


def _finite(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"ToolSpec.{name} = {value!r}: expected a finite number")
    return float(value)


def apply_tool(spec: mujoco.MjSpec, tool: ToolSpec, *, flange_site: str, tool_site: str) -> None:
    """Put `tool` on the model `spec` in place of its own (module docstring).

    Raises:
        ModelError: The model lacks the flange or tool site, or the tool body does not hang below the flange's body.
    """
    flange, tcp = spec.site(flange_site), spec.site(tool_site)
    if flange is None or tcp is None:
        raise ModelError(f"the model has no site {flange_site if flange is None else tool_site!r}: cannot put the "
                         "declared tool on it")
    # the flange body's frame -> each body down to the tool body (no joints between: the tool hangs rigidly)
    chain: list[mujoco.MjsBody] = []
    body = tcp.parent
    while body is not None and body.name != flange.parent.name:
        if body.joints:
            raise ModelError(f"the tool body {tcp.parent.name!r} hangs on a joint below the flange: cannot put the "
                             "declared tool on it")
        chain.append(body)
        body = body.parent
    if body is None:
        raise ModelError(f"the tool site {tool_site!r} is not below the flange site {flange_site!r}'s body")
    # pose of the tool body in the flange body's frame
    R, p = np.eye(3), np.zeros(3)
    for b in reversed(chain):
        R_b = _body_rotation(b)
        p = p + R @ np.asarray(b.pos, dtype=float)
        R = R @ R_b
    R_fl = _site_rotation(flange)
    p_fl = np.asarray(flange.pos, dtype=float)
    old_tip = R_fl.T @ (p + R @ np.asarray(tcp.pos, dtype=float) - p_fl)
    axis = old_tip / np.linalg.norm(old_tip) if np.linalg.norm(old_tip) > 1e-9 else np.array([0.0, 0.0, 1.0])

    def in_tool_body(x_flange: np.ndarray) -> np.ndarray:  # a point of the flange frame in the tool body's frame
        return R.T @ (p_fl + R_fl @ x_flange - p)

    tcp.pos = in_tool_body(tool.length_m * axis)
    if tool.mass_kg is None and tool.bending_stiffness_n_per_m is None:
        return
    if not chain:
        raise ModelError(f"the tool site {tool_site!r} sits on the flange's own body: a declared tool mass or "
                         "bending needs a tool body")
    if tool.mass_kg is not None:
        _put_mass(tool, chain, R, R_fl, in_tool_body)
    if tool.bending_stiffness_n_per_m is not None:
        from twin.robot.tool_bending import add_bending

        # the flange frame in the tool body's frame, the bending about its x and y axes (the tip along its z)
        R_flange = R.T @ R_fl @ _axis_frame(axis)
        add_bending(spec, chain[0], tcp, R_flange, in_tool_body(np.zeros(3)), tool.length_m,
                    tool.bending_stiffness_n_per_m)


def _axis_frame(axis: np.ndarray) -> np.ndarray:
    """A frame in the flange's whose z is the tool axis (the flange's own where the tool lies along its z)."""
    z = axis / np.linalg.norm(axis)
    if np.allclose(z, [0.0, 0.0, 1.0], atol=1e-12):
        return np.eye(3)
    x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _put_mass(tool: ToolSpec, chain: list[mujoco.MjsBody], R: np.ndarray, R_fl: np.ndarray,
              in_tool_body: Callable[[np.ndarray], np.ndarray]) -> None:
    """The declared mass into the tool body (`chain[0]`), the bodies between it and the flange massless."""
    import mujoco

    assert tool.mass_kg is not None
    for b in chain[1:]:  # the bodies between the flange and the tool body: the declared mass includes them
        b.explicitinertial = True
        b.mass, b.ipos, b.inertia = 0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    holder = chain[0]
    m, L, r = tool.mass_kg, tool.length_m, INERTIA_RADIUS_M
    transverse = m * (3.0 * r * r + L * L) / 12.0
    holder.explicitinertial = True
    holder.mass = m
    holder.ipos = in_tool_body(tool.cog)
    # principal axes: the flange frame's, turned into the tool body's frame
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, (R.T @ R_fl).reshape(-1))
    holder.iquat = quat
    holder.inertia = [transverse, transverse, m * r * r / 2.0]


def _quat_matrix(quat: Sequence[float]) -> np.ndarray:
    import mujoco

    out = np.zeros(9)
    q = np.asarray(quat, dtype=float)
    mujoco.mju_quat2Mat(out, q / np.linalg.norm(q))
    return out.reshape(3, 3)


def _body_rotation(body: mujoco.MjsBody) -> np.ndarray:
    import mujoco

    if body.alt.type != mujoco.mjtOrientation.mjORIENTATION_QUAT:
        raise ModelError(f"body {body.name!r}: only a quaternion orientation is read for a declared tool")
    return _quat_matrix(body.quat)


def _site_rotation(site: mujoco.MjsSite) -> np.ndarray:
    import mujoco

    if site.alt.type != mujoco.mjtOrientation.mjORIENTATION_QUAT:
        raise ModelError(f"site {site.name!r}: only a quaternion orientation is read for a declared tool")
    return _quat_matrix(site.quat)
