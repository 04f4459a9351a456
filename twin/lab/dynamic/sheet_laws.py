"""The dynamic plant's sheet laws: one protocol, chosen by the knob `sheet_law`.

The plant forms its own sheet; which physical law pushes back on the tool is a plant setting the twin never sees
(it is recorded in `truth.json`). Every law forms its own surface along the real tool tip and answers the same
calls each servo tick (`force` at the tip, then `advance` through it), and the same questions after the run (the
loaded and unloaded sections, the unloaded surface for the part scan).

* 1: `twin.lab.dynamic.sheet.PlantSheet`, a membrane wrapped across the tool (Silva et al.'s membrane analysis);
* 2: `twin.lab.dynamic.sheet_patch.PatchSheet`, a contact patch: the sphere's penetration into the formed surface
  over the nodes under the tool on an elastic-plastic foundation (another form, another hardening law).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from twin.lab.dynamic.knobs import Knobs
from twin.process.description import Process


class SheetLaw(Protocol):
    """What the plant's stepping loop and its sensors ask of a sheet (units SI, sheet frame)."""

    x_m: np.ndarray  # grid columns [m], (nx,)
    y_m: np.ndarray  # grid rows [m], (ny,)

    def start(self, p_sheet_m: np.ndarray, direction: float) -> None:
        """Where the tool starts [m] and the direction along x it starts to travel (+1 or -1)."""

    def force(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """Force of the sheet on the tool [N], (3,), at tip `p_sheet_m` [m]; pure."""

    def advance(self, p_sheet_m: np.ndarray) -> None:
        """Commit: the tool tip passed through `p_sheet_m` [m]."""

    def section(self) -> tuple[np.ndarray, np.ndarray]:
        """The loaded surface along y = 0: x [m], z [m]."""

    def unloaded_section(self) -> tuple[np.ndarray, np.ndarray]:
        """The surface after unclamping along y = 0: x [m], z [m]."""

    def unloaded_surface(self) -> np.ndarray:
        """The surface after unclamping [m], (ny, nx)."""


def make_sheet(knobs: Knobs, process: Process) -> SheetLaw:
    """The sheet law the knobs choose, for this declared sheet and tool.

    Args:
        knobs: The plant's knobs (`sheet_law`, `friction_reversal_mm`, `timestep_s`, `sheet_grid_mm`,
            `sheet_side_read_radii`, `sheet_side_read_band`).
        process: The sheet and tool formed (thickness, tool radius, friction, R_m).
    """
    reversal_m = 1e-3 * knobs["friction_reversal_mm"]
    timestep_s, spacing_m = knobs["timestep_s"], 1e-3 * knobs["sheet_grid_mm"]
    if int(knobs["sheet_law"]) == 2:
        from twin.lab.dynamic.sheet_patch import PatchSheet

        return PatchSheet(process, reversal_m, timestep_s, spacing_m)
    from twin.lab.dynamic.sheet import PlantSheet

    return PlantSheet(process, reversal_m, timestep_s, spacing_m, knobs["sheet_side_read_radii"],
                      knobs["sheet_side_read_band"])
