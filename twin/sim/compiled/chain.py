"""The robot's hinge chain for the compiled replay: MuJoCo's own model parameters, evaluated in compiled code.

`chain_arrays` copies what `mj_kinematics`, `mj_jacSite` and `mj_rne` (at rest) read from the compiled
`MjModel` — body offsets and orientations, hinge axes and anchors, body masses and centres of mass, the
site's offset, gravity — into flat arrays. `chain_eval` then gives, in one compiled call, what the twin's
Newton iteration asks MuJoCo for at one configuration:

* the site's position: bodies composed in tree order as `mj_kinematics` does (body offset and orientation,
  then each hinge rotated about its anchor; rotation matrices instead of quaternions);
* its translational Jacobian, column j = axis_j × (p_site − anchor_j) for every dof on the site's branch
  (`mj_jacSite`);
* the gravity torques `mj_rne(flg_acc=0)` gives at rest: τ_j = −(axis_j × (S_j − M_j·anchor_j))·g, with M_j and
  S_j the mass and mass-weighted centre of mass of the subtree the dof moves.

MuJoCo stays the source: the parameters are the compiled model's, and `tests/test_compiled_replay.py` holds
all three against MuJoCo's own calls to 1e-12. Models the chain cannot express (a joint other than a hinge,
mocap bodies, gravity compensation) get None from `chain_arrays`; the twin then calls MuJoCo per sample.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np
from numba import njit


class ChainArrays(NamedTuple):
    """A hinge-chain model as flat arrays (read-only), with scratch space for `chain_eval`."""

    parent: np.ndarray  # (nbody,) parent body id
    body_pos: np.ndarray  # (nbody, 3) offset in the parent frame [m]
    body_rot: np.ndarray  # (nbody, 3, 3) orientation in the parent frame
    mass: np.ndarray  # (nbody,) [kg]
    ipos: np.ndarray  # (nbody, 3) centre of mass in the body frame [m]
    jnt_start: np.ndarray  # (nbody,) first joint of the body
    jnt_num: np.ndarray  # (nbody,) joints of the body
    jnt_axis: np.ndarray  # (njnt, 3) unit axis in the body frame
    jnt_pos: np.ndarray  # (njnt, 3) anchor in the body frame [m]
    jnt_dof: np.ndarray  # (njnt,) dof (= qpos address) of the hinge
    jnt_q0: np.ndarray  # (njnt,) qpos0 [rad]
    jnt_k: np.ndarray  # (njnt, 3, 3) cross-product matrix of the axis
    jnt_kk: np.ndarray  # (njnt, 3, 3) its square
    dof_body: np.ndarray  # (nv,) body each dof moves
    site_dep: np.ndarray  # (nv,) 1 where the dof moves the site
    site_body: int
    site_pos: np.ndarray  # (3,) site offset in its body's frame [m]
    gravity: np.ndarray  # (3,) [m/s²]
    frame_rot: np.ndarray  # (3, 3) R_sheet_base: the site's position and Jacobian are given in this frame
    frame_origin: np.ndarray  # (3,) its origin in the base frame [m]
    xpos: np.ndarray  # scratch (nbody, 3)
    xmat: np.ndarray  # scratch (nbody, 3, 3)
    xanchor: np.ndarray  # scratch (nv, 3)
    xaxis: np.ndarray  # scratch (nv, 3)
    sub_m: np.ndarray  # scratch (nbody,)
    sub_mc: np.ndarray  # scratch (nbody, 3)
    rot: np.ndarray  # scratch (2, 3, 3)
    pw: np.ndarray  # scratch (3,): the site in the base frame


def _quat_mat(quat: np.ndarray) -> np.ndarray:
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
    return R.reshape(3, 3)


def _is_hinge_chain_with_gravity(m: mujoco.MjModel) -> bool:
    """Hinges only (qpos and dof alike), no mocap bodies, no gravity compensation, gravity on."""
    hinge = mujoco.mjtJoint.mjJNT_HINGE
    if m.nq != m.nv or m.nmocap or np.any(m.body_gravcomp) or np.any(m.jnt_type != hinge):
        return False
    if m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY:
        return False
    return not np.any(m.jnt_dofadr != m.jnt_qposadr)


def _ancestors(m: mujoco.MjModel, body: int) -> set[int]:
    """`body` and the bodies above it, up to (not including) the world."""
    out = set()
    while body != 0:
        out.add(body)
        body = int(m.body_parentid[body])
    return out


def chain_arrays(
    model: mujoco.MjModel,
    site_id: int,
    origin: np.ndarray | None = None,
    R_base_frame: np.ndarray | None = None,
) -> ChainArrays | None:
    """The chain of `model` with site `site_id` as flat arrays; None if it is not a chain of hinges.

    Args:
        model: A compiled model.
        site_id: The tool-tip site.
        origin: Origin of the frame `chain_eval` gives the site in, base frame [m]; None: the base origin.
        R_base_frame: Orientation of that frame in the base (the sheet's placement); None: the base axes.

    Returns:
        The arrays, or None when a joint is not a hinge, the model has mocap bodies or gravity compensation,
        or gravity is disabled (the twin then uses MuJoCo per sample).
    """
    m = model
    if not _is_hinge_chain_with_gravity(m):
        return None
    nb = m.nbody
    dof_body = np.array([m.jnt_bodyid[j] for j in range(m.njnt)], dtype=np.int64)[np.argsort(m.jnt_dofadr)]
    site_body = int(m.site_bodyid[site_id])
    ancestors = _ancestors(m, site_body)
    site_dep = np.array([1.0 if int(body) in ancestors else 0.0 for body in dof_body])
    axes = m.jnt_axis / np.linalg.norm(m.jnt_axis, axis=1, keepdims=True) if m.njnt else np.zeros((0, 3))
    K = np.array([[[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]] for a in axes]).reshape(-1, 3, 3)
    return ChainArrays(
        parent=m.body_parentid.astype(np.int64),
        body_pos=m.body_pos.copy(),
        body_rot=np.array([_quat_mat(q) for q in m.body_quat]),
        mass=m.body_mass.copy(),
        ipos=m.body_ipos.copy(),
        jnt_start=m.body_jntadr.astype(np.int64),
        jnt_num=m.body_jntnum.astype(np.int64),
        jnt_axis=np.ascontiguousarray(axes),
        jnt_pos=m.jnt_pos.copy(),
        jnt_dof=m.jnt_dofadr.astype(np.int64),
        jnt_q0=np.array([m.qpos0[a] for a in m.jnt_qposadr], dtype=float),
        jnt_k=K,
        jnt_kk=K @ K,
        dof_body=dof_body,
        site_dep=site_dep,
        site_body=site_body,
        site_pos=m.site_pos[site_id].copy(),
        gravity=m.opt.gravity.copy(),
        frame_rot=np.eye(3) if R_base_frame is None else np.ascontiguousarray(np.asarray(R_base_frame, float).T),
        frame_origin=np.zeros(3) if origin is None else np.asarray(origin, dtype=float).copy(),
        xpos=np.zeros((nb, 3)),
        xmat=np.zeros((nb, 3, 3)),
        xanchor=np.zeros((m.nv, 3)),
        xaxis=np.zeros((m.nv, 3)),
        sub_m=np.zeros(nb),
        sub_mc=np.zeros((nb, 3)),
        rot=np.zeros((2, 3, 3)),
        pw=np.zeros(3),
    )


@njit(cache=True)
def chain_tip(c: ChainArrays, q: np.ndarray, p: np.ndarray) -> None:
    """Site position at `q`, into `p` (`chain_eval` without the Jacobian and gravity; the bodies' frames are left in
    the chain's scratch space for it).

    Args:
        c: The chain (`chain_arrays`).
        q: Joint positions [rad], shape (nv,).
        p: Out: site position in the chain's frame (the sheet frame; the base frame by default) [m], shape (3,).
    """
    xpos, xmat = c.xpos, c.xmat
    nb = xpos.shape[0]
    for r in range(3):
        xpos[0, r] = 0.0
        for s in range(3):
            xmat[0, r, s] = 1.0 if r == s else 0.0
    for b in range(1, nb):
        par = c.parent[b]
        for r in range(3):
            acc = xpos[par, r]
            for s in range(3):
                acc += xmat[par, r, s] * c.body_pos[b, s]
            xpos[b, r] = acc
            for s in range(3):
                v = 0.0
                for t in range(3):
                    v += xmat[par, r, t] * c.body_rot[b, t, s]
                xmat[b, r, s] = v
        for j in range(c.jnt_start[b], c.jnt_start[b] + c.jnt_num[b]):
            d = c.jnt_dof[j]
            ax, jp = c.jnt_axis[j], c.jnt_pos[j]
            for r in range(3):
                c.xanchor[d, r] = xpos[b, r] + xmat[b, r, 0] * jp[0] + xmat[b, r, 1] * jp[1] + xmat[b, r, 2] * jp[2]
                c.xaxis[d, r] = xmat[b, r, 0] * ax[0] + xmat[b, r, 1] * ax[1] + xmat[b, r, 2] * ax[2]
            theta = q[d] - c.jnt_q0[j]
            sn, cs = np.sin(theta), 1.0 - np.cos(theta)
            # R <- R (I + sin K + (1 - cos) K²), K the cross-product matrix of the local axis (Rodrigues)
            rot, new = c.rot[0], c.rot[1]
            K, K2 = c.jnt_k[j], c.jnt_kk[j]
            for r in range(3):
                for s in range(3):
                    rot[r, s] = (1.0 if r == s else 0.0) + sn * K[r, s] + cs * K2[r, s]
            for r in range(3):
                for s in range(3):
                    new[r, s] = xmat[b, r, 0] * rot[0, s] + xmat[b, r, 1] * rot[1, s] + xmat[b, r, 2] * rot[2, s]
            for r in range(3):
                for s in range(3):
                    xmat[b, r, s] = new[r, s]
                xpos[b, r] = c.xanchor[d, r] - (new[r, 0] * jp[0] + new[r, 1] * jp[1] + new[r, 2] * jp[2])
    sb = c.site_body
    pw = c.pw  # the site in the base frame
    for r in range(3):
        pw[r] = (
            xpos[sb, r]
            + xmat[sb, r, 0] * c.site_pos[0]
            + xmat[sb, r, 1] * c.site_pos[1]
            + xmat[sb, r, 2] * c.site_pos[2]
        )
    R, o = c.frame_rot, c.frame_origin
    for r in range(3):
        p[r] = R[r, 0] * (pw[0] - o[0]) + R[r, 1] * (pw[1] - o[1]) + R[r, 2] * (pw[2] - o[2])


@njit(cache=True)
def chain_eval(c: ChainArrays, q: np.ndarray, p: np.ndarray, jac: np.ndarray, g: np.ndarray) -> None:
    """Site position, translational Jacobian and gravity torques at `q`, into `p`, `jac`, `g`.

    Args:
        c: The chain (`chain_arrays`).
        q: Joint positions [rad], shape (nv,).
        p: Out: site position in the chain's frame (the sheet frame; the base frame by default) [m], shape (3,).
        jac: Out: d p / d q in that frame [m/rad], shape (3, nv).
        g: Out: gravity torques, as `mj_rne` at rest [N·m], shape (nv,).
    """
    chain_tip(c, q, p)
    xpos, xmat, pw, R = c.xpos, c.xmat, c.pw, c.frame_rot
    nb = xpos.shape[0]
    # subtree masses and mass-weighted centres of mass, leaves first (children have larger ids)
    for b in range(nb):
        c.sub_m[b] = c.mass[b]
        for r in range(3):
            com = xpos[b, r] + xmat[b, r, 0] * c.ipos[b, 0] + xmat[b, r, 1] * c.ipos[b, 1] + xmat[b, r, 2] * c.ipos[b, 2]
            c.sub_mc[b, r] = c.mass[b] * com
    for b in range(nb - 1, 0, -1):
        par = c.parent[b]
        c.sub_m[par] += c.sub_m[b]
        for r in range(3):
            c.sub_mc[par, r] += c.sub_mc[b, r]
    gx, gy, gz = c.gravity[0], c.gravity[1], c.gravity[2]
    for d in range(c.dof_body.shape[0]):
        b = c.dof_body[d]
        a0, a1, a2 = c.xaxis[d, 0], c.xaxis[d, 1], c.xaxis[d, 2]
        v0 = c.sub_mc[b, 0] - c.sub_m[b] * c.xanchor[d, 0]
        v1 = c.sub_mc[b, 1] - c.sub_m[b] * c.xanchor[d, 1]
        v2 = c.sub_mc[b, 2] - c.sub_m[b] * c.xanchor[d, 2]
        g[d] = -((a1 * v2 - a2 * v1) * gx + (a2 * v0 - a0 * v2) * gy + (a0 * v1 - a1 * v0) * gz)
        dep = c.site_dep[d]  # 0 or 1
        w0, w1, w2 = pw[0] - c.xanchor[d, 0], pw[1] - c.xanchor[d, 1], pw[2] - c.xanchor[d, 2]
        j0, j1, j2 = dep * (a1 * w2 - a2 * w1), dep * (a2 * w0 - a0 * w2), dep * (a0 * w1 - a1 * w0)
        for r in range(3):
            jac[r, d] = R[r, 0] * j0 + R[r, 1] * j1 + R[r, 2] * j2
