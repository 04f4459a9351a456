"""Cartesian stiffness identification of the robot at the machining pose (thesis §4.2, Eqs. 4.16–4.27).

Method 1 (§4.2.1, Eq. 4.16): static load cases F_i = K_R·ΔU_i, K_R fitted by ordinary least squares.
Method 2 (§4.2.2, Eqs. 4.18–4.25): the whole nominal run, F_ID = K_R(2)·ΔU_NT on x and z, OLS per force row.
Also the compliance C_R fitted directly (ΔU regressed on F) and the load-case CSV reader. The joint
stiffness K_q consistent with K_R (§4.1.2) is in `twin.analysis.identify.joint`.

Conventions: K_R rows are force components, columns deflection components (as Eq. 4.17), so
F = K_R·ΔU with ΔU = U_ideal − U_measured (Eq. 4.19). SI inside: N/m, m/N, N·m/rad; N/mm only in constants
named `_N_PER_MM` and at CSV/JSON edges.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.base.csvio import read_table
from twin.errors import IdentificationError, InputError, UnitsError

# Thesis Table 4.2 (§4.2.1): Method 1 load cases (Fx, Fy, Fz) [N]. Measured deflections are not printed.
THESIS_TABLE_4_2_LOADS_N = np.array(
    [
        [800.0, 800.0, 1500.0],
        [500.0, 500.0, 1000.0],
        [1500.0, 800.0, 800.0],
        [800.0, 1500.0, 800.0],
        [1000.0, 1000.0, 1000.0],
    ]
)
# Thesis Eq. 4.17 (§4.2.1): K_R(1) [N/mm], rows Fx, Fy, Fz; columns ΔUx, ΔUy, ΔUz.
THESIS_KR1_N_PER_MM = np.array(
    [
        [716.50, -949.00, -135.00],
        [320.50, 378.00, -91.00],
        [-552.00, 1130.00, 1080.00],
    ]
)
# Thesis Eq. 4.26 (§4.2.2): K_R(2) [N/mm], x–z only, rows Fx, Fz; columns ΔUx, ΔUz.
THESIS_KR2_N_PER_MM = np.array([[779.37, -563.74], [-436.71, 1374.00]])
# Thesis Eq. 4.27a (§4.2.3): C_R(1) [mm/kN], x–z. It is the inverse of the x–z SUB-BLOCK of K_R(1)
# (y held fixed), not the x–z block of inv(K_R(1)) (y free), which is [[0.897, 0.241], [1.002, 1.009]].
THESIS_CR1_MM_PER_KN = np.array([[1.54, 0.19], [0.79, 1.02]])
# Thesis Eq. 4.27b (§4.2.3): C_R(2) = inv(K_R(2)) [mm/kN], x–z.
THESIS_CR2_MM_PER_KN = np.array([[1.67, 0.68], [0.53, 0.95]])

LOAD_CASE_COLUMNS = ("fx_n", "fy_n", "fz_n", "dx_mm", "dy_mm", "dz_mm")
MAX_METRES_LIKE_DEFLECTION_MM = 0.01  # ~1 kN deflects this robot 0.1–10 mm: all values below 0.01 are metres
MAX_KN_LIKE_FORCE_N = 10.0  # load cases are ~1 kN: all values below 10 are kN
RANK_RTOL = 1e-9  # singular values below this times the largest count as zero


@dataclass(frozen=True)
class KrFit:
    """A Cartesian stiffness fit F = K_R·ΔU.

    Attributes:
        k_r_n_per_m: Stiffness, shape (k, k), rows force, columns deflection [N/m].
        residuals_n: Norm of F_i − K_R·ΔU_i per sample/load case, shape (m,) [N].
        condition_number: 2-norm condition number of the deflection (regressor) matrix.
        rank: Numerical rank of the deflection matrix.
    """

    k_r_n_per_m: np.ndarray
    residuals_n: np.ndarray
    condition_number: float
    rank: int

    @property
    def k_r_n_per_mm(self) -> np.ndarray:
        """Stiffness in the thesis's unit [N/mm]."""
        return self.k_r_n_per_m * 1e-3


def _pair(f_n: np.ndarray, d_m: np.ndarray, widths: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(f_n, dtype=float)
    d = np.asarray(d_m, dtype=float)
    if f.ndim != 2 or f.shape != d.shape or f.shape[1] not in widths:
        raise InputError(f"forces {f.shape} and deflections {d.shape} must both be (n, k) with k in {widths}")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(d))):
        raise InputError("forces and deflections must be finite (found NaN or inf)")
    return f, d


def _ols_stiffness(f: np.ndarray, d: np.ndarray, what: str) -> KrFit:
    """Solve F_i = K·ΔU_i for all i: row j of K from ΔUᵀ·k_j = F_jᵀ (Eqs. 4.22–4.25), stacked."""
    k = d.shape[1]
    singular = np.linalg.svd(d, compute_uv=False)
    rank = int(np.sum(singular > RANK_RTOL * max(float(singular[0]), np.finfo(float).tiny)))
    if rank < k:
        raise IdentificationError(
            f"{what}: the deflection vectors have rank {rank}, need {k} independent deflection "
            f"directions to determine the {k}×{k} stiffness ({d.shape[0]} sample(s) given); "
            "add load cases in other directions"
        )
    k_transposed, *_ = np.linalg.lstsq(d, f, rcond=None)  # d·Kᵀ = f
    k_r = k_transposed.T
    residuals = np.linalg.norm(f - d @ k_transposed, axis=1)
    return KrFit(k_r, residuals, float(singular[0] / singular[-1]), rank)


def fit_kr_load_cases(f_n: np.ndarray, d_m: np.ndarray) -> KrFit:
    """Method 1 (Eq. 4.16): 3×3 K_R from static load cases by ordinary least squares.

    Each case gives 3 equations F_i = K_R·ΔU_i; m cases give a (3m × 9) system in the 9 entries of K_R
    (15 × 9 for the thesis's 5 cases). It decouples into one (m × 3) OLS per row of K_R, which is solved.

    Args:
        f_n: Applied loads, shape (m, 3) [N].
        d_m: Measured deflections ΔU, shape (m, 3) [m].

    Returns:
        The fit; `residuals_n` has one entry per load case.

    Raises:
        InputError: Shapes differ, are not (m, 3), or hold NaN.
        IdentificationError: Fewer than 3 independent deflection vectors (rank-deficient load set).
    """
    f, d = _pair(f_n, d_m, (3,))
    return _ols_stiffness(f, d, "Method 1 load set")


def fit_kr_from_run(f_n: np.ndarray, d_m: np.ndarray, axes: tuple[int, ...] = (0, 2)) -> KrFit:
    """Method 2 (Eqs. 4.18–4.25): the x–z stiffness from a whole run, exactly as the thesis did (2×2), or over
    other axes of (n, 3) inputs (all three for a part whose forces span y too).

    The thesis regresses FORCE on DEFLECTION: for each force row, ΔU_NTᵀ·[k_xx, k_xz]ᵀ = F_IDxᵀ (Eq. 4.22),
    solved with the Moore–Penrose inverse (Eqs. 4.24–4.25). Here with `numpy.linalg.lstsq` (same solution,
    better numerics). Note that the measured deflections are the noisy regressor, which biases K towards
    zero (errors in variables); see `fit_compliance` for the better-posed alternative.

    Args:
        f_n: Forces (ideal F_ID or measured), shape (n, 2) as (x, z) or (n, 3) as (x, y, z) [N].
        d_m: Deflections ΔU = U_ideal − U_measured, same shape [m].
        axes: From (n, 3) inputs, the axes fitted (0: x, 1: y, 2: z): x and z by default, (0, 1, 2) for all.

    Returns:
        The k×k fit over `axes` (2×2 rows (Fx, Fz), columns (ΔUx, ΔUz) by default) [N/m].

    Raises:
        InputError: Bad shapes, or `axes` not 2 or 3 distinct axes of 0, 1, 2.
    """
    f, d = _pair(f_n, d_m, (2, 3))
    if len(set(axes)) != len(axes) or len(axes) not in (2, 3) or not set(axes) <= {0, 1, 2}:
        raise InputError(f"axes {axes!r}: expected 2 or 3 distinct axes of 0 (x), 1 (y), 2 (z)")
    if f.shape[1] == 3:
        f, d = f[:, list(axes)], d[:, list(axes)]
    return _ols_stiffness(f, d, "Method 2 run data")


def fit_compliance(f_n: np.ndarray, d_m: np.ndarray, direction: np.ndarray | None = None) -> np.ndarray:
    """Compliance C with ΔU = C·F by ordinary least squares (deflection regressed on force).

    With `direction` (+1/-1 per sample), ΔU = C·F + b·direction: an offset per axis that flips with the
    travel direction (joint friction, lost motion) is fitted alongside and kept out of C.

    Not what the thesis did (it fitted K, Eqs. 4.22–4.25, and inverted it for C_R, Eq. 4.27). This is
    better posed for run data: the ideal forces F_ID are (nearly) noise-free and span a wide range, the
    tracker noise (~40 µm, §3.3) sits in the response where OLS expects it, so C is unbiased; fitting K
    puts that noise in the regressor and biases K low (C high). The regressor here is the force matrix,
    whose condition number does not depend on the small, noisy deflections. The two estimates agree only
    for noise-free data, so inv(fit_compliance) is not fit_kr_from_run in general.

    Args:
        f_n: Forces, shape (n, k) with k in {2, 3} [N].
        d_m: Deflections, same shape [m].

    Returns:
        C, shape (k, k), rows deflection, columns force [m/N].

    Raises:
        IdentificationError: The forces do not span k independent directions.
    """
    f, d = _pair(f_n, d_m, (2, 3))
    singular = np.linalg.svd(f, compute_uv=False)
    rank = int(np.sum(singular > RANK_RTOL * max(float(singular[0]), np.finfo(float).tiny)))
    if rank < f.shape[1]:
        raise IdentificationError(
            f"forces have rank {rank}, need {f.shape[1]} independent force directions to fit a compliance"
        )
    if direction is None:
        c_transposed, *_ = np.linalg.lstsq(f, d, rcond=None)  # f·Cᵀ = d
        return np.asarray(c_transposed.T)
    sign = np.asarray(direction, dtype=float)
    if sign.shape != (f.shape[0],):
        raise InputError(f"direction has shape {sign.shape}, expected ({f.shape[0]},)")
    solution, *_ = np.linalg.lstsq(np.column_stack([f, sign]), d, rcond=None)
    return np.asarray(solution[: f.shape[1]].T)


def load_cases_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read Method 1 load cases: columns `fx_n, fy_n, fz_n, dx_mm, dy_mm, dz_mm`.

    Unit heuristics (a ~1 kN load deflects this robot by 0.1–10 mm): if every deflection magnitude is
    below 0.01 the `_mm` columns hold metres; if every force magnitude is below 10 the `_n` columns hold
    kN. Both raise UnitsError.

    Returns:
        (f_n, d_m): loads (m, 3) [N] and deflections (m, 3) [m].

    Raises:
        DataFileError: Missing file/columns, bad or truncated rows (names file and row).
        UnitsError: Values that look like metres or kN.
    """
    table = read_table(path, LOAD_CASE_COLUMNS, min_rows=1)
    f_n = np.column_stack([table[name] for name in LOAD_CASE_COLUMNS[:3]])
    d_mm = np.column_stack([table[name] for name in LOAD_CASE_COLUMNS[3:]])
    if np.max(np.abs(d_mm)) < MAX_METRES_LIKE_DEFLECTION_MM:
        raise UnitsError(
            path,
            f"all deflections are below {MAX_METRES_LIKE_DEFLECTION_MM} "
            f"(largest {np.max(np.abs(d_mm)):.3g}); "
            "a ~1 kN load deflects the robot 0.1-10 mm: are dx_mm/dy_mm/dz_mm in metres? multiply by 1000",
        )
    if np.max(np.abs(f_n)) < MAX_KN_LIKE_FORCE_N:
        raise UnitsError(
            path,
            f"all forces are below {MAX_KN_LIKE_FORCE_N} (largest {np.max(np.abs(f_n)):.3g}); "
            "load cases are ~1 kN: are fx_n/fy_n/fz_n in kN? multiply by 1000",
        )
    return f_n, d_mm * 1e-3
