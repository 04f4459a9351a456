"""`lab --plant dynamic`: a measured run (or a Method 1 load-test file) made on the dynamic plant
(`twin.lab.dynamic`: MuJoCo's mj_step with the robot's joint friction, gear play and servo loops, its own sheet and
sensor chain), its effects set as physical knobs (`twin.lab.dynamic.knobs`); the request is `twin.apps.tasks.lab`'s,
and its progress goes to the task's `Note`."""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.analysis.compensation_record import CompensationRecord
from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N
from twin.analysis.resolve import resolve_process, resolve_robot, resolve_spec
from twin.analysis.tool_choice import cell_words, resolve_tool_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.lab_output import (
    LoadTestReport,
    check_out,
    compensation_record,
    with_records,
    write_load_cases,
)
from twin.base.csvio import write_table
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.lab.dynamic.knobs import parse_set_args
from twin.lab.dynamic.online import OnlineLog
from twin.lab.dynamic.run import dynamic_load_test, run_dynamic_lab
from twin.process.description import Process
from twin.runs.format import Stream
from twin.runs.read import lab_commanded
from twin.runs.write import write_run
from twin.sim.online import AssumedForces, OnlineCompensator
from twin.sim.online_settings import AT_LIMIT_MM, OnlineSettings

if TYPE_CHECKING:
    from twin.apps.tasks.lab import LabRequest


@dataclass(frozen=True)
class DynamicRunReport(Report):
    """A nominal or compensated run made on the dynamic plant.

    Attributes:
        scenario: "nominal" or "compensated".
        out: The run folder written.
        seed: The seed of the tracker's noise.
        knobs_changed: The knobs that differ from their neutral values.
        tracker_samples: Tracker samples measured.
        force_samples: F/T samples measured.
        deviation_max_mm: The largest |measured - commanded| tip position [mm].
        peak_force_n: The largest |F| measured [N].
        steps: The servo ticks simulated.
        wall_s: Wall time of the simulation [s].
    """

    scenario: str
    out: Path
    seed: int
    knobs_changed: dict[str, float]
    tracker_samples: int
    force_samples: int
    deviation_max_mm: float
    peak_force_n: float
    steps: int
    wall_s: float
    online: dict[str, float] | None = None

    def lines(self) -> list[str]:
        lines = [f"lab {self.scenario} (dynamic plant, {self.steps} steps in {self.wall_s:.1f} s): "
                 f"{self.tracker_samples} tracker / {self.force_samples} force samples, "
                 f"max |measured - commanded| {self.deviation_max_mm:.2f} mm, "
                 f"peak |F| {self.peak_force_n:.0f} N -> {self.out}"]
        if self.online is not None:
            o = self.online
            lines.append(f"  online: {o['cycles']:.0f} cycles, correction up to {o['correction_max_mm']:.2f} mm, "
                         f"compute p50 {o['compute_p50_us']:.1f} / p99 {o['compute_p99_us']:.1f} / max "
                         f"{o['compute_max_us']:.0f} µs per cycle")
            if o["at_limit_share"] > 0.0:  # the cell needs more than the compensator may give: say so
                lines.append(f"  online: the correction sat at its limit ({o['limit_mm']:.1f} mm, "
                             f"max_correction_mm) in {100.0 * o['at_limit_share']:.1f} % of the cycles")
            if o["lost_on_command_cycles"] > 0.0:  # the command has a detour the robot cut short
                lines.append(f"  online: the robot was lost on the offline command (a detour of it cut short) in "
                             f"{o['lost_on_command_cycles']:.0f} cycles; the force the command assumed was taken at "
                             "the nearest of its segments ahead")
        return lines

    def record(self) -> dict[str, Any]:
        online = {} if self.online is None else {"online": self.online}
        return {"scenario": self.scenario, "plant": "dynamic", "out": self.out, "seed": self.seed,
                "knobs_changed_from_neutral": self.knobs_changed, "tracker_samples": self.tracker_samples,
                "force_samples": self.force_samples, "measured_deviation_max_mm": self.deviation_max_mm,
                "peak_force_n": self.peak_force_n, "simulation_wall_s": self.wall_s, **online}


def dynamic_lab_task(request: LabRequest, note: Note = silent) -> Report:
    """Run the request's scenario (nominal, compensated or loadtest) on the dynamic plant and write it.

    Returns:
        A `LoadTestReport` or a `DynamicRunReport`.

    Raises:
        InputError: An existing output without `overwrite`, "compensated" without `commanded`, a bad knob, a bad
            declaration, a plant that diverged.
    """
    check_out(request.out, request.overwrite)
    process = Process()
    if request.scenario != "loadtest":
        commanded, protect = lab_commanded(request.scenario, request.commanded)
        process = resolve_process(process, request.declaration, request.force_model, commanded.values, note=note)
    record = compensation_record(request)
    robot = resolve_robot(request.robot)
    knobs = parse_set_args(cell_knobs(request.cell, request.knobs), neutral=request.neutral)
    tool = resolve_tool_spec(robot, cell=request.cell)  # the cell's tool is the plant's
    if request.scenario == "loadtest":
        loads, deflections = dynamic_load_test(THESIS_TABLE_4_2_LOADS_N, knobs=knobs, seed=request.seed, robot=robot,
                                               tool=tool)
        write_load_cases(request.out, loads, deflections)
        return LoadTestReport(request.out, len(loads), plant="dynamic")
    p_cmd = commanded.values
    compensator = None
    if request.online:  # the twin beside the controller, at the run's placement
        spec = resolve_spec(model=request.model, robot=robot, placement=request.placement, p_sheet_m=p_cmd,
                            cell=request.cell)
        compensator = OnlineCompensator(spec, OnlineSettings(max_correction_mm=request.max_correction_mm,
                                                             max_rate_mm_s=request.max_rate_mm_s),
                                        assumed=assumed_forces(record, commanded))
    run, truth, log = run_dynamic_lab(
        commanded.t_s, p_cmd, scenario=request.scenario, knobs=knobs, seed=request.seed, progress=_NoteStream(note),
        process=process, placement=request.placement, robot=robot, corrector=compensator, tool=tool,
    )
    truth["force_model"] = process.force_model
    run = with_records(run, request)  # the compensation record (for `check`) and the cell travel with the run
    if compensator is not None:
        run = replace(run, meta={**run.meta, "online": online_record(compensator, request.model)})
    # the true tip at the tracker's stamps, for an experiment to score a result on beside the tracker
    tip = Stream(run.tracker.t_s, interp_rows(run.tracker.t_s, log.t_s, log.p_tip_sheet_m))
    write_run(request.out, run, truth=truth, truth_tip=tip, overwrite=request.overwrite, protect=protect)
    if log.online is not None:
        write_online_log(request.out / ONLINE_LOG, log.online)
    deviation = run.tracker.values - interp_rows(run.tracker.t_s, run.commanded.t_s, p_cmd)
    assert run.forces is not None
    lost = 0 if compensator is None else compensator.cycles_lost_on_command
    return DynamicRunReport(
        request.scenario, request.out, request.seed, knobs.changed(), len(run.tracker.t_s), len(run.forces.t_s),
        1e3 * float(np.max(np.linalg.norm(deviation, axis=1))),
        float(np.max(np.linalg.norm(run.forces.values, axis=1))), log.t_s.size, log.wall_s,
        None if log.online is None else online_summary(log.online, request.max_correction_mm, lost),
    )


def cell_knobs(cell: Mapping[str, Any] | None, typed: Sequence[str] | None) -> list[str]:
    """The plant's `--set` items: those typed, then a `--cell`'s `[sensors]` (rates and noise of its tracker and F/T
    sensor, the plant's knobs of the same names) for the knobs not typed: a typed `--set` wins, as every flag
    over a cell.

    Raises:
        InputError: A cell's sensor value outside the plant's range for that knob (naming the cell file).
    """
    items = list(typed or ())
    typed_names = {item.partition("=")[0].strip() for item in items}
    for name, value in dict((cell or {}).get("sensors") or {}).items():
        if name in typed_names:
            continue
        item = f"{name}={float(value)!r}"
        try:
            parse_set_args([item])
        except InputError as exc:
            raise InputError(f"{cell_words(cell)} [sensors] {exc}") from exc
        items.append(item)
    return items


def assumed_forces(record: CompensationRecord | None, commanded: Stream) -> AssumedForces | None:
    """The forces an offline-compensated command assumed (its compensation record), each at its command sample's
    tool tip: the online compensator looks them up by where along the command the controller's joints are.

    Only what the PC beside a controller has: the command and its record. The plant's controller re-times the
    command (it stops at sharp corners) by its own rules; the compensator does not take them from the plant.

    Returns:
        The tips [m] and forces [N] (`AssumedForces`), sheet frame; None for a command without a record.
    """
    if record is None:
        return None
    return AssumedForces(interp_rows(record.t_s, commanded.t_s, commanded.values), record.f_used_n)


#: What the online compensator did, each cycle, beside the run's files (not part of the run format).
ONLINE_LOG = "online.csv"


def online_record(compensator: OnlineCompensator, model: Path | None) -> dict[str, Any]:
    """The meta.json entry of an online run: the compensator's settings and its twin."""
    from dataclasses import asdict

    return {"settings": asdict(compensator.settings), "model": None if model is None else str(model),
            "log": ONLINE_LOG}


def write_online_log(path: Path, log: OnlineLog) -> None:
    """Each cycle: time, correction [mm] (sheet frame), compute time [µs], status code."""
    write_table(path, {"t_s": log.t_s, "dx_mm": 1e3 * log.correction_m[:, 0], "dy_mm": 1e3 * log.correction_m[:, 1],
                       "dz_mm": 1e3 * log.correction_m[:, 2], "compute_us": 1e6 * log.compute_s,
                       "status": log.status},
                formats={"t_s": ".4f", "dx_mm": ".5f", "dy_mm": ".5f", "dz_mm": ".5f", "compute_us": ".2f"})


def online_summary(log: OnlineLog, limit_mm: float, lost_cycles: int = 0) -> dict[str, float]:
    """The correction's largest size [mm], the share of cycles it sat at its size limit `limit_mm` [mm] (a cell
    whose deflection the limit leaves uncorrected), the cycles the robot was lost on an offline command
    (`lost_cycles`, `OnlineCompensator.cycles_lost_on_command`), and the per-cycle compute time's p50, p99 and max
    [µs]."""
    compute = 1e6 * log.compute_s[1:]  # the first cycle compiles nothing but warms caches
    size_mm = 1e3 * np.linalg.norm(log.correction_m, axis=1)
    return {"cycles": float(log.t_s.size), "correction_max_mm": float(np.max(size_mm)), "limit_mm": float(limit_mm),
            "at_limit_share": float(np.mean(size_mm >= limit_mm - AT_LIMIT_MM)),
            "lost_on_command_cycles": float(lost_cycles),
            "compute_p50_us": float(np.percentile(compute, 50)), "compute_p99_us": float(np.percentile(compute, 99)),
            "compute_max_us": float(np.max(compute))}


class _NoteStream(io.StringIO):
    """A text stream that says each whole line written to it as a `Note` (the plant's progress)."""

    def __init__(self, note: Note) -> None:
        super().__init__()
        self._note = note
        self._pending = ""

    def write(self, text: str) -> int:
        *done, self._pending = (self._pending + text).split("\n")
        for line in done:
            self._note(line)
        return len(text)
