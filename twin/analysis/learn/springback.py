"""The sheet's springback learned from the runs' part profiles: how far the cell's part recovers once unclamped.

Forces do not show how far a part springs back; a profile of the formed part does (`part_profile.csv`: the
groove's centre line after unclamping, as the cell's profilometer reads it). The learned twin replays each run's
command; its loaded section z_loaded(x) and the force each point last carried give the predicted section

    z_after(x) = depth_ratio · min(z_loaded(x) + recovery_scale · F_z,last(x) / k_unload, 0)

(`twin.process.part.springback`, the model's elastic recovery), and the two constants are fitted by least squares to
the measured profile over the formed points (deeper than `FORMED_BELOW_M`). A run with a 3-D part scan instead
needs its design to be registered: `identify --springback RUN --design STL` fits these two there, and the scale
of the wall's tilt a 3-D part shows (`twin.process.part.wall_tilt`; a groove's centre line has no such wall).
`truth.json` is never read.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from twin.process.part.springback import last_contact_force
from twin.runs.format import Run, run_placement
from twin.sim.spec import TwinSpec

#: A profile point counts as formed below this depth [m].
FORMED_BELOW_M = 0.2e-3
#: Bounds of (recovery_scale, depth_ratio).
BOUNDS = ((1e-3, 0.5), (20.0, 1.5))


class SpringbackFit(NamedTuple):
    """`fit_springback`'s result (fitted).

    Attributes:
        recovery_scale: Factor on the model's elastic recovery F/k_unload [-].
        depth_ratio: The depth the part keeps of it [-].
        rms_before_mm: Per run, RMS of the measured minus the model's profile, both constants 1 [mm].
        rms_after_mm: The same with the fitted constants [mm].
        at_bound: The constants that ended on a bound of `BOUNDS` (the model's form could not take the profile
            there: e.g. a part that recovers less than the model allows, recovery_scale at its floor).
    """

    recovery_scale: float
    depth_ratio: float
    rms_before_mm: tuple[float, ...]
    rms_after_mm: tuple[float, ...]
    at_bound: tuple[str, ...] = ()


def _sections(run: Run, spec: TwinSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(measured z, loaded z, predicted recovery) at the run's profile points [m]."""
    assert run.part_profile is not None
    twin = spec.replace(placement=run_placement(run.meta)).build()
    sim = twin.simulate(run.commanded.t_s, run.commanded.values)
    field = twin.sheet_field
    recovery = last_contact_force(sim.formed_x_m, sim.p_sheet_m[:, 0], sim.f_sheet_n[:, 2], field.radius)
    x, z = run.part_profile
    return (np.asarray(z), np.interp(x, sim.formed_x_m, sim.formed_z_m),
            np.interp(x, sim.formed_x_m, recovery / field.k_unload))


def fit_springback(runs: list[Run], spec: TwinSpec) -> SpringbackFit | None:
    """Fit the springback's two constants to the runs' part profiles (module docstring); None where no run has
    one, or none of its points is formed.

    Args:
        runs: The runs (those without `part_profile.csv` are skipped).
        spec: The learned twin (its forces and robot predict the loaded part).
    """
    sections = [_sections(run, spec) for run in runs if run.part_profile is not None]
    sections = [(z, zl, r) for z, zl, r in sections if np.any(z < -FORMED_BELOW_M)]
    if not sections:
        return None

    def predicted(values: np.ndarray, zl: np.ndarray, r: np.ndarray) -> np.ndarray:
        return values[1] * np.minimum(zl + values[0] * r, 0.0)

    def residual(values: np.ndarray) -> np.ndarray:
        return np.concatenate([(predicted(values, zl, r) - z)[z < -FORMED_BELOW_M] for z, zl, r in sections])

    fit = least_squares(residual, np.array([1.0, 1.0]), bounds=BOUNDS)
    scale, ratio = (float(v) for v in fit.x)

    def rms(values: np.ndarray, z: np.ndarray, zl: np.ndarray, r: np.ndarray) -> float:
        keep = z < -FORMED_BELOW_M
        return 1e3 * float(np.sqrt(np.mean((predicted(values, zl, r) - z)[keep] ** 2)))

    at_bound = tuple(name for name, value, low, high in zip(("recovery_scale", "depth_ratio"), fit.x, *BOUNDS,
                                                             strict=True) if min(value - low, high - value) < 1e-3 * (high - low))
    return SpringbackFit(scale, ratio, tuple(rms(np.array([1.0, 1.0]), *s) for s in sections),
                         tuple(rms(fit.x, *s) for s in sections), at_bound)
