"""How much the stand-in FE history's Fx taper costs the ISF model along the groove.

The shipped stand-in (`twin.process.fe.generator`) tapers Fx over the arc length *since* the last reversal
(causal). The alternative, `fx_taper="nearest"`, tapers over the arc length to the *nearest* reversal, so before
the tool reverses as well as after, which no causal model can follow. This script reports the ISF
model's Fx and Fz errors against both, with the constants fitted to the shipped stand-in (`calibrate_isf`: the
groove factor, μ_t, L_f, Δz_min) and refitted to each, and where the remaining Fx error lies.

Run: `.venv/bin/python experiments/fx_causal_taper.py` (about 10 s).
"""

from __future__ import annotations

import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.base.csvio import write_table
from twin.process.fe.generator import generate_history
from twin.process.fe.load import load_force_history
from twin.process.force.isf_calibration import calibrate_isf, groove_errors
from twin.process.force.isf_params import IsfForceParams

NEAR_BEFORE, NEAR_AFTER = 3, 5  # samples around each reversal counted as "at the reversal"


def history(fx_taper: str, directory: Path):
    columns = generate_history(fx_taper=fx_taper)
    return load_force_history(write_table(directory / f"{fx_taper}.csv", columns), symmetry="half")


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        shipped, acausal = history("since", Path(tmp)), history("nearest", Path(tmp))
    params = calibrate_isf(shipped, replace(IsfForceParams(), mu_eff=0.3)).params
    for name, h in (("shipped (taper since the reversal)", shipped), ("old (taper to the nearest reversal)", acausal)):
        rms_fz, rms_fx, forces = groove_errors(params, h)
        refit = calibrate_isf(h)
        path, ref = h.to_path(), h.f_sheet_n  # pass labels of the samples (turns between samples put back)
        err = (forces[:, 0] - ref[:, 0]) ** 2
        near = np.zeros(len(err), dtype=bool)
        for r in np.flatnonzero(np.diff(path.pass_index) != 0):
            near[max(0, r - NEAR_BEFORE) : r + NEAR_AFTER + 1] = True
        away = np.sqrt(err[~near].mean()) / np.abs(ref[:, 0]).max()
        print(
            f"{name}: Fz {100 * rms_fz:.1f} %, Fx {100 * rms_fx:.1f} % of peak (refitted: Fx {100 * refit.rms_fx:.1f} %); "
            f"{100 * err[near].sum() / err.sum():.0f} % of the Fx squared error within {NEAR_BEFORE} samples before and "
            f"{NEAR_AFTER} after the reversals, {100 * away:.1f} % away from them"
        )


if __name__ == "__main__":
    main()
