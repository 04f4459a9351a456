"""Where a twin's compensation leaves the tool off the sheet while the ideal path is in it.

The twin's compensation moves each command sample until the simulated tip lies on the ideal path; the deflection
it takes off comes from the force its sheet predicts there. Where that sheet predicts no force although the ideal
path goes into the sheet, the command carries no compensation at those samples, between neighbours compensated by
millimetres: a hump the arm will not follow, and a part that misses there. A learned sheet does this outside what
its runs showed: one learned from a cone, on the plant's second law, predicts no force where a groove's pass turns
back onto the material it has just formed (how many samples, and what the command then missed: CHANGELOG). Such a
command is written, since the sheet may be right (a pass over material already formed that deep), but
`compensate` warns (`off_sheet_warning`), naming how many samples and the first.
"""

from __future__ import annotations

import numpy as np

#: The ideal path is in the sheet this far below the sheet's plane [m] (the sheet frame's z = 0): past the
#: tracker's noise and the first contact.
IN_SHEET_M = 1e-3
#: A sample whose predicted axial force is below this share of the median over the samples in the sheet is off
#: the sheet [-].
OFF_SHARE = 0.05


def off_sheet_warning(t_s: np.ndarray, p_ideal_sheet_m: np.ndarray, f_sheet_n: np.ndarray) -> str | None:
    """The warning for the samples where the twin's predicted force is nil while the ideal path is in the sheet.

    Args:
        t_s: The command's sample times [s], shape (n,).
        p_ideal_sheet_m: The ideal path, sheet frame [m], shape (n, 3).
        f_sheet_n: The force the twin predicted at each sample for its command, sheet frame [N], shape (n, 3).

    Returns:
        The sentence naming the count and the first such sample, or None when there is none.
    """
    inside = p_ideal_sheet_m[:, 2] < -IN_SHEET_M
    if not inside.any():
        return None
    fz = np.abs(f_sheet_n[:, 2])
    off = inside & (fz < OFF_SHARE * float(np.median(fz[inside])))
    if not off.any():
        return None
    first = int(np.flatnonzero(off)[0])
    x, y, z = 1e3 * p_ideal_sheet_m[first]
    return (f"the twin's compensation leaves the tool off the sheet at {int(off.sum())} of the {int(inside.sum())} "
            f"samples where the ideal path is in it (first at {t_s[first]:.2f} s, ({x:.1f}, {y:.1f}, {z:.1f}) mm): "
            "its sheet predicts no force there, so the command carries no deflection compensation there and the "
            "part will miss (a learned sheet outside what its runs showed, such as a pass turning back onto "
            "material it has just formed)")
