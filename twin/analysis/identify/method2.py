"""Method 2 (thesis sec. 4.2.2, Eqs. 4.18-4.25): the robot's x-z stiffness from a whole nominal run.

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


@dataclass(frozen=True)
class Method2Result:
    """Method 2 fits on one run (x-z).

    Attributes:
        k_r_ideal_n_per_m: K from ideal forces, the thesis's variant (Eqs. 4.22-4.25) [N/m], (2, 2).
        k_r_measured_n_per_m: K from measured forces [N/m], (2, 2).
        c_ideal_m_per_n: Compliance d = C f_ID fitted directly [m/N], (2, 2).
        c_measured_m_per_n: Compliance d = C f fitted directly [m/N], (2, 2).
        force_drop: RMS of (f_ID - f) over RMS of f_ID, x and z [-]: how much the sheet force fell
            because the robot gave way.
        samples: Number of common samples used.
    """

    k_r_ideal_n_per_m: np.ndarray
    k_r_measured_n_per_m: np.ndarray
    c_ideal_m_per_n: np.ndarray
    c_measured_m_per_n: np.ndarray
    force_drop: float
    samples: int


def method2(run: Run, process: Process | None = None) -> Method2Result:
    """Fit the x-z stiffness of the robot from a nominal run (commanded = ideal path).

    Args:
        run: A nominal run with forces.
        process: The process whose force model, driven rigidly along the command, gives the ideal forces;
            None: the thesis's (the groove's table field of the shipped history).

    Raises:
        RunFormatError: The run has no forces.
        IdentificationError: Too few loaded samples.
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
    xz = [0, 2]
    fi, fm, dd = f_ideal[loaded][:, xz], f_meas[loaded][:, xz], d[loaded][:, xz]
    drop = float(np.sqrt(np.mean((fi - fm) ** 2)) / np.sqrt(np.mean(fi**2)))
    return Method2Result(
        k_r_ideal_n_per_m=fit_kr_from_run(fi, dd).k_r_n_per_m,
        k_r_measured_n_per_m=fit_kr_from_run(fm, dd).k_r_n_per_m,
        c_ideal_m_per_n=fit_compliance(fi, dd),
        c_measured_m_per_n=fit_compliance(fm, dd),
        force_drop=drop,
        samples=int(np.sum(loaded)),
    )
