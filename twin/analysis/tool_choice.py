"""The tool the twin simulates (`TwinSpec.tool`), by the precedence of `twin.analysis.resolve.PRECEDENCE`: a run's
record, a cell file's `[tool]`, a model file's `tool`, the robot model's own (issue #46)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from twin.robot.description import RobotDescription
from twin.robot.tool import ToolSpec
from twin.runs.format import Run


def resolve_tool_spec(
    robot: RobotDescription,
    *,
    run: Run | None = None,
    cell: Mapping[str, Any] | None = None,
    model: ToolSpec | None = None,
) -> ToolSpec | None:
    """The tool the twin simulates (`TwinSpec.tool`) by `PRECEDENCE`, length and mass each on its own (the centre
    of gravity goes with the mass): the run's record (its `tool_length_m`, the tool it was made with, else its `cell`
    record's tool length; its `cell` record's mass), else the cell's `[tool]`, else the model file's, else robot
    `robot`'s own. An import's sensor `tool_mass_kg` (the sensor's gravity compensation) is not taken for the twin.
    None where the tool is the robot model's: its length (to 1 nm) and no mass declared, so a twin without a declared
    tool is the robot model as it is.

    Raises:
        InputError: A run's tool length out of the plausible range (naming its meta.json).
    """
    from twin.process.description import check_plausible

    meta = {} if run is None else run.meta
    run_tool = dict((meta.get("cell") or {}).get("tool") or {})
    if "tool_length_m" in meta:
        run_tool["length_mm"] = 1e3 * check_plausible(
            "tool_length_m", float(meta["tool_length_m"]),
            f"{(run.directory if run else None) or '.'}/meta.json: tool_length_m")
    cell_tool = {} if cell is None else dict(cell.get("tool") or {})
    model_tool: dict[str, Any] = {} if model is None else model.to_json()
    length_mm = next((float(t["length_mm"]) for t in (run_tool, cell_tool, model_tool)
                      if t.get("length_mm") is not None), 1e3 * robot.tool_length_m)
    carrier = next((t for t in (run_tool, cell_tool, model_tool) if t.get("mass_kg") is not None), {})
    mass, cog = carrier.get("mass_kg"), carrier.get("cog_mm")
    if mass is None and abs(length_mm / 1e3 - robot.tool_length_m) < 1e-9:
        return None
    return ToolSpec.make(length_mm / 1e3, None if mass is None else float(mass),
                         None if cog is None else [float(v) / 1e3 for v in cog])
