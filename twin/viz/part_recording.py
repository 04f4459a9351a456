"""Rerun recordings of a part on its way to the design: the design surface, and at each stage (the twin's
predicted part at each part-compensation iteration, the scan of each formed part) the surface coloured by its
normal deviation from the design, with the per-region rms plotted over the stages.

Entities (sheet frame, metres, z up): `world/design` (mesh, static), `world/predicted` and `world/scanned`
(points at the stage's step of the `stage` timeline, the other one cleared), `plots/rms_mm/<region>`, `README`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
import trimesh
from matplotlib import colormaps

from twin.analysis.part_compensation import STAGE_KINDS as KINDS
from twin.analysis.part_compensation import PartStage
from twin.analysis.surface_check import REGIONS
from twin.base.csvio import check_not_an_input
from twin.errors import InputError
from twin.viz.rrd_file import save_recording

TIMELINE = "stage"
POINT_RADIUS_M = 3e-4


def deviation_colors(deviation_m: np.ndarray, limit_m: float) -> np.ndarray:
    """RGB (n, 3) uint8 of signed deviations on the maps' diverging scale (red: too shallow) within +-limit [m]."""
    scaled = 0.5 + 0.5 * np.clip(np.asarray(deviation_m) / max(limit_m, 1e-9), -1.0, 1.0)
    return (255 * colormaps["RdBu_r"](scaled)[:, :3]).astype(np.uint8)


def _readme(stages: Sequence[PartStage], limit_m: float) -> str:
    lines = ["# The part against its design, stage by stage", "",
             "Sheet frame [m], z up, z = 0 at the unformed sheet's top. `design`: the design surface; `predicted`: the "
             "twin's part after unclamping; `scanned`: a formed part's scan. Colour: normal deviation from the design, "
             f"red too shallow, blue too deep, saturated at +-{1e3 * limit_m:.3f} mm.", "",
             "| stage | kind | " + " | ".join(f"{r} rms [mm]" for r in REGIONS) + " |",
             "|---|---|" + "---|" * len(REGIONS)]
    for stage in stages:
        stats = stage.deviation.stats_mm()
        cells = [f"{stats[r]['rms_mm']:.3f}" if r in stats else "" for r in REGIONS]
        lines.append(f"| {stage.name} | {stage.kind} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def record_part(
    path: str | Path,
    design: trimesh.Trimesh,
    stages: Sequence[PartStage],
    *,
    protect: Sequence[str | Path] = (),
    application_id: str = "tx200-twin",
) -> Path:
    """Record the design and each stage's surface and deviation into a `.rrd` (module docstring).

    Args:
        path: The `.rrd` to write (atomically).
        design: The design surface, sheet frame [m].
        stages: The stages in order (at least one).
        protect: Inputs the recording must never overwrite.
        application_id: Rerun application id.

    Raises:
        InputError: No stage, or a stage of another kind than `KINDS`.
    """
    target = Path(path)
    check_not_an_input(target, protect)
    if not stages:
        raise InputError("a part recording needs at least one stage")
    bad = [s.kind for s in stages if s.kind not in KINDS]
    if bad:
        raise InputError(f"stage kind {bad[0]!r} is not one of {', '.join(KINDS)}")
    limit = max(float(np.max(np.abs(s.deviation.deviation_m))) for s in stages)

    def log(rec: rr.RecordingStream) -> None:
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log("world/design", rr.Mesh3D(vertex_positions=np.asarray(design.vertices),
                                          triangle_indices=np.asarray(design.faces),
                                          albedo_factor=[0.75, 0.75, 0.75, 0.35]), static=True)
        rec.log("README", rr.TextDocument(_readme(stages, limit), media_type=rr.MediaType.MARKDOWN), static=True)
        for k, stage in enumerate(stages):
            rec.set_time(TIMELINE, sequence=k)
            dev = stage.deviation
            rec.log(f"world/{stage.kind}", rr.Points3D(dev.points_m, colors=deviation_colors(dev.deviation_m, limit),
                                                       radii=POINT_RADIUS_M, labels=None))
            for other in KINDS:
                if other != stage.kind:
                    rec.log(f"world/{other}", rr.Clear(recursive=False))
            rec.log("stage_name", rr.TextLog(stage.name))
            for region, stats in stage.deviation.stats_mm().items():
                rec.log(f"plots/rms_mm/{region}", rr.Scalars(stats["rms_mm"]))

    blueprint = rrb.Blueprint(rrb.Horizontal(
        rrb.Spatial3DView(origin="/world", name="part"),
        rrb.Vertical(rrb.TimeSeriesView(origin="/plots/rms_mm", name="rms by region [mm]"),
                     rrb.TextDocumentView(origin="/README", name="notes"), row_shares=[1, 1]),
        column_shares=[3, 2]), collapse_panels=True)
    return save_recording(target, blueprint, log, application_id=application_id)
