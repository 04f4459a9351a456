"""A robot from the user's own URDF or MJCF: what the twin needs is found by name, what is missing is an error or
an assumption the twin states.

`describe_model_file(path)` reads the file with MuJoCo (`mujoco.MjSpec`: a URDF's fixed links are kept as bodies),
takes the hinge joints in tree order as the arm (six, each with limits: a joint without limits is an error
naming it), and looks for the frames by the names robot descriptions use:

* the tool tip (required): a site `tcp`, else a body/link `tcp`, `tool_tip` or `tcp_link`;
* the F/T sensor (required): a site `ft_site`, else a body/link `ft_sensor`, `ft_frame` or `ft_link`;
* the flange: a site `attachment_site`, else a body/link `flange` or `tool0`; else the last arm body's origin
  (assumed);
* the joint springs: each arm joint's position actuator; where there is none, one of `ASSUMED_KQ_NM_PER_RAD`
  (assumed: identify K_q before trusting the deflections);
* the force sensor on the F/T site (added, assumed, where missing);
* the `home` keyframe: the model's; a URDF has none, so home is every joint at 0, or the middle of its range
  where 0 lies outside it (assumed: the sheet origin is the tool tip there, the tool turned down).

The completed model is written as MJCF beside a `tx200-twin-robot/1` description in a folder of the system's
temporary directory (named by the file's content), and read back like a shipped robot; the assumptions are
returned, and `load_robot` warns with each (`AssumptionWarning`).
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from pathlib import Path

import mujoco
import numpy as np

from twin.errors import ModelError

#: Joint spring assumed where a model has no position actuator [N·m/rad] (a heavy robot's order of magnitude).
ASSUMED_KQ_NM_PER_RAD = 1.0e6
ARM_JOINTS = 6
TOOL_NAMES = ("tcp", "tool_tip", "tcp_link")
FT_NAMES = ("ft_sensor", "ft_frame", "ft_link")
FLANGE_NAMES = ("flange", "tool0")


def _site_or_body(spec: mujoco.MjSpec, site: str, bodies: tuple[str, ...]) -> tuple[str | None, str | None]:
    """(an existing site's name, or a body to put one on) for a frame."""
    if any(s.name == site for s in spec.sites):
        return site, None
    for name in bodies:
        if spec.body(name) is not None:
            return None, name
    return None, None


def describe_model_file(path: str | Path) -> tuple[Path, list[str]]:
    """Complete a user's URDF or MJCF for the twin (module docstring).

    Returns:
        (the description file written, the assumptions made, one sentence each).

    Raises:
        ModelError: The file does not load, has not six limited hinge joints, or lacks a tool or F/T frame.
    """
    path = Path(path)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except (ValueError, OSError) as exc:
        raise ModelError(f"{path}: not a URDF or MJCF MuJoCo can read: {exc}") from None
    spec.compiler.fusestatic = False
    urdf = path.suffix.lower() == ".urdf"
    assumed: list[str] = []
    joints = [j for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_HINGE]
    if len(joints) != ARM_JOINTS:
        raise ModelError(f"{path}: the twin needs {ARM_JOINTS} hinge joints (the arm); found {len(joints)}: "
                         f"{[j.name for j in joints]}")
    unlimited = [j.name for j in joints if j.range[0] >= j.range[1]]
    if unlimited:
        raise ModelError(f"{path}: joint(s) {unlimited} have no limits; the twin needs every arm joint's range")
    frames = {}
    for role, site, bodies, required in (("tool", "tcp", TOOL_NAMES, True), ("ft", "ft_site", FT_NAMES, True),
                                         ("flange", "attachment_site", FLANGE_NAMES, False)):
        found, body = _site_or_body(spec, site, bodies)
        if found is None and body is None:
            if required:
                what = "tool frame (the tool tip)" if role == "tool" else "F/T sensor frame"
                raise ModelError(f"{path}: no {what}: expected a site {site!r} or a body/link named one of "
                                 f"{list(bodies)}")
            body = joints[-1].parent.name
            assumed.append(f"no flange frame: the flange is taken at the origin of the last arm body {body!r}")
        if found is None:
            spec.body(body).add_site(name=site)
        frames[role] = site
    if not any(s.type == mujoco.mjtSensor.mjSENS_FORCE and s.objname == "ft_site" for s in spec.sensors):
        spec.add_sensor(name="ft_force", type=mujoco.mjtSensor.mjSENS_FORCE, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname="ft_site")
        spec.add_sensor(name="ft_torque", type=mujoco.mjtSensor.mjSENS_TORQUE, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname="ft_site")
        assumed.append("no force sensor on the F/T site: one was added (ft_force, ft_torque)")
    driven = {a.target for a in spec.actuators}
    actuators = []
    for j in joints:
        if j.name not in driven:
            spec.add_actuator(name=f"{j.name}_spring", target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(
                kp=ASSUMED_KQ_NM_PER_RAD)
            assumed.append(f"joint {j.name!r} has no position actuator: a joint spring of "
                           f"{ASSUMED_KQ_NM_PER_RAD:.0e} N·m/rad was assumed (identify K_q)")
        actuators.append(j.name)
    if not any(k.name == "home" for k in spec.keys):
        q = np.array([0.0 if j.range[0] <= 0.0 <= j.range[1] else 0.5 * (j.range[0] + j.range[1]) for j in joints])
        model = spec.compile()
        qadr = np.array([model.jnt_qposadr[model.joint(j.name).id] for j in joints])
        turned, q, by = _tool_down(model, qadr, q, model.site(frames["tool"]).id)
        qpos = model.qpos0.copy()
        qpos[qadr] = q
        spec.add_key(name="home", qpos=qpos.tolist(), ctrl=q.tolist())
        how = "every joint at 0 (or mid-range)" + (
            "" if turned < 1e-3 else f", turned {turned:.0f} deg by {by} so the tool points down")
        assumed.append(f"no 'home' keyframe{' (a URDF has none)' if urdf else ''}: home is {how}, q = "
                       f"{np.degrees(q).round(1).tolist()} deg; the sheet origin is the tool tip there")
    try:
        spec.compile()
    except ValueError as exc:
        raise ModelError(f"{path}: the completed model does not compile: {exc}") from None
    if spec.meshdir:
        spec.meshdir = str((path.parent / spec.meshdir).resolve())
    elif any(spec.meshes):
        spec.meshdir = str(path.parent.resolve())
    xml = spec.to_xml()
    folder = Path(tempfile.gettempdir()) / "tx200-twin-robots" / (
        f"{path.stem}-{hashlib.sha256(path.read_bytes()).hexdigest()[:12]}")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "robot.xml").write_text(xml, encoding="utf-8")
    names = ", ".join(json.dumps(j.name) for j in joints)  # a TOML basic string is a JSON string: quotes escaped
    (folder / "robot.toml").write_text(
        f'format = "tx200-twin-robot/1"\nname = {json.dumps(path.stem)}\nvendor = "user"\n'
        f'model = {json.dumps(path.name)}\ncontroller = "unknown"\nlanguage = "unknown"\nmjcf = "robot.xml"\n'
        f'# generated from {json.dumps(str(path))}\n\n'
        f'[frames]\nflange_site = "attachment_site"\ntool_site = "tcp"\nft_site = "ft_site"\n'
        f'ft_force_sensor = "{_force_sensor(spec)}"\nhome_keyframe = "home"\n\n[joints]\nnames = [{names}]\n',
        encoding="utf-8",
    )
    return folder / "robot.toml", assumed


def _tool_down(model: mujoco.MjModel, qadr: np.ndarray, q0: np.ndarray,
               tcp: int) -> tuple[float, np.ndarray, str]:
    """(the turn [deg], joint angles [rad], what turned) that point the tool tip site's z axis straight down from
    `q0`: the twin forms with the tool down at home (`Kinematics.R_tool_down`), and a URDF's zero pose often points
    its tool forward (ROS-Industrial's tool0). Damped least squares on the wrist (the last three joints orient the
    tool), else on the whole arm, within the joints' limits; `q0` as it is where its tool already points down or
    neither gets it within 1 deg (the twin then holds the tool down from the home pose's heading, as before).
    """
    joint_ids = [j for j in range(model.njnt) if model.jnt_qposadr[j] in set(qadr.tolist())]
    dofs = np.array([model.jnt_dofadr[j] for j in joint_ids])
    low, high = model.jnt_range[joint_ids].T
    data = mujoco.MjData(model)
    jac = np.zeros((3, model.nv))
    down = np.array([0.0, 0.0, -1.0])

    def tool_axis(q: np.ndarray) -> np.ndarray:
        data.qpos[qadr] = q
        mujoco.mj_kinematics(model, data)
        return data.site_xmat[tcp].reshape(3, 3)[:, 2].copy()

    if tool_axis(q0) @ down > np.cos(np.radians(1e-3)):
        return 0.0, q0, "nothing"
    for moving, by in ((np.arange(ARM_JOINTS - 3, ARM_JOINTS), "the wrist"), (np.arange(ARM_JOINTS), "the arm")):
        q = q0.astype(float).copy()
        for _ in range(200):
            z = tool_axis(q)
            error = np.cross(z, down)  # the rotation that takes z to down (axis times sine)
            if z @ down < 0.0 and np.linalg.norm(error) < 1e-6:  # pointing straight up: turn about any axis
                error = np.cross(z, np.array([1.0, 0.0, 0.0]))
            if np.linalg.norm(error) < 1e-12 and z @ down > 0.0:
                break
            mujoco.mj_comPos(model, data)
            mujoco.mj_jacSite(model, data, None, jac, tcp)
            J = jac[:, dofs[moving]]
            step = J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(3), error)
            q[moving] = np.clip(q[moving] + np.clip(step, -0.3, 0.3), low[moving], high[moving])
        if tool_axis(q) @ down > np.cos(np.radians(1.0)):
            return float(np.degrees(np.linalg.norm(q - q0))), q, by
    return 0.0, q0, "nothing"


def _force_sensor(spec: mujoco.MjSpec) -> str:
    """The force sensor on the F/T site."""
    return next(s.name for s in spec.sensors if s.type == mujoco.mjtSensor.mjSENS_FORCE and s.objname == "ft_site")
