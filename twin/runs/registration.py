"""Registration of the tracker frame to the sheet frame: a given 4x4 transform, or a least-squares rigid fit.

The rigid fit is the Kabsch (1976) solution: with the reference points centred in both frames, the rotation
is `R = V diag(1, 1, det(V Uᵀ)) Uᵀ` from the SVD `H = U S Vᵀ` of `H = Σ q̃_i p̃_iᵀ` (q in the tracker frame,
p in the sheet frame), and `t = p̄ - R q̄`. The residual of the fit, per point, is reported: it is the
tracker's own error plus the error of locating the reference points on the sheet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.errors import InputError

MIN_POINTS = 3
COLLINEAR_RATIO = 1e-3  # second singular value of the centred points / first: below this they are on a line


@dataclass(frozen=True)
class Registration:
    """A rigid transform from the tracker frame to the sheet frame.

    Attributes:
        T_sheet_tracker: Homogeneous transform, p_sheet = R p_tracker + t, shape (4, 4) [m].
        residual_rms_m: RMS distance between the mapped and the given sheet points [m] (0 for a given T).
        residual_max_m: Largest such distance [m].
        points: Number of reference points (0 for a given T).
    """

    T_sheet_tracker: np.ndarray
    residual_rms_m: float
    residual_max_m: float
    points: int

    def apply(self, p_tracker_m: np.ndarray) -> np.ndarray:
        """Map points from the tracker frame to the sheet frame.

        Args:
            p_tracker_m: Points in the tracker frame, shape (n, 3) [m].

        Returns:
            The same points in the sheet frame, shape (n, 3) [m].
        """
        R, t = self.T_sheet_tracker[:3, :3], self.T_sheet_tracker[:3, 3]
        return np.asarray(p_tracker_m, dtype=float) @ R.T + t


def check_spread(points_m: np.ndarray) -> None:
    """Raise InputError unless there are >= 3 points that do not lie on one line.

    Args:
        points_m: Points, shape (k, 3) [m].
    """
    points = np.asarray(points_m, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < MIN_POINTS:
        raise InputError(
            f"need at least {MIN_POINTS} reference points of shape (k, 3), got shape {points.shape}"
        )
    singular = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if singular[0] <= 0 or singular[1] / singular[0] < COLLINEAR_RATIO:
        ratio = 0.0 if singular[0] <= 0 else singular[1] / singular[0]
        raise InputError(
            f"the reference points are collinear (spread ratio {ratio:.2g} < {COLLINEAR_RATIO:g}): a rotation "
            "about their line is undetermined; measure at least 3 points that span a triangle"
        )


def fit_rigid(p_tracker_m: np.ndarray, p_sheet_m: np.ndarray) -> Registration:
    """Least-squares rigid transform (rotation + translation, no scale) from point pairs (Kabsch).

    Args:
        p_tracker_m: Reference points measured in the tracker frame, shape (k, 3), k >= 3 [m].
        p_sheet_m: The same points in the sheet frame, shape (k, 3) [m].

    Returns:
        The registration with its residual.

    Raises:
        InputError: Fewer than 3 points, different counts, or collinear points.
    """
    q = np.asarray(p_tracker_m, dtype=float)
    p = np.asarray(p_sheet_m, dtype=float)
    if q.shape != p.shape:
        raise InputError(f"point lists differ in shape: tracker {q.shape}, sheet {p.shape}")
    check_spread(q)
    check_spread(p)
    q_mean, p_mean = q.mean(axis=0), p.mean(axis=0)
    H = (q - q_mean).T @ (p - p_mean)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    t = p_mean - R @ q_mean
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    residual = np.linalg.norm(q @ R.T + t - p, axis=1)
    return Registration(T, float(np.sqrt(np.mean(residual**2))), float(residual.max()), len(p))


def given_transform(T_sheet_tracker: np.ndarray) -> Registration:
    """Wrap a known transform (rotation checked proper within 1e-6).

    Args:
        T_sheet_tracker: Homogeneous transform tracker -> sheet, shape (4, 4) [m].

    Raises:
        InputError: Not 4x4, not a proper rotation, or a last row other than [0, 0, 0, 1].
    """
    T = np.asarray(T_sheet_tracker, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"T_sheet_tracker must be a finite 4x4 matrix, got shape {T.shape}")
    R = T[:3, :3]
    if (
        not np.allclose(R.T @ R, np.eye(3), atol=1e-6)
        or np.linalg.det(R) < 0
        or not np.allclose(T[3], [0, 0, 0, 1])
    ):
        raise InputError(f"T_sheet_tracker is not a rigid transform: {T.tolist()}")
    return Registration(T.copy(), 0.0, 0.0, 0)
