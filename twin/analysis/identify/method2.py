"""Method 2 (thesis sec. 4.2.2, Eqs. 4.18-4.25): the robot's stiffness from a whole nominal run: over x-z, as
the thesis did on its groove, or over x, y and z when the run's ideal forces span all three directions (a cone,
a pyramid: `MIN_FORCE_SPAN`); the axes the data supports, never a block it cannot determine.

The streams are resampled onto the force sensor's samples (the slower stream) inside the tracker's span:
deflection d = tracker - commanded (the tool gives way along the sheet's force), ideal force f_ID = the
field driven rigidly along the commanded path (the FE history's forces), measured force f = forces.csv.
Convention: f (sheet on tool) = K d, the same K as the thesis's F = K_R (U_ID - U_meas) with F the force of
the tool on the sheet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.analysis.identify.cartesian import fit_compliance, fit_kr_from_run
from twin.base.signals import interp_rows
from twin.errors import IdentificationError, RunFormatError
from twin.process.description import Process
from twin.process.force.registry import build_force_field
from twin.process.toolpath.groove import ToolPath, label_passes
from twin.runs.format import Run, resample
from twin.sim.quasi_static import PASS_DEADBAND_M

MIN_FORCE_SPAN = 0.05
"""Smallest over largest singular value of the loaded samples' ideal forces (x, y, z) from which the run supports
the 3x3 fit [-]: the groove's forces lie in the x-z plane (0), a cone's span all three (~0.17)."""
AXIS_NAMES = ("x", "y", "z")


@dataclass(frozen=True)
class Method2Result:
    """Method 2 fits on one run, over `axes` (k of them: rows and columns in that order).

    Attributes:
        k_r_ideal_n_per_m: K from ideal forces, the thesis's variant (Eqs. 4.22-4.25) [N/m], (k, k).
        k_r_measured_n_per_m: K from measured forces [N/m], (k, k).
        c_ideal_m_per_n: Compliance d = C f_ID fitted directly [m/N], (k, k).
        c_measured_m_per_n: Compliance d = C f fitted directly [m/N], (k, k).
        force_drop: RMS of (f_ID - f) over RMS of f_ID, on `axes` [-]: how much the sheet force fell
            because the robot gave way.
        samples: Number of common samples used.
        axes: The axes fitted (0: x, 1: y, 2: z): (0, 2) for x-z, (0, 1, 2) for all.
        force_span: Smallest over largest singular value of the ideal forces (x, y, z) [-] (`MIN_FORCE_SPAN`).
    """

    k_r_ideal_n_per_m: np.ndarray
    k_r_measured_n_per_m: np.ndarray
    c_ideal_m_per_n: np.ndarray
    c_measured_m_per_n: np.ndarray
    force_drop: float
    samples: int
    axes: tuple[int, ...] = (0, 2)
    force_span: float = 0.0

    @property
    def axis_names(self) -> list[str]:
        """The fitted axes' names ("x", "y", "z")."""
        return [AXIS_NAMES[k] for k in self.axes]


def method2(run: Run, process: Process | None = None, axes: tuple[int, ...] | None = None) -> Method2Result:
    """Fit the stiffness of the robot from a nominal run (commanded = ideal path), over the axes its forces span.

    Args:
        run: A nominal run with forces.
        process: The process whose force model, driven rigidly along the command, gives the ideal forces;
            None: the thesis's (the groove's table field of the shipped history).
        axes: The axes to fit ((0, 2): x-z; (0, 1, 2): all); None: all three when the ideal forces span them
            (their singular values' ratio >= `MIN_FORCE_SPAN`), else x-z.

    Raises:
        RunFormatError: The run has no forces.
        IdentificationError: Too few loaded samples, or forces that do not span the axes asked for.
        InputError: `axes` not 2 or 3 distinct axes of 0, 1, 2.
    """
    if run.forces is None:
        raise RunFormatError(run.directory or "run", "Method 2 needs forces.csv (a run without forces)")
    t = run.forces.t_s
    t = t[(t >= run.tracker.t_s[0]) & (t <= run.tracker.t_s[-1]) & (t <= run.commanded.t_s[-1])]
    cmd = run.commanded
    pass_index, direction = label_passes(cmd.values[:, 0], deadband_m=PASS_DEADBAND_M)
    path = ToolPath(t_s=cmd.t_s, p_sheet_m=cmd.values, pass_index=pass_index, direction=direction)
    f_ideal_cmd = build_force_field(process or Process()).rigid_forces(path)
    f_ideal = interp_rows(t, cmd.t_s, f_ideal_cmd)
    f_meas = resample(run.forces, t)
    d = resample(run.tracker, t) - resample(cmd, t)
    loaded = np.linalg.norm(f_ideal, axis=1) > 0.1 * np.max(np.linalg.norm(f_ideal, axis=1))
    if np.sum(loaded) < 10:
        raise IdentificationError(f"only {int(np.sum(loaded))} loaded samples in the run; need at least 10")
    singular = np.linalg.svd(f_ideal[loaded], compute_uv=False)
    span = float(singular[-1] / singular[0])
    if axes is None:
        axes = (0, 1, 2) if span >= MIN_FORCE_SPAN else (0, 2)
    k_ideal = fit_kr_from_run(f_ideal[loaded], d[loaded], axes).k_r_n_per_m  # refuses bad axes
    k_measured = fit_kr_from_run(f_meas[loaded], d[loaded], axes).k_r_n_per_m
    kept = list(axes)
    fi, fm, dd = f_ideal[loaded][:, kept], f_meas[loaded][:, kept], d[loaded][:, kept]
    drop = float(np.sqrt(np.mean((fi - fm) ** 2)) / np.sqrt(np.mean(fi**2)))
    return Method2Result(
        k_r_ideal_n_per_m=k_ideal,
        k_r_measured_n_per_m=k_measured,
        c_ideal_m_per_n=fit_compliance(fi, dd),
        c_measured_m_per_n=fit_compliance(fm, dd),
        force_drop=drop,
        samples=int(np.sum(loaded)),
        axes=tuple(axes),
        force_span=span,
    )
