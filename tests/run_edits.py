"""Data-level edits of a measured run, written by the tests themselves (a change the twin and the plant did not
make): the run read, one stream changed by the test's own function, written back as a run."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.runs.format import Stream
from twin.runs.read import read_run
from twin.runs.write import write_run


def with_forces(run_dir: Path, out: Path, change: Callable[[np.ndarray], np.ndarray]) -> Path:
    """A copy of the run at `run_dir` written to `out` whose F/T samples are `change(forces)` [N], (m, 3)."""
    run = read_run(run_dir)
    assert run.forces is not None
    return write_run(out, replace(run, forces=Stream(run.forces.t_s, change(run.forces.values.copy()))))
