"""The sliding direction of the tool on the sheet, implicit in its step: the in-plane force of the ISF model.

The ISF force model (`twin.process.force.isf`) puts its in-plane force along -v, v the filtered direction in
which the tool slides over the sheet. From the held direction v_prev and a step (dx, dy) of length ℓ from the
last committed tip, with e = (dx, dy)/ℓ:

    v⁺ = v_prev - r·min(v_prev·e, 0)·e,   r = 1 - exp(-ℓ/L_r)     (release)
    v  = w·v⁺ + (1 - w)·e,                w = exp(-ℓ/L_f)          (turn and build-up)

* On a straight run |v| = 1.
* A turn of 90° or less releases nothing: v turns towards e over L_f of travel.
* A tool that moves back (v_prev·e < 0) leaves the wall it was pushing; the sheet cannot pull it, so the held
  component against e is dropped over the release length L_r (0.05 mm) and the in-plane force builds up against
  the new travel as 1 - exp(-u/L_f), u the travel since the reversal. Steps much shorter than L_r (the jitter
  of a deflecting tool) release nothing, so the force stays continuous in the queried position.

v is implicit in the queried position (a tool pushed sideways meets friction against that motion), so its
Jacobian ∂v/∂(x, y) enters the field's stiffness; it is analytic here and tested against central differences.
"""

from __future__ import annotations

import math

import numpy as np

#: Step over which a reversal releases the in-plane force held against the old travel [m].
RELEASE_LENGTH_M = 0.05e-3
#: Steps shorter than this [m] leave the direction as held (no Jacobian).
MIN_STEP_M = 1e-9


def sliding_direction(
    v_prev: tuple[float, float],
    dx: float,
    dy: float,
    turn_length_m: float,
    release_length_m: float,
    jacobian: bool = True,
) -> tuple[float, float, np.ndarray | None]:
    """Sliding direction after a step, and its Jacobian (module docstring).

    Args:
        v_prev: Held direction (vx, vy) [-] (|v| <= 1; (0, 0) before any motion).
        dx: Step along x from the last committed tip [m].
        dy: Step along y [m].
        turn_length_m: L_f, the travel over which v turns and builds up [m].
        release_length_m: L_r, the step over which a reversal releases the held direction [m].
        jacobian: False skips the Jacobian (returned as None): the force alone, and the commit.

    Returns:
        (vx, vy, ∂v/∂(x, y) (2, 2) [1/m]); the Jacobian is None for a step shorter than `MIN_STEP_M`.
    """
    length = math.hypot(dx, dy)
    if length < MIN_STEP_M:
        return v_prev[0], v_prev[1], None
    ex, ey = dx / length, dy / length
    qx, qy = v_prev
    c = qx * ex + qy * ey
    if not jacobian:
        if c < 0.0:
            r = 1.0 - math.exp(-length / release_length_m)
            qx, qy = qx - r * c * ex, qy - r * c * ey
        w = math.exp(-length / turn_length_m)
        return w * qx + (1.0 - w) * ex, w * qy + (1.0 - w) * ey, None
    # ∂e/∂(x, y) = P / length, P = I - e·eᵀ
    pxx, pxy, pyy = 1.0 - ex * ex, -ex * ey, 1.0 - ey * ey
    dqxx = dqxy = dqyx = dqyy = 0.0  # ∂v⁺/∂(x, y)
    if c < 0.0:  # moving back against the held direction: release it
        wr = math.exp(-length / release_length_m)
        r = 1.0 - wr
        qx, qy = qx - r * c * ex, qy - r * c * ey
        a, b, k = c * wr / release_length_m, r / length, r * c / length
        gx, gy = v_prev[0] - c * ex, v_prev[1] - c * ey  # ∂c/∂(x, y) · length = P·v_prev
        dqxx = -(a * ex * ex + b * ex * gx + k * pxx)
        dqxy = -(a * ex * ey + b * ex * gy + k * pxy)
        dqyx = -(a * ey * ex + b * ey * gx + k * pxy)
        dqyy = -(a * ey * ey + b * ey * gy + k * pyy)
    w = math.exp(-length / turn_length_m)
    vx, vy = w * qx + (1.0 - w) * ex, w * qy + (1.0 - w) * ey
    dw = -w / turn_length_m  # ∂w/∂length; ∂length/∂(x, y) = e
    g = (1.0 - w) / length
    jac = np.array(
        [
            [(qx - ex) * dw * ex + w * dqxx + g * pxx, (qx - ex) * dw * ey + w * dqxy + g * pxy],
            [(qy - ey) * dw * ex + w * dqyx + g * pxy, (qy - ey) * dw * ey + w * dqyy + g * pyy],
        ]
    )
    return vx, vy, jac
