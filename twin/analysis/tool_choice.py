"""Which tool is on the flange, by the one precedence (`PRECEDENCE`): an explicit flag > the run's record > the cell
file > the model file > the robot model's own, length, mass and bending each on its own (the centre of gravity goes
with the mass; a shank's bending is its stiffness at the chosen length's tip). `resolve_tool` is the rule; a program takes its answer as it is (`export`), the twin takes it as the tool it
simulates (`resolve_tool_spec`: `TwinSpec.tool`). The precedence's layers and words (`Chosen`, `first_given`,
`cell_words`) are shared with the sheet's placement (`twin.analysis.resolve.resolve_placement`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from twin.robot.facts import RobotDescription
from twin.robot.tool import ToolSpec
from twin.runs.format import Run

#: Who wins for the sheet's placement and the tool, first to last (docs/process.md's cell section).
PRECEDENCE = ("flag", "run", "cell", "model", "robot default")


@dataclass(frozen=True)
class Chosen:
    """A value and where it came from (`PRECEDENCE`'s layer, in words: "--origin-mm", "the run runs/n1", ...)."""

    value: Any
    source: str


def first_given(layers: Sequence[tuple[str, bool, Any]], default: Chosen) -> Chosen:
    """The first layer that gives a value: `layers` are (source in words, given, value), in `PRECEDENCE` order."""
    for source, given, value in layers:
        if given:
            return Chosen(value, source)
    return default


def cell_words(cell: Mapping[str, Any] | None) -> str:
    """A cell file's record in words: "the cell NAME (FILE)"."""
    return "" if cell is None else f"the cell {cell.get('name')} ({cell.get('file')})"


@dataclass(frozen=True)
class ToolChoice:
    """The tool chosen: its length [mm], mass [kg] and centre of gravity [mm, flange frame] (None: the robot
    model's tool body's), its bending stiffness at the tip [N/mm] (None: rigid), and where each came from."""

    length_mm: float
    mass_kg: float | None
    length_from: str
    mass_from: str
    cog_mm: tuple[float, ...] | None = None
    bending_stiffness_n_per_mm: float | None = None
    bending_from: str = ""


def resolve_tool(
    robot: RobotDescription,
    *,
    length_mm: float | None = None,
    mass_kg: float | None = None,
    run: Run | None = None,
    cell: Mapping[str, Any] | None = None,
    model: ToolSpec | None = None,
    sensor_mass: bool = True,
) -> ToolChoice:
    """The tool by `PRECEDENCE`: `--tool-length-mm` / `--tool-mass-kg`, else the run's (its `cell` record's tool,
    else its `tool_length_m`; its mass the `cell` record's, else, with `sensor_mass`, an import's sensor
    `tool_mass_kg`), else the cell's `[tool]`, else the model file's tool, else robot `robot`'s model.

    Args:
        sensor_mass: Take an import's sensor `tool_mass_kg` (the mass below the F/T sensor its gravity compensation
            used) as the run's tool mass: a program's load data does; the twin's tool body (everything below the
            flange) does not.

    Raises:
        InputError: A run's tool length out of the plausible range (naming its meta.json).
    """
    from twin.process.description import check_plausible

    meta = {} if run is None else run.meta
    run_name = "" if run is None else f"the run {run.directory}"
    run_tool = dict((meta.get("cell") or {}).get("tool") or {})
    run_length = run_tool.get("length_mm")
    if run_length is None and "tool_length_m" in meta:
        run_length = 1e3 * float(meta["tool_length_m"])
        check_plausible("tool_length_m", run_length / 1e3, f"{(run.directory if run else None) or '.'}/meta.json: "
                        f"tool_length_m {run_length / 1e3:g} m")
    if run_tool.get("mass_kg") is None and sensor_mass:
        sensor = meta.get("import", {}).get("sensor", {}).get("tool_mass_kg")
        if isinstance(sensor, int | float) and sensor > 0:
            run_tool = {**run_tool, "mass_kg": float(sensor), "cog_mm": None}
    cell_tool = {} if cell is None else dict(cell.get("tool") or {})
    model_tool: dict[str, Any] = {} if model is None else model.to_json()
    cell_name = cell_words(cell)
    length = first_given([
        ("--tool-length-mm", length_mm is not None, length_mm),
        (run_name, run is not None and run_length is not None, run_length),
        (cell_name, cell_tool.get("length_mm") is not None, cell_tool.get("length_mm")),
        ("the model file", model_tool.get("length_mm") is not None, model_tool.get("length_mm")),
    ], Chosen(1e3 * robot.tool_length_m, f"robot {robot.name}'s model"))
    carrier = first_given([  # the mass and the centre of gravity it acts at come from one layer
        ("--tool-mass-kg", mass_kg is not None, {"mass_kg": mass_kg}),
        (run_name, run is not None and run_tool.get("mass_kg") is not None, run_tool),
        (cell_name, cell_tool.get("mass_kg") is not None, cell_tool),
        ("the model file", model_tool.get("mass_kg") is not None, model_tool),
    ], Chosen({}, f"robot {robot.name}'s model (its tool body)"))
    mass, cog = carrier.value.get("mass_kg"), carrier.value.get("cog_mm")
    bending = first_given([(source, bool(_bending_keys(tool)), tool) for source, tool in (
        (run_name, run_tool if run is not None else {}), (cell_name, cell_tool), ("the model file", model_tool))],
        Chosen({}, "a rigid tool"))
    return ToolChoice(float(length.value), None if mass is None else float(mass), length.source, carrier.source,
                      None if cog is None else tuple(float(v) for v in cog),
                      _tip_stiffness_n_per_mm(bending.value, float(length.value)), bending.source)


def _bending_keys(tool: Mapping[str, Any]) -> dict[str, float]:
    keys = ("diameter_mm", "youngs_modulus_gpa", "bending_stiffness_n_per_mm")
    return {k: float(tool[k]) for k in keys if tool.get(k) is not None}


def _tip_stiffness_n_per_mm(tool: Mapping[str, Any], length_mm: float) -> float | None:
    """The tool's bending stiffness at its tip [N/mm]: as measured, else its shank's at `length_mm`
    (`twin.robot.tool_bending.cantilever_tip_stiffness`, E default steel's); None: no bending declared."""
    from twin.robot.tool_bending import STEEL_YOUNGS_MODULUS_GPA, cantilever_tip_stiffness

    given = _bending_keys(tool)
    if "bending_stiffness_n_per_mm" in given:
        return given["bending_stiffness_n_per_mm"]
    if "diameter_mm" not in given:
        return None
    modulus_gpa = given.get("youngs_modulus_gpa", STEEL_YOUNGS_MODULUS_GPA)
    return cantilever_tip_stiffness(given["diameter_mm"] / 1e3, modulus_gpa * 1e9, length_mm / 1e3) / 1e3


def resolve_tool_spec(
    robot: RobotDescription,
    *,
    run: Run | None = None,
    cell: Mapping[str, Any] | None = None,
    model: ToolSpec | None = None,
) -> ToolSpec | None:
    """The tool the twin simulates (`TwinSpec.tool`): `resolve_tool` without flags or an import's sensor mass; None
    where it is the robot model's own (its length to 1 nm and no mass declared), so a twin without a declared tool
    is the robot model as it is.

    Raises:
        InputError: A run's tool length out of the plausible range (naming its meta.json).
    """
    tool = resolve_tool(robot, run=run, cell=cell, model=model, sensor_mass=False)
    bending = tool.bending_stiffness_n_per_mm
    if tool.mass_kg is None and bending is None and abs(tool.length_mm / 1e3 - robot.tool_length_m) < 1e-9:
        return None
    return ToolSpec.make(tool.length_mm / 1e3, tool.mass_kg,
                         None if tool.cog_mm is None else [v / 1e3 for v in tool.cog_mm],
                         None if bending is None else 1e3 * bending)
