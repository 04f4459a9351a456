"""`replay`: a run's commanded path simulated on the twin, and the gap to its measurements; optionally its
figure (measured vs simulated on each axis x, y, z) and its rerun recording."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from twin.analysis.replay import ReplayResult, replay
from twin.analysis.resolve import AUTO, resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.base.csvio import check_not_an_input
from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.process.force.span import warn_outside_span
from twin.process.process_file import ProcessDeclaration, process_record
from twin.runs.read import read_run
from twin.sim.dynamic_servo import ServoModel
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:
    from twin.analysis.learn.split import GapSplit

FORCES = ("twin", "measured")


@dataclass(frozen=True)
class ReplayRequest:
    """What to replay.

    Attributes:
        run_dir: A tx200-twin-run/1 folder.
        model: A model file (`learn --write-model`, `discrepancy --model-out`), or None for the default cell.
        declaration: The process declared over the model's and the run's (a process file, flags).
        force_model: A registered force model, or "auto" (`twin.analysis.resolve.choose_force_model`).
        robot: A robot name or description file; it must be the run's.
        forces: "twin": the twin's own forces; "measured": also drive the twin's robot by the run's F/T stream
            and split the gap into the robot's part and the sheet's.
        rrd: A rerun recording to write, or None.
        figure: A figure to write (PNG): the measured and the simulated tool tip minus the commanded one on each
            axis x, y, z [mm] against time [s]; never over an input; or None.
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
        dynamic: Step the arm in time (`twin.sim.dynamic`) under the model's servo (`learn --dynamic`: predicted),
            or one fitted on this run where the model has none (`fit_servo`: fitted); the quasi-static replay's gap
            is reported beside it.
    """

    run_dir: Path
    model: Path | None = None
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    force_model: str = AUTO
    robot: str | Path | None = None
    forces: str = "twin"
    rrd: Path | None = None
    figure: Path | None = None
    cell: dict[str, Any] | None = None
    dynamic: bool = False

    def __post_init__(self) -> None:
        if self.forces not in FORCES:
            raise InputError(f"forces {self.forces!r}: expected one of {', '.join(FORCES)}")
        inputs = [p for p in (self.run_dir, self.model) if p is not None]
        for output in (self.figure, self.rrd):
            if output is not None:
                check_not_an_input(output, inputs)


@dataclass(frozen=True)
class ReplayReport(Report):
    """A replay and its gap.

    Attributes:
        run_dir: The run replayed.
        spec: The twin it was replayed on.
        result: The prediction and its metrics (`twin.analysis.replay.replay_metrics`).
        split: With forces="measured": the gap split into the robot's part and the sheet's, and where the robot's
            part lies, above 0.5 Hz and near the controller's stops (`twin.analysis.learn.split.GapSplit`, [mm]);
            with dynamic too, the robot's part with the arm moving; else None.
        figure: The figure written, or None.
        servo: With dynamic: the servo of the dynamic replay (`twin.sim.dynamic.ServoModel`), the result the
            dynamic replay's; else None.
        servo_fitted: Whether that servo was fitted on this run (else the model's).
        quasi_static_rms_mm: With dynamic: the quasi-static replay's position gap [mm rms], else None.
    """

    run_dir: Path
    spec: TwinSpec
    result: ReplayResult
    split: GapSplit | None = None
    figure: Path | None = None
    servo: ServoModel | None = None
    quasi_static_rms_mm: float | None = None
    servo_fitted: bool = False

    def metrics(self) -> dict[str, Any]:
        """The replay's metrics, with the split when there is one."""
        m: dict[str, Any] = dict(self.result.metrics)
        if (s := self.split) is not None:
            m.update(robot_gap_rms_mm=s.robot_rms_mm, sheet_gap_rms_mm=s.sheet_rms_mm, robot_gap_fast_mm=s.robot_fast_mm,
                     robot_gap_near_stop_share=s.robot_near_stop, samples_near_stop_share=s.samples_near_stop)
            if self.servo is not None:
                m.update(robot_gap_moving_rms_mm=s.robot_moving_mm)
        if self.servo is not None:
            m.update(quasi_static_position_rms_mm=self.quasi_static_rms_mm, dynamic_servo={
                **self.servo.to_json(), "fitted_on_this_run": self.servo_fitted})
        return m

    def lines(self) -> list[str]:
        m, process = self.result.metrics, self.spec.process
        lines = [
            f"replay {self.run_dir}: {m['samples']} tracker samples; "
            f"position gap rms {m['position_rms_mm']:.3f} mm (max {m['position_max_mm']:.3f}); "
            f"force gap rms {m.get('force_rms_n', float('nan')):.1f} N "
            f"(max {m.get('force_max_n', float('nan')):.1f}); "
            f"measured deflection max {m['deflection_max_mm']:.2f} mm; process {process.material}, "
            f"{1e3 * process.thickness_m:g} mm, {process.force_model} model"
        ]
        if (s := self.split) is not None:
            from twin.analysis.learn.split import FAST_HZ, NEAR_STOP_S

            lines.append(f"  split: the robot's part (the twin's robot driven by the measured forces) "
                         f"{s.robot_rms_mm:.3f} mm rms; the sheet's part (what the twin's forces move the "
                         f"tip by) {s.sheet_rms_mm:.3f} mm rms")
            stops = "" if s.samples_near_stop == 0.0 else (
                f"; {100 * s.robot_near_stop:.0f} % of its mean square within {NEAR_STOP_S:g} s of the "
                f"controller's stops, where {100 * s.samples_near_stop:.0f} % of the samples are")
            lines.append(f"  the robot's part: {s.robot_fast_mm:.3f} mm rms above {FAST_HZ:g} Hz (faster than a "
                         f"quasi-static robot follows){stops}")
            if self.servo is not None:
                lines.append(f"  with the arm moving (the dynamic twin's arm driven by the measured forces under the "
                             f"servo below): {s.robot_moving_mm:.3f} mm rms")
        if self.servo is not None:
            servo, whose = self.servo, "fitted on this run" if self.servo_fitted else "the model's (predicted)"
            lines.append(f"  dynamic (the arm stepped in time, docs/dynamic-twin.md), its servo {whose}: "
                         f"bandwidth {servo.bandwidth_over_mode:.2f} x each joint's mode, damping "
                         f"{servo.damping_ratio:.2f}, delay {1e3 * servo.delay_s:.1f} ms, feed-forward "
                         f"{servo.feedforward:.2f}, load fed forward {servo.load_feedforward:.2f}; the quasi-static "
                         f"replay's gap {self.quasi_static_rms_mm:.3f} mm rms")
        return lines

    def record(self) -> dict[str, Any]:
        process = {**process_record(self.spec.process), "force_model": self.spec.process.force_model}
        figure = {} if self.figure is None else {"figure": self.figure}
        return {"run": self.run_dir, **self.metrics(), "process": process, **figure}


def replay_task(request: ReplayRequest, note: Note = silent) -> ReplayReport:
    """Replay a run on the twin its request resolves to (`twin.analysis.resolve.resolve_spec`).

    Raises:
        InputError: Another robot than the run's, forces="measured" on a run without forces.csv.
        RunFormatError: A bad run folder (naming the file and row).
    """
    measured = read_run(request.run_dir)
    spec = resolve_spec(cell=request.cell, model=request.model, robot=request.robot, run=measured, declaration=request.declaration,
                        force_model_name=request.force_model, note=note)
    warn_outside_span(spec.process, measured.commanded.values, f"the run {request.run_dir}",
                      measured.tracker.values)  # the depth its tip reached, the turns its command made
    twin = spec.build()
    result = replay(measured, twin)
    servo = quasi_static_rms = None
    if request.dynamic:
        from twin.analysis.learn.servo_fit import dynamic_replay, fit_servo, prepare

        dynamic, quasi_static_rms = prepare(measured, twin), float(result.metrics["position_rms_mm"])
        # the model's (predicted), else fitted here (driven by the measured forces where the stream is fast enough)
        servo = spec.dynamic_servo or fit_servo(measured, twin).servo
        result = dynamic_replay(measured, dynamic, servo)
    split = None
    if request.forces == "measured":
        from twin.analysis.learn.split import split_gap

        if measured.forces is None:
            raise InputError(f"run {request.run_dir} has no forces.csv: --forces measured needs the F/T stream")
        split = split_gap(measured, twin, result, servo)
    if request.rrd is not None:
        from twin.viz.recording import record_replay

        record_replay(request.rrd, measured, result, twin_model=twin.model, placement=twin.placement)
        note(f"rerun recording -> {request.rrd}")
    figure = None
    if request.figure is not None:
        from twin.viz.path_figures import plot_replay

        tracker, commanded = measured.tracker, measured.commanded
        figure = plot_replay(request.figure, tracker.t_s, tracker.values, result.tracker_pred_m,
                             interp_rows(tracker.t_s, commanded.t_s, commanded.values),
                             title=f"replay of {request.run_dir}: measured vs simulated tool tip, minus the command")
        note(f"figure -> {figure}")
    return ReplayReport(request.run_dir, spec, result, split, figure, servo, quasi_static_rms,
                        request.dynamic and spec.dynamic_servo is None)
