"""The part's springback learned from the cell: three global springback constants fitted to a formed part's scan.

Forces do not show how far a part springs back once unclamped; a scan does. The nominal part is formed anyway
(its F/T stream gives the forces, `twin.analysis.identify.forces`), so its scan gives the springback: the twin
replays the run's command (the robot's deflection under the model's forces, the sheet's height map) and its
predicted part after unclamping is compared with the scan. The scan is registered to that predicted part, not
to the design (`twin.analysis.scan_registration`, the flat sheet as datum: it fixes the height and the tilts, the
part x, y and the spin): a nominal part sits off the design's centre by the robot's deflection (a 45° cone Ø 80
mm: 0.9 mm), which a registration to the design would take away. The twin's part may miss the scan by the very
springback it does not know (the dynamic plant's Ø 80 mm cone: 1.0 mm rms), so the registration's thresholds are
looser than `check`'s (`REGISTRATION_RMS_M`); the scan is registered again to the part the fit found and fitted
again (`PASSES`), and a fit that leaves more than `MAX_FIT_RMS_M` rms is refused (another part). The
design classes the points (wall, bottom, rim). Three constants of the model's springback
(`twin.process.part.surface.springback_surface`) are fitted by least squares:

    z_after = depth_ratio · min(min(z_loaded + recovery_scale · F_z/k_unload, 0) + wall_tilt_scale · lift, 0)

`recovery_scale` scales the elastic recovery the twin predicts (the sheet's unloading stiffness k_unload, as a
forming engineer's "elastic springback of the wall"), `depth_ratio` is the depth the part keeps of it (a global
loss of depth on unclamping, as the thesis's rigid CNC kept 8.7 mm of 10 mm), `wall_tilt_scale` the wall's turn
about its top when the load is released (`twin.process.part.wall_tilt`: the model's, 1, from scanned cones). The
residual of a scan point is its
distance to the predicted surface along that surface's normal, to first order: (z_scan - z_pred(x, y)) /
sqrt(1 + |∇z_pred|²), over the points the design classes as the part (wall, bottom, rim). This is model
identification: three global numbers, the same everywhere on the part; it corrects no point on its own (that is
the learning from scans, `twin.analysis.part_compensation.learn_from_scan`).

The fit uses the run's command and scan and the design only; `truth.json` is never read.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import trimesh
from scipy.interpolate import RegularGridInterpolator
from scipy.optimize import least_squares

from twin.analysis.scan_registration import ScanRegistration, register_scan
from twin.analysis.surface_check import REGIONS, DesignIndex, region_deviation
from twin.errors import InputError
from twin.process.part.surface import DESIGN_MARGIN_M, cropped_surface, heightmap_mesh, springback_surface
from twin.runs.format import Run
from twin.sim.spec import TwinSpec

#: Fitted constants: (name, lower bound, upper bound) [-].
FITTED = (("recovery_scale", 0.01, 10.0), ("depth_ratio", 0.5, 1.5), ("wall_tilt_scale", 0.0, 10.0))
#: Registration to the twin's part before the fit (it may miss the scan by the springback it does not know): rms
#: [m] and share of points within 2 mm; then the fit must leave at most `MAX_FIT_RMS_M` rms [m].
REGISTRATION_RMS_M, REGISTRATION_FRACTION, MAX_FIT_RMS_M = 3e-3, 0.9, 1e-3
#: Registration and fit passes (the second registers to the part the first fitted).
PASSES = 2
#: The design regions whose scan points the fit uses.
FIT_REGIONS = ("wall", "bottom", "rim")


class SpringbackFit(NamedTuple):
    """`fit_springback`'s result.

    Attributes:
        springback_fit: The fitted constants (name, value), for `Process.force_fit`.
        rms_before_m: RMS normal distance of the scan from the predicted part with the model's constants [m].
        rms_after_m: The same with the fitted constants [m].
        points: Scan points used.
        evaluations: Residual evaluations the fit took.
        registration: The scan's registration to the twin's predicted part.
    """

    springback_fit: tuple[tuple[str, float], ...]
    rms_before_m: float
    rms_after_m: float
    points: int
    evaluations: int
    registration: ScanRegistration


def springback_residual(
    surface: tuple[np.ndarray, np.ndarray, np.ndarray], points_m: np.ndarray
) -> np.ndarray:
    """Distance of points from a surface z(x, y) along its normal, to first order [m], + above; NaN off the grid.

    Args:
        surface: (x_m (nx,), y_m (ny,), z_m (ny, nx)) [m], uniform grid.
        points_m: Points, same frame [m] (n, 3).
    """
    x, y, z = surface
    gy, gx = np.gradient(z, y, x)
    at = np.asarray(points_m)[:, [1, 0]]
    grid = (y, x)
    z_p = RegularGridInterpolator(grid, z, bounds_error=False, fill_value=np.nan)(at)
    sx = RegularGridInterpolator(grid, gx, bounds_error=False, fill_value=np.nan)(at)
    sy = RegularGridInterpolator(grid, gy, bounds_error=False, fill_value=np.nan)(at)
    return np.asarray((points_m[:, 2] - z_p) / np.sqrt(1.0 + sx**2 + sy**2))


def fit_springback(run: Run, spec: TwinSpec, design: trimesh.Trimesh | DesignIndex) -> SpringbackFit:
    """Fit the twin's springback constants to the run's part scan (module docstring).

    Args:
        run: A formed part's run with its scan (`part_scan.csv`).
        spec: The twin that replays it (a height-map force model; its process's `force_fit` the start and the
            forces, e.g. those `identify --forces` fitted to the same run).
        design: The design surface, sheet frame [m] (its regions select the points).

    Raises:
        InputError: The run has no scan, the scan does not fit the twin's predicted part, or the force model keeps
            no surface.
    """
    if run.part_scan is None:
        raise InputError(f"run {run.directory}: identify --springback needs the formed part's scan (part_scan.csv); "
                         "the run has none")
    twin = spec.build()
    twin.simulate(run.commanded.t_s, run.commanded.values)
    field = twin.sheet_field
    if getattr(field, "map", None) is None or not hasattr(field, "k_unload"):
        raise InputError(f"force model {spec.process.force_model!r} keeps no surface; identify --springback needs "
                         "a height-map model (--force-model isf)")
    names = [name for name, _, _ in FITTED]
    start = dict(spec.process.force_fit)
    lo, hi = np.array([f[1] for f in FITTED]), np.array([f[2] for f in FITTED])
    v0 = np.clip([start.get(name, 1.0) for name in names], lo + 1e-9, hi - 1e-9)
    index = design if isinstance(design, DesignIndex) else DesignIndex(design)
    v, evaluations = v0, 0
    for _ in range(PASSES):  # register to the twin's part, fit; again to the fitted part
        predicted = heightmap_mesh(*cropped_surface(*springback_surface(field, *v), DESIGN_MARGIN_M))
        registration = register_scan(run.part_scan, predicted, max_rms_m=REGISTRATION_RMS_M,
                                     min_inlier_fraction=REGISTRATION_FRACTION)
        deviation = region_deviation(registration.apply(run.part_scan), index)
        points = deviation.points_m[np.isin(deviation.region, [REGIONS.index(r) for r in FIT_REGIONS])]
        points = points[np.isfinite(springback_residual(springback_surface(field, *v0), points))]
        if len(points) < 10 * len(FITTED):
            raise InputError(f"run {run.directory}: only {len(points)} scan points lie on the twin's part; the scan "
                             "and the run's command do not show the same part")

        def residual(values: np.ndarray, points: np.ndarray = points) -> np.ndarray:
            return springback_residual(springback_surface(field, *values), points)

        result = least_squares(residual, v, bounds=(lo, hi), x_scale=np.ones(len(v)) * 0.1, diff_step=1e-4)
        v, evaluations = result.x, evaluations + int(result.nfev)
    after = _rms(result.fun)
    if after > MAX_FIT_RMS_M:
        raise InputError(f"run {run.directory}: the twin's part with the best springback constants still misses the "
                         f"scan by {1e3 * after:.3f} mm rms (at most {1e3 * MAX_FIT_RMS_M:g} mm): a scan of another "
                         "part, or a part the twin's springback model does not describe")
    fit = tuple((name, float(value)) for name, value in zip(names, v, strict=True))
    return SpringbackFit(fit, _rms(residual(v0)), after, len(points), evaluations, registration)


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values**2)))
