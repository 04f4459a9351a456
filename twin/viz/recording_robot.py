"""The robot in a rerun recording: MuJoCo geoms as static meshes, body poses on the timeline."""

from __future__ import annotations

import mujoco
import numpy as np
import rerun as rr
import trimesh

from twin.errors import InputError

COLLISION_GROUP = 3  # menagerie convention: visual geoms group 2, collision geoms group 3
TIMELINE = "sim_time"


def _quat_wxyz_to_xyzw(q: np.ndarray) -> np.ndarray:
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def _geom_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    mat = int(model.geom_matid[geom])
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[geom]
    return np.clip(np.round(np.asarray(rgba) * 255), 0, 255).astype(np.uint8)


def geom_mesh(model: mujoco.MjModel, geom: int) -> trimesh.Trimesh | None:
    """Triangle mesh of one geom in its body's frame [m] (None for planes, height fields, SDFs).

    Mesh geoms take `mesh_vert`/`mesh_face`; boxes, spheres, ellipsoids, capsules and cylinders are
    tessellated with `trimesh.creation`; the result is placed by `geom_pos`/`geom_quat`.
    """
    gtype = int(model.geom_type[geom])
    size = model.geom_size[geom]
    types = mujoco.mjtGeom
    if gtype == types.mjGEOM_MESH:
        mesh_id = int(model.geom_dataid[geom])
        v0, nv = int(model.mesh_vertadr[mesh_id]), int(model.mesh_vertnum[mesh_id])
        f0, nf = int(model.mesh_faceadr[mesh_id]), int(model.mesh_facenum[mesh_id])
        mesh = trimesh.Trimesh(
            model.mesh_vert[v0 : v0 + nv].copy(), model.mesh_face[f0 : f0 + nf].copy(), process=False
        )
    elif gtype == types.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2.0 * size[:3])
    elif gtype == types.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif gtype == types.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size[:3])
    elif gtype == types.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[16, 8])
    elif gtype == types.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=24)
    else:
        return None
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.geom_quat[geom])
    transform = np.eye(4)
    transform[:3, :3] = rot.reshape(3, 3)
    transform[:3, 3] = model.geom_pos[geom]
    mesh.apply_transform(transform)
    return mesh


def _name(model: mujoco.MjModel, obj: str, index: int) -> str:
    name = mujoco.mj_id2name(model, getattr(mujoco.mjtObj, f"mjOBJ_{obj.upper()}"), index)
    return rr.escape_entity_path_part(name) if name else f"{obj}{index}"


def log_robot_geometry(rec: rr.RecordingStream, model: mujoco.MjModel, prefix: str = "") -> None:
    """Log every body's visual geoms once (static) at `<prefix>world/robot/<body>/<geom>`, body frame [m]."""
    for geom in range(model.ngeom):
        if int(model.geom_group[geom]) == COLLISION_GROUP or model.geom_rgba[geom][3] == 0.0:
            continue
        mesh = geom_mesh(model, geom)
        if mesh is None:
            continue
        body = int(model.geom_bodyid[geom])
        rec.log(
            f"{prefix}world/robot/{_name(model, 'body', body)}/{_name(model, 'geom', geom)}",
            rr.Mesh3D(
                vertex_positions=np.asarray(mesh.vertices, dtype=np.float32),
                triangle_indices=np.asarray(mesh.faces, dtype=np.uint32),
                vertex_normals=np.asarray(mesh.vertex_normals, dtype=np.float32),
                albedo_factor=_geom_rgba(model, geom),
            ),
            static=True,
        )


def log_body_poses(
    rec: rr.RecordingStream, model: mujoco.MjModel, t_s: np.ndarray, qpos: np.ndarray, prefix: str = ""
) -> None:
    """Log the pose of every body at each sample (columns on `sim_time`); world-welded bodies once, static.

    Args:
        rec: Open recording.
        model: Compiled model whose `nq` matches `qpos`.
        t_s: Sample times [s], shape (n,).
        qpos: Joint positions [rad], shape (n, nq).
        prefix: Entity prefix ("" or "name/").
    """
    qpos = np.asarray(qpos, dtype=float)
    if len(t_s) == 0:
        raise InputError("no samples to log; expected at least one")
    if qpos.ndim != 2 or qpos.shape[1] != model.nq or qpos.shape[0] != len(t_s):
        raise InputError(
            f"qpos has shape {qpos.shape}, the model expects ({len(t_s)}, {model.nq}): pass the twin's own "
            "model (Twin.model) when it carries extra joints"
        )
    data = mujoco.MjData(model)
    xpos = np.zeros((len(t_s), model.nbody, 3))
    xquat = np.zeros((len(t_s), model.nbody, 4))
    for i, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        xpos[i], xquat[i] = data.xpos, data.xquat
    quat_xyzw = _quat_wxyz_to_xyzw(xquat)
    times = [rr.TimeColumn(TIMELINE, duration=np.asarray(t_s, dtype=float))]
    for body in range(1, model.nbody):
        entity = f"{prefix}world/robot/{_name(model, 'body', body)}"
        if int(model.body_weldid[body]) == 0:
            rec.log(
                entity, rr.Transform3D(translation=xpos[0, body], quaternion=quat_xyzw[0, body]), static=True
            )
            continue
        rec.send_columns(
            entity,
            indexes=times,
            columns=rr.Transform3D.columns(translation=xpos[:, body], quaternion=quat_xyzw[:, body]),
        )
