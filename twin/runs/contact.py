"""Whether a run's F/T stream saw the tool form the sheet at all: a sensor not connected, not switched on or read
on the wrong channel gives a flat stream, and a fit to it returns the fit's lower bounds as if they were the
cell's (`identify --forces` fitted a force scale of 0.05 to all-zero forces, issue #46)."""

from __future__ import annotations

import numpy as np

from twin.errors import InputError
from twin.runs.format import Run

#: The least peak |F| a forming run's sensor shows [N]: an eighth of the smallest steady axial force of the
#: published measurements the force model is held to (docs/force-validation.md: Bharti et al. 2024, a 71° AA1050-O
#: cone, 381 N), and ten times an F/T sensor's noise per axis at this range (the lab's 5 N).
MIN_FORMING_PEAK_N = 50.0


def require_forming_contact(run: Run, what: str) -> None:
    """Refuse a run whose F/T stream never rises above `MIN_FORMING_PEAK_N`.

    Args:
        run: The run (its forces; a run without them is its reader's error, not this one's).
        what: What needs the forces, for the message ("`identify --forces`").

    Raises:
        InputError: Naming the run, its peak force and what was expected.
    """
    if run.forces is None or not len(run.forces.t_s):
        return
    peak = float(np.max(np.linalg.norm(run.forces.values, axis=1)))
    if peak < MIN_FORMING_PEAK_N:
        raise InputError(f"run {run.directory}: its F/T stream peaks at {peak:.1f} N, below the {MIN_FORMING_PEAK_N:g} N "
                         f"any forming run shows: no forming contact in the sensor's data (a sensor not connected, "
                         f"not switched on, or read on the wrong channel?); {what} needs the forming forces")
