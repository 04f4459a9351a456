"""How the model's default joint stiffness K_q was derived (models/README.md), reproducible.

The diagonal K_q whose Cartesian compliance J_v K_q^-1 J_v^T at `home` best matches (Frobenius, compliances
kept >= 0) the symmetric part of inv(K_R(1)) of the thesis (Eq. 4.17). Joints that are not observable from
tool-tip translations there (the TX200's joints 4 and 6) are fixed at the stiffness the robot's description
assumes for them (its priors whose source is `assumed...`); the others are the fitted priors the description
records with this fit as their source. For identification from data (which joints a given K_R can see, with
rank tests), use `twin.analysis.identify.joint.fit_diagonal_kq`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from twin.analysis.identify.cartesian import THESIS_KR1_N_PER_MM
from twin.robot.kinematics import Kinematics
from twin.robot.model import load_model


@dataclass(frozen=True)
class StiffnessFit:
    """Diagonal joint stiffness fitted to a Cartesian compliance.

    Attributes:
        K_q: Joint stiffnesses (dof,) [N m/rad].
        fitted: 0-based indices of the fitted joints (the others were fixed).
        C_target: Compliance fitted to (3, 3) [m/N].
        C_model: J_v K_q^-1 J_v^T with the fitted K_q (3, 3) [m/N].
        residual_rel: ||C_model - C_target||_F / ||C_target||_F.
    """

    K_q: np.ndarray
    fitted: tuple[int, ...]
    C_target: np.ndarray
    C_model: np.ndarray
    residual_rel: float


def fit_diagonal_joint_stiffness(
    J_v: np.ndarray, C_target: np.ndarray, fixed: Mapping[int, float] | None = None
) -> StiffnessFit:
    """Least-squares diagonal K_q with J_v K_q^-1 J_v^T ~ C_target (Frobenius), compliances kept >= 0.

    Args:
        J_v: Translational Jacobian (3, dof) [m/rad].
        C_target: Symmetric target compliance (3, 3) [m/N].
        fixed: 0-based joint index -> fixed stiffness [N m/rad] for joints not to fit.
    """
    fixed = {} if fixed is None else dict(fixed)
    dof = J_v.shape[1]
    basis = np.stack([np.outer(J_v[:, i], J_v[:, i]).ravel() for i in range(dof)], axis=1)
    rhs = C_target.ravel() - sum(basis[:, i] / k for i, k in fixed.items())
    free = tuple(i for i in range(dof) if i not in fixed)
    c, _ = nnls(basis[:, free], rhs)
    K_q = np.empty(dof)
    for i, k in fixed.items():
        K_q[i] = k
    with np.errstate(divide="ignore"):
        K_q[list(free)] = 1.0 / c
    C_model = (J_v / K_q) @ J_v.T
    resid = float(np.linalg.norm(C_model - C_target) / np.linalg.norm(C_target))
    return StiffnessFit(K_q, free, C_target.copy(), C_model, resid)


def thesis_stiffness_fit(kin: Kinematics | None = None) -> StiffnessFit:
    """Default K_q of the model: fit to the symmetric part of inv(K_R(1)) (thesis Eq. 4.17) at home.

    Joints whose stiffness prior the robot's description marks as assumed are fixed at it (not observable
    from tip translations).
    """
    kin = Kinematics(load_model(scene=False)) if kin is None else kin
    C = np.linalg.inv(THESIS_KR1_N_PER_MM * 1e3)  # [m/N]
    J_v = kin.jacobian(kin.q_home)[:3]
    fixed = {kin.robot.joints.index(p.joint): p.k_nm_per_rad for p in kin.robot.stiffness_priors
             if p.source.startswith("assumed")}
    return fit_diagonal_joint_stiffness(J_v, 0.5 * (C + C.T), fixed=fixed)
