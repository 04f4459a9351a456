"""The formed part compensated to the design: springback included, and learned from scans.

A path compensation (`twin.analysis.compensate.compensate_twin`) makes the tool tip follow the path; the part then
springs back when it is unclamped (the elastic recovery F/k_unload of `twin.process.part.heightmap`, the unsupported
bottom of `twin.process.part.bottom`), so it misses the drawing by about that recovery. Two loops close the gap:

* **Part compensation** (`compensate_part`, on the twin): the target tool path is moved, each sample along z, by the
  twin's predicted surface error of the surface that sample formed (the part after unclamping, minus the design,
  read as `twin.analysis.scan_learning.learn_from_scan(at="formed")` reads a scan), and the robot's deflection is
  compensated again for the new target; `iterations` times. Held fixed: x-y of every sample,
  the timing. The design is a surface z_design(x, y) in the sheet frame (the tool-side sheet surface, z = 0 at the
  unformed sheet's top), from an STL or from the path itself (`design_heights`).
* **Learning from a scan** (part to part, `twin.analysis.scan_learning`): the last part's miss of the twin's
  prediction, held as the twin's error (`discrepancy`), or the last command moved by the scan's error.

Surface errors are normal to the design, per region of it, as `check --target-stl` reports them
(`twin.analysis.surface_check.region_deviation`: wall, bottom, rim, sheet), and for the part itself (`part`: its
wall, bottom and rim together, `part_error`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import trimesh

from twin.analysis.compensate import Compensation, compensate_twin
from twin.analysis.scan_learning import learn_from_scan
from twin.analysis.surface_check import REGIONS, DesignIndex, RegionDeviation, region_deviation
from twin.errors import InputError
from twin.process.part.surface import formed_surface, surface_points
from twin.process.toolpath.groove import ToolPath
from twin.sim.quasi_static import Twin

#: The regions of the design that are the part (the rest is flat sheet).
PART_REGIONS = ("wall", "bottom", "rim")
#: What a stage's surface is: the twin's part after unclamping, or a formed part's scan.
STAGE_KINDS = ("predicted", "scanned")


class PartStage(NamedTuple):
    """One stage of a part on its way to the design, for its figures and recordings.

    Attributes:
        name: What the stage is, e.g. "twin, iteration 1" or "scan: learn 2".
        kind: One of `STAGE_KINDS`.
        deviation: Its points and their signed normal deviation from the design, by region [m].
    """

    name: str
    kind: str
    deviation: RegionDeviation


class PartCompensation(NamedTuple):
    """`compensate_part`'s result.

    Attributes:
        target: The tool path whose formed part (after unclamping) the twin predicts on the design.
        compensation: The twin compensation of `target` (its command is the part-compensated command).
        deviations: The twin's predicted part against the design at each outer iteration (0: path-compensated).
    """

    target: ToolPath
    compensation: Compensation
    deviations: list[RegionDeviation]

    @property
    def error_per_iteration(self) -> list[dict[str, dict[str, float]]]:
        """`part_stats` of each iteration's predicted part [mm]."""
        return [part_stats(d) for d in self.deviations]

    def stages(self) -> list[PartStage]:
        """The iterations as stages ("twin, iteration k", predicted)."""
        return [PartStage(f"twin, iteration {k}", "predicted", d) for k, d in enumerate(self.deviations)]


def part_error(points_m: np.ndarray, design: trimesh.Trimesh | DesignIndex) -> dict[str, dict[str, float]]:
    """Normal deviation of surface points from the design [mm] per region (`region_deviation`), and `part`: the
    wall, bottom and rim together (rms, max |.|, mean, points)."""
    return part_stats(region_deviation(points_m, design))


def part_stats(deviation: RegionDeviation) -> dict[str, dict[str, float]]:
    """`RegionDeviation.stats_mm` and `part`: the wall, bottom and rim together (rms, max |.|, mean, points) [mm]."""
    stats = deviation.stats_mm()
    d = 1e3 * deviation.deviation_m[np.isin(deviation.region, [REGIONS.index(r) for r in PART_REGIONS])]
    stats["part"] = {"rms_mm": float(np.sqrt(np.mean(d**2))), "max_mm": float(np.max(np.abs(d))),
                     "mean_mm": float(np.mean(d)), "points": float(len(d))}
    return stats


def predicted_surface(twin: Twin, t_s: np.ndarray, command_m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The part the twin forms with `command_m`, after unclamping (x, y, z grid) [m]."""
    twin.simulate(t_s, command_m)
    surface = formed_surface(twin.sheet_field)
    if surface is None:
        raise InputError(f"force model {twin.spec.process.force_model!r} keeps no surface; part compensation needs "
                         "a height-map model (--force-model isf)")
    return surface


def compensate_part(
    ideal: ToolPath, twin: Twin, design: trimesh.Trimesh, *, iterations: int = 3, tol_m: float = 10e-6,
    gain: float = 1.0, discrepancy: Callable[[np.ndarray], np.ndarray] | None = None,
    progress: Callable[[str], None] | None = None,
) -> PartCompensation:
    """Move the target path until the twin's formed part after unclamping lies on the design (module docstring).

    Args:
        ideal: The tool path of the design (its x-y are kept).
        twin: The twin (a height-map force model).
        design: The design surface, sheet frame [m].
        iterations: Outer iterations (each one a twin compensation).
        tol_m: The twin compensation's tolerance [m].
        gain: Fraction of the predicted error moved per iteration [-].
        discrepancy: A formed part's vertical miss of the twin's prediction, learned from a scan (the real part's z
            minus the twin's at x-y (n, 2) [m] -> (n,) [m], `twin.analysis.scan_learning.twin_discrepancy`): the
            twin's part is then aimed at the design minus it, and each iteration's reported part is the twin's
            plus it (what the cell is expected to form). None: the twin is taken as right.
        progress: Told of each iteration's predicted part (a line of text), or None.
    """
    if not 0.0 < gain <= 1.0 or iterations < 1:
        raise InputError(f"gain {gain} must be in (0, 1] and iterations {iterations} >= 1")
    target = ideal
    index = DesignIndex(design)
    deviations: list[RegionDeviation] = []
    comp = compensate_twin(ideal.t_s, ideal.p_sheet_m, twin, tol_m=tol_m)
    for _ in range(iterations + 1):
        surface = predicted_surface(twin, target.t_s, comp.p_cmd_sheet_m)
        points = surface_points(*surface)
        if discrepancy is not None:
            points[:, 2] += np.nan_to_num(discrepancy(points[:, :2]))
        deviations.append(region_deviation(points, index))
        if progress is not None:
            part = part_stats(deviations[-1])["part"]
            progress(f"part iteration {len(deviations) - 1}/{iterations}: the twin's part {part['rms_mm']:.3f} mm rms "
                     f"from the design (mean {part['mean_mm']:+.3f} mm)")
        if len(deviations) == iterations + 1:
            break
        p = learn_from_scan(target.p_sheet_m, points, design, gain=gain, tool_radius_m=twin.spec.process.tool_radius_m,
                            at="formed").command_m
        target = replace(target, p_sheet_m=p)
        comp = compensate_twin(target.t_s, target.p_sheet_m, twin, tol_m=tol_m)
    return PartCompensation(target, comp, deviations)
