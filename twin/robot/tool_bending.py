"""The tool's own bending: a cantilever clamped at the flange, as two spring hinges in the MuJoCo model.

A long tool bends under the in-plane force: a 300 mm steel shank of Ø25 mm yields ~0.7 mm at 300 N at its tip. The
cell declares either the shank (`[tool] diameter_mm`, `youngs_modulus_gpa`) or the stiffness measured at the tip
(`[tool] bending_stiffness_n_per_mm`), and `ToolSpec.bending_stiffness_n_per_m` carries the tip stiffness k:

- from the shank, Euler-Bernoulli's cantilever under a tip load: k = 3 E I / L³, I = π d⁴ / 64, L the tool length
  (flange to tip; `cantilever_tip_stiffness`);
- in the model (`add_bending`, called by `twin.robot.tool.apply_tool`): the tool body's mass and the tip site move
  to a child body `BENDING_BODY` whose frame is the flange's, hung on two hinges about the flange x and y axes
  (`BENDING_JOINTS`), each a spring of k_θ = k L² [N·m/rad] with reference 0. A force F across the tool at the tip
  turns a hinge by F L / k_θ, so the tip moves F / k: the cantilever's tip deflection (its slope there, 1.5x the
  hinge's, is not modelled; the tip position is what the forming sees). Along the tool axis the hinges give nothing
  (the shank's axial stiffness, ~πd²E/4L ~ 3e8 N/m, is two orders above the robot's).
- the F/T sensor site stays on the tool body above the hinges: the sensor is clamped above the bending, and its
  reading (the force through the tool body, its subtree included) is the rigid tool's at the same load.

The hinges' angles are the tool's bending only: kinematics and IK use the rigid tool (hinges at 0). The quasi-static
twin adds k_θ to its stiffness diagonal (`twin.sim.quasi_static`); the dynamic plant damps them
(`twin.lab.dynamic.plant`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from twin.errors import InputError, ModelError
from twin.robot.facts import RobotDescription

if TYPE_CHECKING:
    import mujoco

#: Young's modulus of a steel tool when the cell gives none [GPa]: EN 1993-1-1 (Eurocode 3) §3.2.6, E = 210 000
#: N/mm² for structural steel (tool steels lie at 190-215 GPa).
STEEL_YOUNGS_MODULUS_GPA = 210.0
#: The body that carries the bending tool's mass and tip, and its two hinges (about the flange x and y axes).
BENDING_BODY = "tool_bending"
BENDING_JOINTS = ("tool_bend_x", "tool_bend_y")
#: Damping of the tool's own bending mode in a dynamic model, as a ratio of critical (`damp_bending`): a steel shank
#: in a clamped holder rings at 1-5 % (joint friction of the clamp dominates the material's ~0.1 %).
BENDING_DAMPING_RATIO = 0.05
#: The most ω·dt of the tool's mode a time-stepped model keeps (`damp_bending`): MuJoCo integrates a joint spring
#: explicitly (stable to ω·dt < 2); at 1 there are 6 steps a period.
BENDING_OMEGA_DT_MAX = 1.0


def cantilever_tip_stiffness(diameter_m: float, youngs_modulus_pa: float, length_m: float) -> float:
    """Tip stiffness of a round shank clamped at one end, k = 3 E I / L³ with I = π d⁴ / 64 [N/m].

    Args:
        diameter_m: The shank's diameter d [m].
        youngs_modulus_pa: Its Young's modulus E [Pa].
        length_m: Clamp (the flange) to the tip, L [m].

    Raises:
        InputError: A value not finite and positive.
    """
    for name, value in (("diameter_m", diameter_m), ("youngs_modulus_pa", youngs_modulus_pa),
                        ("length_m", length_m)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
            raise InputError(f"cantilever_tip_stiffness: {name} = {value!r}: expected a positive finite number")
    second_moment = math.pi * diameter_m**4 / 64.0
    return 3.0 * youngs_modulus_pa * second_moment / length_m**3


def hinge_stiffness(tip_stiffness_n_per_m: float, length_m: float) -> float:
    """k_θ = k L² [N·m/rad]: the hinge at the flange whose tip deflection under a tip force is the cantilever's."""
    return tip_stiffness_n_per_m * length_m * length_m


def add_bending(spec: mujoco.MjSpec, holder: mujoco.MjsBody, tcp: mujoco.MjsSite, R_holder_flange: np.ndarray,
                p_holder_flange: np.ndarray, length_m: float, tip_stiffness_n_per_m: float) -> None:
    """Hang the tool's mass and tip on the bending hinges (module docstring), in place.

    Args:
        spec: The model being edited.
        holder: The tool body (the F/T site's): it keeps its sites but no mass.
        tcp: The tool tip site, on `holder`, at its final position.
        R_holder_flange, p_holder_flange: The flange frame in `holder`'s frame (rotation, origin [m]).
        length_m: Flange to tool tip [m].
        tip_stiffness_n_per_m: The tool's bending stiffness at the tip [N/m].

    Raises:
        ModelError: The model already has the bending body, or its tool body's inertia cannot be read.
    """
    import mujoco

    if spec.body(BENDING_BODY) is not None:
        raise ModelError(f"the model already has a body {BENDING_BODY!r}: cannot add the tool's bending twice")
    mass, ipos, R_inertia, inertia = _holder_inertial(spec, holder)
    bend = holder.add_body()
    bend.name = BENDING_BODY
    bend.pos = p_holder_flange
    bend.quat = _quat(R_holder_flange)
    k_theta = hinge_stiffness(tip_stiffness_n_per_m, length_m)
    for name, axis in zip(BENDING_JOINTS, ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), strict=True):
        hinge = bend.add_joint()
        hinge.name, hinge.type, hinge.axis, hinge.pos = name, mujoco.mjtJoint.mjJNT_HINGE, axis, [0.0, 0.0, 0.0]
        hinge.stiffness = [k_theta, 0.0, 0.0]  # mujoco 4: [linear, quadratic, cubic]
        hinge.springref = 0.0
        hinge.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    # the holder's mass, as it is (in the flange frame now), hangs below the hinges
    bend.explicitinertial = True
    bend.mass = mass
    bend.ipos = R_holder_flange.T @ (ipos - p_holder_flange)
    bend.iquat = _quat(R_holder_flange.T @ R_inertia)
    bend.inertia = inertia
    holder.explicitinertial = True
    holder.mass, holder.ipos, holder.iquat, holder.inertia = 0.0, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0] * 3
    # the tip site moves onto the bending body (MuJoCo re-parents no site: a copy under the same name)
    R_tcp = R_holder_flange.T @ _matrix(np.asarray(tcp.quat, dtype=float))
    pos = R_holder_flange.T @ (np.asarray(tcp.pos, dtype=float) - p_holder_flange)
    copy = {"name": tcp.name, "type": tcp.type, "size": np.array(tcp.size), "group": tcp.group,
            "rgba": np.array(tcp.rgba), "material": tcp.material, "userdata": list(tcp.userdata)}
    spec.delete(tcp)
    site = bend.add_site(**copy)
    site.pos, site.quat = pos, _quat(R_tcp)


def bending_dofs(model: mujoco.MjModel) -> np.ndarray:
    """The dof addresses of the tool's bending hinges in `model` (empty without a bending tool)."""
    import mujoco

    out = []
    for name in BENDING_JOINTS:
        joint = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if joint >= 0:
            out.append(int(model.jnt_dofadr[joint]))
    return np.array(out, dtype=int)


def bending_compliance(model: mujoco.MjModel, data: mujoco.MjData, site: int) -> np.ndarray:
    """The tool's own compliance at `site` at the pose in `data` (`mj_kinematics` done), J_b k_θ⁻¹ J_bᵀ [m/N], (3, 3):
    (I − z zᵀ) / k for the tool axis z; zeros without a bending tool."""
    import mujoco

    dofs = bending_dofs(model)
    if not dofs.size:
        return np.zeros((3, 3))
    mujoco.mj_comPos(model, data)  # the Jacobian reads the dofs' motion axes
    jacp = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jacp, None, site)
    J = jacp[:, dofs]
    k_theta = model.jnt_stiffness[model.dof_jntid[dofs]]
    return (J / k_theta) @ J.T


def damp_bending(model: mujoco.MjModel, timestep_s: float, ratio: float = BENDING_DAMPING_RATIO,
                 omega_dt_max: float = BENDING_OMEGA_DT_MAX) -> dict[str, float]:
    """Give the bending hinges of a compiled model a damping of `ratio` of critical on the tool's own mode, in place.

    The mode is the tool swinging on one hinge with the arm held, ω = √(k_θ / M_ii) (M_ii the tool's inertia about
    the hinge, pose-independent: it is the rigid subtree below). Where ω·dt exceeds `omega_dt_max` the hinge gets
    armature, so that the mode slows to ω·dt = `omega_dt_max` (the static deflection is k_θ's alone; the mode,
    above the step's resolution anyway, is then lower than the tool's). Damping c = 2 ratio √(k_θ (M_ii + armature)).

    Returns:
        The tool's mode [Hz], the mode kept [Hz], the armature added [kg m²] and the damping [N·m·s/rad] (the
        hinges'; the two are equal but for an off-axis centre of gravity, the largest given); empty without a
        bending tool.
    """
    import mujoco

    dofs = bending_dofs(model)
    if not dofs.size:
        return {}
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    out: dict[str, float] = {}
    for dof in dofs:
        k_theta = float(model.jnt_stiffness[model.dof_jntid[dof]])
        inertia = float(M[dof, dof] - model.dof_armature[dof])
        omega = math.sqrt(k_theta / inertia)
        armature = max(0.0, k_theta * (timestep_s / omega_dt_max) ** 2 - inertia)
        model.dof_armature[dof] = armature
        model.dof_damping[dof] = 2.0 * ratio * math.sqrt(k_theta * (inertia + armature))
        kept = math.sqrt(k_theta / (inertia + armature))
        if omega / (2.0 * math.pi) > out.get("mode_hz", 0.0):
            out = {"mode_hz": omega / (2.0 * math.pi), "mode_kept_hz": kept / (2.0 * math.pi),
                   "armature_kg_m2": armature, "damping_nms_per_rad": float(model.dof_damping[dof])}
    return out


def bending_compliance_at(model: mujoco.MjModel, robot: RobotDescription, q: np.ndarray) -> np.ndarray:
    """`bending_compliance` at the tool tip with the arm at `q` [rad] and the hinges at 0 [m/N], (3, 3)."""
    import mujoco

    if not bending_dofs(model).size:
        return np.zeros((3, 3))
    data = mujoco.MjData(model)
    data.qpos[robot.addresses(model).qpos] = q
    mujoco.mj_kinematics(model, data)
    return bending_compliance(model, data, model.site(robot.tool_site).id)


def _holder_inertial(spec: mujoco.MjSpec, holder: mujoco.MjsBody) -> tuple[float, np.ndarray, np.ndarray,
                                                                          np.ndarray]:
    """The tool body's mass [kg], centre of mass [m], principal axes and inertia [kg m²], in its own frame: as
    declared, else (from its geoms, or a full inertia) as the compiler makes it."""
    if holder.explicitinertial and not np.isfinite(holder.fullinertia[0]):
        return (float(holder.mass), np.asarray(holder.ipos, dtype=float), _matrix(np.asarray(holder.iquat)),
                np.asarray(holder.inertia, dtype=float))
    try:
        model = spec.compile()
    except Exception as exc:
        raise ModelError(f"cannot read the tool body {holder.name!r}'s inertia for its bending: {exc}") from exc
    b = model.body(holder.name).id
    return (float(model.body_mass[b]), model.body_ipos[b].copy(), _matrix(model.body_iquat[b]),
            model.body_inertia[b].copy())


def _matrix(quat: np.ndarray) -> np.ndarray:
    import mujoco

    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(quat, dtype=float) / np.linalg.norm(quat))
    return out.reshape(3, 3)


def _quat(R: np.ndarray) -> np.ndarray:
    import mujoco

    out = np.zeros(4)
    mujoco.mju_mat2Quat(out, np.ascontiguousarray(R, dtype=float).reshape(-1))
    return out
