"""Joint stiffness from a Cartesian one at one pose (thesis §4.1.2, Eqs. 4.4–4.5).

A diagonal K_q gives the Cartesian compliance J_v·K_q⁻¹·J_vᵀ; `fit_diagonal_kq` fits it to sym(K_R⁻¹) in
compliance space and flags the joints the tool-tip translations cannot see; `kq_from_kr_congruence` is
Eq. 4.5 taken literally, for comparison. SI: N/m, m/N, N·m/rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from twin.errors import IdentificationError, InputError


@dataclass(frozen=True)
class KqFit:
    """A diagonal joint-stiffness fit at one pose.

    Attributes:
        k_q_nm_per_rad: Joint stiffness, shape (dof,) [N·m/rad]; the default (NaN) for unobservable joints,
            inf where the fit drives the compliance to its zero bound.
        observable: Whether each joint's compliance is determined by the tool-tip translations, shape (dof,).
        singular_values: Singular values of the (6 entries × dof joints) compliance design matrix [m²].
        relative_residual: ‖J_v·diag(c)·J_vᵀ − sym(K_R⁻¹)‖ / ‖sym(K_R⁻¹)‖ over the 6 unique entries.
    """

    k_q_nm_per_rad: np.ndarray
    observable: np.ndarray
    singular_values: np.ndarray
    relative_residual: float


_SYM_ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _translational(jacobian: np.ndarray) -> np.ndarray:
    J = np.asarray(jacobian, dtype=float)
    if J.ndim != 2 or J.shape[0] not in (3, 6) or J.shape[1] < 1 or not np.all(np.isfinite(J)):
        raise InputError(
            f"Jacobian has shape {J.shape}, expected finite (6, dof) or (3, dof) (translational rows first)"
        )
    return J[:3]


def _stiffness3(k_r_n_per_m: np.ndarray) -> np.ndarray:
    K = np.asarray(k_r_n_per_m, dtype=float)
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise InputError(f"K_R has shape {K.shape}, expected a finite (3, 3) matrix [N/m]")
    return K


def _observable_joints(design: np.ndarray, rcond: float) -> np.ndarray:
    """Drop joints greedily while the design's smallest singular value is below rcond × the largest.

    The joint with the largest share of the weakest direction goes first, so a zero (or negligible)
    Jacobian column, or two joints that move the tool tip the same way (e.g. joints 1 and 4 at the
    machining pose, both along y), are caught. Columns are not normalised: a joint whose lever arm is
    tiny would need an enormous compliance to matter, so it is not determined either.
    """
    observable = np.ones(design.shape[1], dtype=bool)
    largest = float(np.linalg.svd(design, compute_uv=False)[0]) if np.any(design) else 0.0
    while np.any(observable):
        if largest == 0.0:
            observable[:] = False
            break
        _, singular, vt = np.linalg.svd(design[:, observable], full_matrices=True)
        n_kept = int(np.sum(observable))
        weakest = float(singular[n_kept - 1]) if len(singular) >= n_kept else 0.0
        if weakest >= rcond * largest:
            break
        direction = vt[n_kept - 1]
        observable[np.flatnonzero(observable)[int(np.argmax(np.abs(direction)))]] = False
    return observable


def fit_diagonal_kq(
    jacobian: np.ndarray,
    k_r_n_per_m: np.ndarray,
    *,
    default_nm_per_rad: float = float("nan"),
    rcond: float = 1e-3,
) -> KqFit:
    """Best diagonal K_q with J_v·K_q⁻¹·J_vᵀ ≈ sym(K_R⁻¹) (Eqs. 4.4–4.5, fitted in compliance space).

    A diagonal K_q gives a symmetric Cartesian compliance Σ_i c_i·j_i·j_iᵀ (j_i: column i of J_v,
    c_i = 1/k_i), linear in the joint compliances c. It is fitted by non-negative least squares
    (`scipy.optimize.nnls`) over the 6 unique entries (xx, yy, zz, xy, xz, yz, equal weights) of the
    symmetric part of K_R⁻¹ (the antisymmetric part cannot come from a diagonal K_q, §4.1.3).
    Joints that the tool-tip translations cannot tell apart are flagged unobservable (see
    `_observable_joints`), left out of the fit, and reported as `default_nm_per_rad`. A compliance that
    the fit drives to its zero bound is reported as an infinite stiffness.

    Args:
        jacobian: Geometric Jacobian at the pose, (6, dof) or its translational rows (3, dof) [m/rad].
        k_r_n_per_m: Cartesian stiffness K_R (3, 3) [N/m].
        default_nm_per_rad: Value reported for unobservable joints [N·m/rad].
        rcond: Relative singular-value threshold below which a design direction counts as undetermined.
            At the thesis's machining pose (Table 4.1) joints 1 and 4 both move the tip along y and the
            weakest direction is at 4e-4 of the largest: the default 1e-3 flags joint 4 (and joint 6,
            whose axis passes through the tool tip).

    Returns:
        The fit.

    Raises:
        IdentificationError: K_R is singular or no joint is observable.
    """
    J_v = _translational(jacobian)
    K = _stiffness3(k_r_n_per_m)
    try:
        C = np.linalg.inv(K)
    except np.linalg.LinAlgError:
        raise IdentificationError("K_R is singular; cannot form the compliance to fit K_q") from None
    C_sym = 0.5 * (C + C.T)
    target = np.array([C_sym[a, b] for a, b in _SYM_ENTRIES])
    dof = J_v.shape[1]
    design = np.array([[J_v[a, i] * J_v[b, i] for i in range(dof)] for a, b in _SYM_ENTRIES])
    singular = np.linalg.svd(design, compute_uv=False)
    observable = _observable_joints(design, rcond)
    if not np.any(observable):
        raise IdentificationError("no joint compliance is observable from tool-tip translations at this pose")
    columns = design[:, observable]
    col_scale = np.linalg.norm(columns, axis=0)
    rhs_scale = max(float(np.max(np.abs(target))), np.finfo(float).tiny)
    scaled, _ = nnls(columns / col_scale, target / rhs_scale)
    compliance = np.zeros(dof)
    compliance[observable] = scaled / col_scale * rhs_scale
    norm_target = max(float(np.linalg.norm(target)), np.finfo(float).tiny)
    residual = float(np.linalg.norm(design @ compliance - target) / norm_target)
    k_q = np.full(dof, float(default_nm_per_rad))
    with np.errstate(divide="ignore"):
        k_q[observable] = np.where(compliance[observable] > 0, 1.0 / compliance[observable], np.inf)
    return KqFit(k_q, observable, singular, residual)


def kq_from_kr_congruence(jacobian: np.ndarray, k_r_n_per_m: np.ndarray) -> np.ndarray:
    """Eq. 4.5 taken literally: K_q ≈ diag(J_vᵀ·K_R·J_v) [N·m/rad], for comparison with `fit_diagonal_kq`.

    This keeps only the diagonal of the congruence and ignores its off-diagonal terms, so it does not
    reproduce K_R even when K_R came from a diagonal K_q.
    """
    J_v = _translational(jacobian)
    K = _stiffness3(k_r_n_per_m)
    return np.asarray(np.diag(J_v.T @ K @ J_v))
