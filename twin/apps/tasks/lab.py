"""`lab`: a measured run made on the virtual lab (`twin.lab.virtual`: the twin with hidden effects, noise and its
own sensor chain), the thesis's rigid-machine CNC validation (`twin.lab.cnc`), or a Method 1 load-test file (the
load cases of thesis Table 4.2 held at home); the dynamic MuJoCo plant's runs are `twin.apps.tasks.lab_dynamic`'s.
The robot and the declared process resolve as for every task (`twin.analysis.resolve`); a compensated path's
record (`twin.analysis.compensation_record`) travels with the run, for `check`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N
from twin.analysis.resolve import AUTO, resolve_robot, resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.lab_cnc import cnc_task
from twin.apps.tasks.lab_output import LoadTestReport, check_out, with_records, write_load_cases
from twin.base.registry import Registry
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.description import Process
from twin.process.process_file import ProcessDeclaration, process_record
from twin.process.toolpath.placement import Placement
from twin.runs.read import lab_commanded
from twin.runs.write import write_run
from twin.sim.effects import Effects, parse_effect_args
from twin.sim.online_settings import OnlineSettings, check_max_correction_mm, check_max_rate_mm_s
from twin.sim.spec import TwinSpec

SCENARIOS = ("nominal", "compensated", "loadtest", "cnc")


@dataclass(frozen=True)
class LabRequest:
    """What to run on the lab.

    Attributes:
        scenario: "nominal", "compensated" (needs `commanded`), "loadtest" (a CSV of load cases, no sheet) or
            "cnc" (the rigid machine).
        out: The run folder to write (loadtest: a CSV file).
        seed: The seed of the lab's noise.
        commanded: A commanded.csv-format path, or None for the groove.
        effects: Hidden effects of the quasi-static plant, "NAME=VALUE" each (`twin.sim.effects.EFFECTS`).
        plant: "quasi-static" (the twin plus hidden effects) or "dynamic" (a MuJoCo mj_step plant).
        knobs: Dynamic plant knobs, "NAME=VALUE" each (`twin.lab.dynamic.knobs`).
        neutral: Dynamic plant: start from the neutral knobs.
        force_model: A registered force model, or "auto" (`twin.analysis.resolve.choose_force_model`).
        declaration: The declared process (a process file, flags); not for the load test.
        robot: A robot name or description file; None: the default robot.
        placement: The sheet frame in the robot base (nominal and compensated runs; recorded in meta.json).
        overwrite: Replace an existing output.
        online: The dynamic plant's controller compensates online each 4 ms cycle with the twin's compensator
            (`twin.sim.online`), on the plant's own F/T stream.
        model: The model file the online compensator's twin is (a `learn`ed one); None: the default twin.
        cell: The `--cell` file's record (`twin.process.cell_file.CellDeclaration.record`), which the run keeps in
            its meta.json, or None.
        max_correction_mm: The online compensator's size limit on the correction [mm] (`--max-correction-mm`;
            with `online` only).
        max_rate_mm_s: The online compensator's rate limit on the correction [mm/s] (`--max-rate-mm-s`; with
            `online` only): a sheet's friction turning at a reversal steps the correction, which this limit spreads
            over time.
    """

    scenario: str
    out: Path
    seed: int
    commanded: Path | None = None
    effects: tuple[str, ...] = ()
    plant: str = "quasi-static"
    knobs: tuple[str, ...] = ()
    neutral: bool = False
    force_model: str = AUTO
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    robot: str | Path | None = None
    placement: Placement = field(default_factory=Placement)
    overwrite: bool = False
    online: bool = False
    model: Path | None = None
    cell: Mapping[str, Any] | None = None
    max_correction_mm: float = OnlineSettings.max_correction_mm
    max_rate_mm_s: float = OnlineSettings.max_rate_mm_s

    def __post_init__(self) -> None:
        check_max_correction_mm(self.max_correction_mm, online=self.online)
        check_max_rate_mm_s(self.max_rate_mm_s, online=self.online)
        for option, value, valid in (("--scenario", self.scenario, SCENARIOS), ("--plant", self.plant,
                                                                                 tuple(LAB_PLANTS))):
            if value not in valid:
                raise InputError(f"{option} {value!r}: expected one of {', '.join(valid)}")
        if not self.placement.is_default and self.scenario in ("loadtest", "cnc"):
            raise InputError(
                f"--origin-mm/--yaw-deg place the sheet for nominal and compensated runs; --scenario {self.scenario} "
                "keeps the cell's sheet_origin, yaw 0"
            )
        if self.scenario == "loadtest" and self.declaration != ProcessDeclaration():
            raise InputError(
                "--scenario loadtest loads the tool at home, with no sheet: --process, --material, --thickness-mm and "
                "--tool-radius-mm apply to the runs that form one (nominal, compensated, cnc)"
            )
        LAB_PLANTS[self.plant].check(self)


class LabPlant(NamedTuple):
    """A plant the lab runs (`--plant NAME`): the extension point of the labs.

    Attributes:
        name: The `--plant` choice.
        description: One line, for messages.
        check: Refuses a request the plant cannot run (raises `InputError`, naming the option), before any file
            is read.
        run: Runs the request's scenario and writes the run; returns the report.
    """

    name: str
    description: str
    check: Callable[[LabRequest], None]
    run: Callable[[LabRequest, Note], Report]


def _check_quasi_static(request: LabRequest) -> None:
    if request.online or request.model is not None:
        raise InputError("--online and --model run the twin's compensator in a controller: they need --plant dynamic")
    if request.knobs or request.neutral:
        raise InputError("--set and --neutral are knobs of --plant dynamic; the quasi-static lab takes --effect")
    parse_effect_args(list(request.effects))
    if request.scenario == "cnc" and request.effects:
        raise InputError("--scenario cnc is the rigid machine: robot effects (--effect) do not apply")


def _check_dynamic(request: LabRequest) -> None:
    if request.effects:
        raise InputError("--plant dynamic takes no --effect: its effects are physical knobs, set with "
                         "--set NAME=VALUE")
    if request.scenario == "cnc":
        raise InputError("--scenario cnc is the rigid machine; it does not apply to --plant dynamic (a robot)")
    if (request.online or request.model is not None) and request.scenario == "loadtest":
        raise InputError("--online compensates a forming run; --scenario loadtest holds loads at home")
    if request.model is not None and not request.online:
        raise InputError("--model is the online compensator's twin: give --online with it")


def _run_dynamic(request: LabRequest, note: Note) -> Report:
    from twin.apps.tasks.lab_dynamic import dynamic_lab_task  # MuJoCo's plant: only when it runs

    return dynamic_lab_task(request, note)


@dataclass(frozen=True)
class LabRunReport(Report):
    """A nominal or compensated run made on the quasi-static lab.

    Attributes:
        scenario: "nominal" or "compensated".
        out: The run folder written.
        seed: The seed of the lab's noise.
        tracker_samples: Tracker samples measured.
        force_samples: F/T samples measured.
        deviation_max_mm: The largest |measured - commanded| tip position [mm].
        peak_force_n: The largest |F| measured [N].
        peak_fz_n: The largest Fz measured [N].
        process: The process the run formed.
    """

    scenario: str
    out: Path
    seed: int
    tracker_samples: int
    force_samples: int
    deviation_max_mm: float
    peak_force_n: float
    peak_fz_n: float
    process: Process

    def lines(self) -> list[str]:
        return [f"lab {self.scenario}: {self.tracker_samples} tracker / {self.force_samples} force samples, "
                f"max |measured - commanded| {self.deviation_max_mm:.2f} mm, peak |F| {self.peak_force_n:.0f} N "
                f"-> {self.out}"]

    def record(self) -> dict[str, Any]:
        return {"scenario": self.scenario, "out": self.out, "seed": self.seed, "tracker_samples": self.tracker_samples,
                "force_samples": self.force_samples, "measured_deviation_max_mm": self.deviation_max_mm,
                "peak_force_n": self.peak_force_n, "peak_fz_n": self.peak_fz_n,
                "process": {**process_record(self.process), "force_model": self.process.force_model}}


def lab_task(request: LabRequest, note: Note = silent) -> Report:
    """Run the request's scenario on its plant and write the run (or the load-test file).

    Returns:
        A `LoadTestReport`, `LabRunReport`, `lab_cnc.CncReport` or (dynamic plant) `DynamicRunReport`.

    Raises:
        InputError: An existing output without `overwrite`, "compensated" without `commanded`, a bad declaration.
        RunFormatError: A bad commanded path (naming the file and row).
    """
    return LAB_PLANTS.get_named(request.plant).run(request, note)


def _run_quasi_static(request: LabRequest, note: Note) -> Report:
    """The quasi-static lab: the twin with hidden effects (`twin.lab.virtual`), or the rigid CNC machine."""
    effects = parse_effect_args(list(request.effects))
    check_out(request.out, request.overwrite)
    if request.scenario == "loadtest":
        from twin.lab.virtual import load_test

        spec = TwinSpec(robot=resolve_robot(request.robot), effects=effects)
        loads, deflections = load_test(THESIS_TABLE_4_2_LOADS_N, seed=request.seed, spec=spec)
        write_load_cases(request.out, loads, deflections)
        return LoadTestReport(request.out, len(loads))
    if request.scenario == "cnc":
        return cnc_task(request, note)
    return _run(request, effects, note)


def lab_settings(cell: Mapping[str, Any] | None) -> Any:
    """The quasi-static lab's sensors: a `--cell`'s `[sensors]` over the lab's defaults."""
    from twin.lab.virtual import LabSettings  # MuJoCo: only when a lab runs

    sensors = {} if cell is None else dict(cell.get("sensors") or {})
    if "tracker_noise_mm" in sensors:  # the cell file's millimetres, the lab's metres
        sensors["tracker_noise_m"] = 1e-3 * sensors.pop("tracker_noise_mm")
    return LabSettings(**sensors)


def _run(request: LabRequest, effects: Effects, note: Note) -> LabRunReport:
    """A nominal or compensated run on the quasi-static lab."""
    commanded, protect = lab_commanded(request.scenario, request.commanded)
    t_s, p_cmd = commanded.t_s, commanded.values
    spec = resolve_spec(robot=request.robot, declaration=request.declaration, force_model_name=request.force_model,
                        placement=request.placement, p_sheet_m=p_cmd, note=note,
                        cell=request.cell).replace(effects=effects)
    from twin.lab.virtual import run_lab

    run, truth = run_lab(t_s, p_cmd, scenario=request.scenario, seed=request.seed, spec=spec,
                         settings=lab_settings(request.cell))
    run = with_records(run, request, None if spec.tool is None else spec.tool.length_m)
    write_run(request.out, run, truth=truth, overwrite=request.overwrite, protect=protect)
    deviation = np.max(np.linalg.norm(run.tracker.values - interp_rows(run.tracker.t_s, t_s, p_cmd), axis=1))
    forces = run.forces
    return LabRunReport(
        request.scenario, request.out, request.seed, len(run.tracker.t_s),
        len(forces.t_s) if forces is not None else 0, 1e3 * float(deviation),
        float(np.max(np.linalg.norm(forces.values, axis=1))) if forces else 0.0,
        float(np.max(forces.values[:, 2])) if forces else 0.0, spec.process,
    )


#: The lab's plants, by name (`twin.base.registry.Registry`): `LAB_PLANTS.register(LabPlant(...))` adds one.
LAB_PLANTS: Registry[LabPlant] = Registry("lab plant")
LAB_PLANTS.register(LabPlant("quasi-static", "the twin plus hidden effects, noise and its sensor chain",
                             _check_quasi_static, _run_quasi_static))
LAB_PLANTS.register(LabPlant("dynamic", "a MuJoCo mj_step plant with its own servo, gears, friction and sheet",
                             _check_dynamic, _run_dynamic))
