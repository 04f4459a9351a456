"""Registration of a part scan to its design: the rigid transform from the scanner's frame to the sheet frame.

A laser scan of a formed part comes in the scanner's frame. `register_scan` finds the rigid transform (rotation
and translation, no scale) that lays it on the design mesh (`path --design-stl`) by the iterative closest point
method, point-to-plane (Chen & Medioni 1992): each scan point is paired with the nearest face of the design
(`DesignIndex`: the design's faces split to 1 mm, in a k-d tree), the small rotation and translation that
minimise the squared distances along the faces' normals are solved in closed form (a 6 x 6 least-squares
problem), applied, and the pairing repeated until a step moves less than 1e-6 rad and 0.1 µm. Only points over
the design's interior count (a point beyond the mesh's border pairs with the border, not the surface), and a
step leaves out pairs farther than `max(INLIER_M, 3 × median)` (trimmed ICP: a clamp in the scan does not pull).

A motion the design does not fix (the spin of a cone about its axis) shows as a small eigenvalue of the normal
matrix: a motion that moves the points 1 mm (rotations scaled by their radius of gyration) changing their
distances by less than `FREE_SENSITIVITY` × 1 mm rms. The solve leaves it out (the transform keeps its start
there) and the result names it (`free`); no deviation depends on it.

It starts from the identity (a scan already near the sheet frame: the twin's own `part_scan.csv`, a scanner
calibrated to the cell); when that does not fit, from the principal axes of the scan laid on the design's
(centroids together, the smallest axis on the design's normal, 12 spins about it, both sides up), each refined
on a subsample and the best refined on every point.

*Fit.* The best fit (every point) must leave at least `MIN_INLIER_FRACTION` (98 %) of the points over the design
within `INLIER_M` (2 mm) of it, those points at most `MAX_RMS_M` (1 mm) rms. A formed part misses its design by a
smooth error, its springback and the robot's deflection, within 2 mm everywhere; another part misses it by more
where they differ. Measured on a 45° cone 40 mm across and 5 mm deep (a 1 mm grid scan, docs/any-part.md): the
twin's uncompensated lab part 100 % within 2 mm, rms 0.63 mm; a cone 3 mm deep 100 %, 0.84 mm; a pyramid of
the same size 94.8 % (its corners, to 3.9 mm); a cone 8 mm deep 80.6 %; one 50 mm across 85.5 %. A scan with
more than 2 % of stray points over the part (clamps, reflections) needs cleaning or a lower share.
*Datum.* A best fit splits a form error between the part and its pose: a part 0.6 mm too shallow is laid
0.25 mm lower and reads half its error. With `datum="sheet"` (the default) the flat, unformed sheet around the
part (the clamped sheet, which the forming does not move) then fixes the height and the two tilts, and the
formed part the rest (x, y and the spin), so a deviation reads against the sheet as a CAD check of a part in
its frame does; `datum="best-fit"` keeps the best fit. A scan with too little flat sheet (under `MIN_POINTS`)
keeps the best fit, and says so (`datum`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from twin.analysis.surface_check import (
    COMPARE_BELOW_M,
    WALL_SLOPE_DEG,
    DesignIndex,
    over_interior,
    signed_distance,
)
from twin.errors import InputError

if TYPE_CHECKING:  # trimesh and scipy load when a scan is registered
    import trimesh

INLIER_M = 2e-3  # a scan point fits when it lies this close to the design [m]
MIN_INLIER_FRACTION = 0.98  # share of the points over the design that must fit [-]
MAX_RMS_M = 1e-3  # largest rms distance of the fitting points after the best fit [m]
FREE_SENSITIVITY = 0.05  # a motion changing the distances by less than this per unit of motion is free [-]
MAX_ITERATIONS = 60
STEP_ROTATION_RAD, STEP_TRANSLATION_M = 1e-6, 1e-7  # converged below these steps
COARSE_POINTS, COARSE_ITERATIONS, COARSE_SPINS = 600, 25, 12
MIN_POINTS = 50
DATUMS = ("sheet", "best-fit")
_MOTIONS = ("rotation about x", "rotation about y", "rotation about z", "translation along x",
            "translation along y", "translation along z")


@dataclass(frozen=True)
class ScanRegistration:
    """The scan's pose on its design: p_sheet = R p_scan + t.

    Attributes:
        T_design_scan: Homogeneous transform, scanner frame to sheet frame (4, 4) [m].
        residual_rms_m: RMS normal distance of the fitting points (within `INLIER_M`) after the best fit [m].
        inlier_fraction: Share of the points over the design that fit, after the best fit [-].
        points: Scan points over the design.
        iterations: ICP iterations of the last refinement.
        start: `identity` or `principal axes`.
        datum: `sheet` or `best-fit` (module docstring).
        free: Motions the design does not fix (e.g. `rotation about z` for a cone), left where the start put
            them (the identity, the principal axes or, with the sheet datum, the best fit).
    """

    T_design_scan: np.ndarray
    residual_rms_m: float
    inlier_fraction: float
    points: int
    iterations: int
    start: str
    datum: str
    free: tuple[str, ...]

    @property
    def rotation_deg(self) -> np.ndarray:
        """The rotation as extrinsic x, y, z angles [deg] (3,)."""
        from scipy.spatial.transform import Rotation

        return np.asarray(Rotation.from_matrix(self.T_design_scan[:3, :3]).as_euler("xyz", degrees=True))

    @property
    def translation_m(self) -> np.ndarray:
        """The translation t [m] (3,)."""
        return np.asarray(self.T_design_scan[:3, 3], dtype=float)

    def apply(self, points_m: np.ndarray) -> np.ndarray:
        """Scan points in the sheet frame [m] (n, 3)."""
        return _transform(self.T_design_scan, np.asarray(points_m, dtype=float))

    def summary_mm(self) -> dict[str, object]:
        """The numbers for a report: angles [deg], translation [mm], residual [mm]."""
        return {
            "registration_rotation_deg": [float(v) for v in self.rotation_deg],
            "registration_translation_mm": [float(v) for v in 1e3 * self.translation_m],
            "registration_rms_mm": 1e3 * self.residual_rms_m,
            "registration_inlier_fraction": self.inlier_fraction,
            "registration_points": self.points,
            "registration_start": self.start,
            "registration_datum": self.datum,
            "registration_free": list(self.free),
        }


@dataclass(frozen=True)
class _Fit:
    T: np.ndarray
    rms_m: float
    fraction: float
    points: int
    iterations: int
    datum: str
    free: tuple[str, ...]

    def fits(self, max_rms_m: float, min_fraction: float) -> bool:
        return self.fraction >= min_fraction and self.rms_m <= max_rms_m and self.points >= MIN_POINTS

    @property
    def score(self) -> tuple[float, float]:
        return (-self.fraction * self.points, self.rms_m)  # most fitting points first


def _transform(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ T[:3, :3].T + T[:3, 3]


def _solve(J: np.ndarray, r: np.ndarray, columns: Sequence[int]) -> tuple[np.ndarray, list[str]]:
    """The least-squares step of `columns` of the motion for residuals r + J x, without its free directions."""
    A = J[:, columns].T @ J[:, columns]
    values, vectors = np.linalg.eigh(A)
    fixed = values > FREE_SENSITIVITY**2 * len(r)
    x = vectors[:, fixed] @ ((vectors[:, fixed].T @ (-J[:, columns].T @ r)) / values[fixed])
    return x, [_MOTIONS[columns[int(np.argmax(np.abs(v)))]] for v in vectors[:, ~fixed].T]


def _icp(scan: np.ndarray, index: DesignIndex, T0: np.ndarray, iterations: int, datum: str) -> _Fit:
    """Point-to-plane trimmed ICP from `T0` (module docstring)."""
    from scipy.spatial.transform import Rotation

    T, used, done = T0.copy(), datum, 0
    free: list[str] = []
    for done in range(1, iterations + 1):  # noqa: B007 (reported)
        moved = _transform(T, scan)
        over = over_interior(moved, index.mesh)
        if over.sum() < MIN_POINTS:
            break
        p = moved[over]
        r, c, n = index.nearest(p)
        keep = np.abs(r) <= max(INLIER_M, 3.0 * float(np.median(np.abs(r))))
        p, r, c, n = p[keep], r[keep], c[keep], n[keep]
        centre = p.mean(axis=0)
        q = p - centre
        scale = float(np.sqrt(np.mean(np.sum(q**2, axis=1)))) or 1.0
        J = np.hstack([np.cross(q, n) / scale, n])  # d r / d (rotation × scale, translation)
        x = np.zeros(len(_MOTIONS))
        sheet = (n[:, 2] > math.cos(math.radians(WALL_SLOPE_DEG))) & (c[:, 2] > -COMPARE_BELOW_M)
        used = datum if min(sheet.sum(), (~sheet).sum()) >= MIN_POINTS else "best-fit"
        if used == "sheet":  # the sheet: height and tilts; then the part: x, y and the spin
            x[[0, 1, 5]], free = _solve(J[sheet], r[sheet], [0, 1, 5])
            part = ~sheet
            rest, free_part = _solve(J[part], r[part] + J[part][:, [0, 1, 5]] @ x[[0, 1, 5]], [2, 3, 4])
            x[[2, 3, 4]] = rest
            free += free_part
        else:
            x, free = _solve(J, r, range(len(_MOTIONS)))
        omega, tau = x[:3] / scale, x[3:]
        step = np.eye(4)
        step[:3, :3] = Rotation.from_rotvec(omega).as_matrix()
        step[:3, 3] = centre + tau - step[:3, :3] @ centre
        T = step @ T
        if np.linalg.norm(omega) < STEP_ROTATION_RAD and np.linalg.norm(tau) < STEP_TRANSLATION_M:
            break
    return _score(scan, index, T, done, used, tuple(free))


def _score(scan: np.ndarray, index: DesignIndex, T: np.ndarray, iterations: int, datum: str,
           free: tuple[str, ...]) -> _Fit:
    moved = _transform(T, scan)
    over = over_interior(moved, index.mesh)
    if over.sum() == 0:
        return _Fit(T, math.inf, 0.0, 0, iterations, datum, free)
    r = np.abs(signed_distance(index.mesh_mm, moved[over])[1])
    inlier = r <= INLIER_M
    rms = float(np.sqrt(np.mean(r[inlier] ** 2))) if inlier.any() else math.inf
    return _Fit(T, rms, float(inlier.mean()), int(over.sum()), iterations, datum, free)


def _principal_starts(scan: np.ndarray, design: trimesh.Trimesh) -> list[np.ndarray]:
    """Coarse starts: centroids together, principal axes on the design's, `COARSE_SPINS` spins, both sides up."""
    from scipy.spatial.transform import Rotation

    def frame(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        centre = points.mean(axis=0)
        axes = np.linalg.svd(points - centre, full_matrices=False)[2].T  # columns: largest to smallest spread
        if np.linalg.det(axes) < 0:
            axes[:, 1] *= -1.0
        return centre, axes

    c_scan, a_scan = frame(scan)
    c_design, a_design = frame(np.asarray(design.vertices))
    starts = []
    for flip in (np.eye(3), np.diag([1.0, -1.0, -1.0])):
        for k in range(COARSE_SPINS):
            spin = Rotation.from_rotvec([0.0, 0.0, 2.0 * math.pi * k / COARSE_SPINS]).as_matrix()
            T = np.eye(4)
            T[:3, :3] = a_design @ spin @ flip @ a_scan.T
            T[:3, 3] = c_design - T[:3, :3] @ c_scan
            starts.append(T)
    return starts


def register_scan(
    points_m: np.ndarray,
    design: trimesh.Trimesh | DesignIndex,
    *,
    datum: str = "sheet",
    max_rms_m: float = MAX_RMS_M,
    min_inlier_fraction: float = MIN_INLIER_FRACTION,
    seed: int = 0,
) -> ScanRegistration:
    """Register scan points to a design mesh (module docstring): identity first, then principal axes.

    Args:
        points_m: Scan points in the scanner's frame [m] (n, 3).
        design: The design surface, sheet frame [m] (e.g. `read_target_mesh` of `path --design-stl`), or its index.
        datum: `sheet` (the flat sheet fixes height and tilts) or `best-fit`.
        max_rms_m: Largest rms distance of the fitting points after the best fit [m].
        min_inlier_fraction: Smallest share of the points over the design within `INLIER_M` of it [-].
        seed: Seed of the subsample of the coarse starts.

    Raises:
        InputError: Not (n, 3) finite points, a bad datum or threshold, or the scan does not fit the design
            (its residual, its share of fitting points and the thresholds in the message).
    """
    scan = np.asarray(points_m, dtype=float)
    if scan.ndim != 2 or scan.shape[1] != 3 or len(scan) < MIN_POINTS or not np.all(np.isfinite(scan)):
        raise InputError(f"scan points must be at least {MIN_POINTS} finite (n, 3) values; got shape {scan.shape}")
    if datum not in DATUMS:
        raise InputError(f"datum = {datum!r}: expected one of {', '.join(DATUMS)}")
    if not (max_rms_m > 0 and 0 < min_inlier_fraction <= 1):
        raise InputError(f"max_rms_m = {max_rms_m!r} must be > 0, min_inlier_fraction = {min_inlier_fraction!r} "
                         "in (0, 1]")
    index = design if isinstance(design, DesignIndex) else DesignIndex(design)
    fit, start = _icp(scan, index, np.eye(4), MAX_ITERATIONS, "best-fit"), "identity"
    if not fit.fits(max_rms_m, min_inlier_fraction):
        sample = scan[np.random.default_rng(seed).choice(len(scan), min(COARSE_POINTS, len(scan)), replace=False)]
        coarse = min((_icp(sample, index, T, COARSE_ITERATIONS, "best-fit")
                      for T in _principal_starts(scan, index.mesh)), key=lambda f: f.score)
        refined = _icp(scan, index, coarse.T, MAX_ITERATIONS, "best-fit")
        if refined.score < fit.score:
            fit, start = refined, "principal axes"
    if not fit.fits(max_rms_m, min_inlier_fraction):
        span = float(np.max(np.ptp(scan, axis=0))) * 1e3
        raise InputError(
            f"the scan does not fit the design: after the best registration (from the {start}) "
            f"{100.0 * fit.fraction:.1f} % of its {fit.points} points over the design lie within "
            f"{INLIER_M * 1e3:g} mm of it (at least {100.0 * min_inlier_fraction:g} % needed), rms "
            f"{fit.rms_m * 1e3:.3f} mm (at most {max_rms_m * 1e3:g} mm); the scan spans {span:.4g} mm, the design "
            f"{float(np.max(index.mesh.extents)) * 1e3:.4g} mm: a scan of another part, in other units, or a part "
            "formed worse than the thresholds allow (`check --fit-fraction`, `--fit-rms-mm`)?"
        )
    final = _icp(scan, index, fit.T, MAX_ITERATIONS, datum) if datum == "sheet" else fit
    return ScanRegistration(final.T, fit.rms_m, fit.fraction, fit.points, final.iterations, start, final.datum,
                            final.free)
