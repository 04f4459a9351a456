"""The joint springs K_q of the TX200: the gains of the position actuators `actuator1..6` of the model.

Joint friction is MuJoCo's own `frictionloss` of joint1..6 (Coulomb friction against the link's motion); the
quasi-static twin reads it from `model.dof_frictionloss` (see `twin.sim.quasi_static`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from twin.errors import InputError


def set_joint_stiffness(model: mujoco.MjModel, k_q_nm_per_rad: np.ndarray) -> None:
    """Set the joint springs K_q (position-actuator gains) of `actuator1..6` in place.

    Args:
        model: Compiled model with position actuators on joint1..6.
        k_q_nm_per_rad: Joint stiffness [N·m/rad], shape (6,), all > 0.
    """
    k = np.asarray(k_q_nm_per_rad, dtype=float)
    if k.shape != (6,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise InputError(f"joint stiffness must be 6 finite positive values [N·m/rad], got {k!r}")
    for i, value in enumerate(k):
        act = model.actuator(f"actuator{i + 1}").id
        model.actuator_gainprm[act, 0] = value
        model.actuator_biasprm[act, 1] = -value

