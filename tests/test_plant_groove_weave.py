"""The plant's groove does not hold a tool that weaves across it: the groove is formed where the tool goes.

What the KR 210's deepest groove passes show on the plant, offline and online alike (docs/online.md): the tool
weaves across the groove. Driven rigidly (no robot), the sheet's lateral force is fitted along passes whose path
weaves sinusoidally across the groove; its part in phase with the weave is a lateral stiffness (negative: it
pushes the tool further out). A tool held still off the centre of the same groove is pushed back. The numbers are
the page's (docs/dynamic-plant.md), read before the claims.
"""

from __future__ import annotations

import copy

import numpy as np
from doc_numbers import quoted

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.metrics import resample, rigid_forces
from twin.lab.dynamic.sheet_laws import make_sheet
from twin.process.description import Process
from twin.process.toolpath.groove import groove_path

DEEP_M = (7.0e-3, 8.5e-3)  # the passes that weave: this deep below the sheet [m]
HALF_LENGTH_M = 0.025  # and within this of the groove's middle, away from its reversals [m]
WAVELENGTH_M = 0.022  # the weave's wavelength along the travel (1.5 Hz at the groove's 2 m/min) [m]
PROBE_DEPTH_M = 7.5e-3  # the still tool's depth [m]


def _lateral_stiffness_on_a_weave(law: int, amplitude_m: float) -> tuple[float, float]:
    """The lateral force's part in phase with the weave, over its lateral offset [N/m], on the forward and the return
    passes (a least-squares fit of F_y to the offset, its slope along the travel and a constant)."""
    p = resample(groove_path().p_sheet_m)
    weave = (-p[:, 2] > DEEP_M[0]) & (-p[:, 2] < DEEP_M[1]) & (np.abs(p[:, 0]) < HALF_LENGTH_M)
    p[weave, 1] = amplitude_m * np.sin(2.0 * np.pi * p[weave, 0] / WAVELENGTH_M)
    f = rigid_forces(make_sheet(Knobs({"sheet_law": law}), Process()), p)
    travel = np.sign(np.gradient(p[:, 0]))
    slope = np.gradient(p[:, 1]) / np.gradient(p[:, 0]) * travel
    out = []
    for direction in (1.0, -1.0):
        sel = weave & (travel == direction)
        fit = np.linalg.lstsq(np.column_stack([p[sel, 1], slope[sel], np.ones(sel.sum())]), f[sel, 1], rcond=None)[0]
        out.append(float(fit[0]))
    return out[0], out[1]


def _still_tool_stiffness(offset_m: float = 2e-4) -> float:
    """A tool held still `offset_m` to either side of the groove's middle at `PROBE_DEPTH_M`, the groove formed
    rigidly up to there (law 1): the change of the lateral force over the offset [N/m]."""
    p = resample(groove_path().p_sheet_m)
    middle = np.flatnonzero(np.abs(p[:, 0]) < 2e-3)
    stop = int(middle[np.argmin(np.abs(-p[middle, 2] - PROBE_DEPTH_M))])
    sheet = make_sheet(Knobs({"sheet_law": 1}), Process())
    rigid_forces(sheet, p[:stop])
    fy = [copy.deepcopy(sheet).force(p[stop] + np.array([0.0, dy, 0.0]))[1] for dy in (-offset_m, offset_m)]
    return float((fy[1] - fy[0]) / (2.0 * offset_m))


def test_the_groove_does_not_hold_a_tool_that_weaves_as_the_page_says() -> None:
    said = quoted("dynamic-plant.md", "weaving across it by 0.2 mm, its lateral force in phase with the weave is", 4)
    small_1, small_2 = _lateral_stiffness_on_a_weave(1, 2e-4), _lateral_stiffness_on_a_weave(2, 2e-4)
    for q, k in zip(said, (*small_1, *small_2), strict=True):
        q.check(1e-6 * k, slack=2.0)  # [kN/mm]; two units of the printed digit: the fit's floating point
    wide = quoted("dynamic-plant.md", "by 0.5 mm, law 1's holds it (", 2)
    large_1 = _lateral_stiffness_on_a_weave(1, 5e-4)
    for q, k in zip(wide, large_1, strict=True):
        q.check(1e-6 * k, slack=2.0)
    still = quoted("dynamic-plant.md", "7.5 mm deep is pushed back (", 1)
    k_still = _still_tool_stiffness()
    still[0].check(1e-6 * k_still, slack=2.0)
    assert min(*small_1, *small_2) > 0.0  # pushed out along the weave, under either law
    assert max(large_1) < 0.0 and k_still < 0.0  # held at a wider weave, and held still
