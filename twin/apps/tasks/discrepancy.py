"""`discrepancy`: where a twin and a measured run disagree (`twin.analysis.discrepancy.search.find_discrepancy`):
the missing effect named, added to the twin, and the gap before and after; when no family explains the gap, the
robot and the sheet learned from the run (`twin.analysis.learn.learn`) and the gap on it and on a run held out.
Optionally the augmented (or learned) twin as a model file and a figure of the residual before and after.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.analysis.discrepancy.families import learns_from_run
from twin.analysis.discrepancy.floor import Floor
from twin.analysis.discrepancy.search import DiscrepancyResult, find_discrepancy
from twin.analysis.discrepancy.summary import result_summary
from twin.analysis.learn.cell import Gap
from twin.analysis.resolve import AUTO, resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.apps.tasks.inputs import HistoryDeclaration
from twin.base.outputs import repeated_input
from twin.errors import InputError
from twin.process.force.registry import FORCE_MODELS
from twin.process.process_file import ProcessDeclaration, process_record
from twin.runs.contact import require_forming_contact
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.sim.model_file import read_floor_entry, write_model_file
from twin.sim.spec import TwinSpec

FIGURE = "residual_before_after.png"
"""The figure's name in the report folder."""


@dataclass(frozen=True)
class DiscrepancyRequest:
    """What to search.

    Attributes:
        run_dir: A tx200-twin-run/1 folder (truth.json is never read).
        model: A model file to start from (effects, K_q, process), or None for the default cell.
        history: The FE force history (as declared; the shipped stand-in by default).
        declaration: The process declared over the model's and the run's (a process file, flags).
        force_model: A registered force model, or "auto" (`twin.analysis.resolve.choose_force_model`).
        robot: A robot name or description file; it must be the run's.
        model_out: Where to write the augmented (or learned) twin as a model file, or None.
        report: A folder for the figure of the residual before and after, or None.
        learn: When no family explains the gap, learn the robot and the sheet from the run.
        held_out: Another run of the same cell, never learned from: the gap before -> after on it, or None.
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
    """

    run_dir: Path
    model: Path | None = None
    history: HistoryDeclaration = field(default_factory=HistoryDeclaration)
    declaration: ProcessDeclaration = field(default_factory=ProcessDeclaration)
    force_model: str = AUTO
    robot: str | Path | None = None
    model_out: Path | None = None
    report: Path | None = None
    learn: bool = True
    held_out: Path | None = None
    cell: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.held_out is not None and repeated_input([self.run_dir, self.held_out]) is not None:
            raise InputError(f"--held-out {self.held_out} is the run {self.run_dir} itself: a held-out run is "
                             "another run of the same cell, never learned from")
        if self.force_model != AUTO and self.force_model not in FORCE_MODELS:
            raise InputError(f"force_model {self.force_model!r}: expected 'auto' or a registered force model "
                             f"({', '.join(FORCE_MODELS)})")


@dataclass(frozen=True)
class LearnedFromRun:
    """What a run taught the twin when no family explained its gap.

    Attributes:
        spec: The learned twin.
        named: What was learned, in sentences (the sheet's, the springback's, the robot's).
        run: The gap on the run learned from (fitted): before_mm, after_mm, before_n, after_n [mm, N rms].
        held_out: The same on the run held out (predicted), or None.
    """

    spec: TwinSpec
    named: list[str]
    run: dict[str, float]
    held_out: dict[str, float] | None = None

    def record(self) -> dict[str, Any]:
        """The sentences and the gaps (the spec goes to the model file)."""
        doc: dict[str, Any] = {"named": self.named, "run": self.run}
        if self.held_out is not None:
            doc["held_out"] = self.held_out
        return doc


@dataclass(frozen=True)
class DiscrepancyReport(Report):
    """A discrepancy search and what came of it.

    Attributes:
        run_dir: The run searched.
        spec: The twin as given.
        result: The search: the named effects, the gap before and after, the noise and what is left.
        learned: What the run taught the twin (no family explained the gap), or None.
        refused: Why the run could not teach the twin, or None.
        model_out: The model file written, or None.
        figure: The residual figure written, or None.
    """

    run_dir: Path
    spec: TwinSpec
    result: DiscrepancyResult
    learned: LearnedFromRun | None = None
    refused: str | None = None
    model_out: Path | None = None
    figure: Path | None = None

    def lines(self) -> list[str]:
        """The verdict and the gap before -> after; what was learned where nothing explained it."""
        result = self.result
        before, after = result.gap_before, result.gap_after
        named = ", ".join(f"{n.reported_name} ({100 * n.explained_fraction:.0f} %)" for n in result.named)
        lines = [
            f"discrepancy {self.run_dir}: effect {result_summary(result)['effect']} (found {named or 'nothing'}; "
            f"{100 * result.explained_fraction:.0f} % of the gap explained); model parameters "
            f"{result.effects.named_parameters()}; position gap {before['position_rms_mm']:.3f} -> "
            f"{after['position_rms_mm']:.3f} mm, force gap {before['force_rms_n']:.1f} -> "
            f"{after['force_rms_n']:.1f} N (noise {result.noise['position_mm']:.3f} mm, "
            f"{result.noise['force_n']:.1f} N per axis); left: {result.remainder['words']}"
        ]
        lines += [f"  {n.reported_name} is not told apart from {', '.join(n.ambiguous_with)} on this run (each "
                  "explains the gap about as well out of sample): a measurement the others do not predict alike tells"
                  for n in result.named if n.ambiguous_with]
        if result.scan:
            lines.append("  the part scan judged the first round's candidates the others could not tell apart (rms "
                         "miss less the cell's own, mm): " + ", ".join(f"{n} {v:.3f}" for n, v in result.scan.items()))
        if result.floor:
            lines.append("  judged above the floor the learned cell leaves on its own clean runs ("
                         + ", ".join(f"{s} {v:.3g}" for s, v in result.floor["excess_per_element"].items())
                         + " x the noise's variance per sample; from the model file)")
        if self.learned is not None:
            lines.append("  no family explains it; learned from the run (fitted):")
            lines += [f"  - {sentence}" for sentence in self.learned.named]
            for label, g in (("this run (fitted)", self.learned.run), ("held-out run (predicted)",
                                                                      self.learned.held_out)):
                if g is not None:
                    lines.append(f"  gap on {label}: {g['before_mm']:.3f} -> {g['after_mm']:.3f} mm, "
                                 f"{g['before_n']:.0f} -> {g['after_n']:.0f} N")
        return lines

    def record(self) -> dict[str, Any]:
        """The run, the search (`result_summary`), the process, and what was learned and written."""
        doc: dict[str, Any] = {
            "run": self.run_dir,
            **result_summary(self.result),
            "process": {**process_record(self.spec.process), "force_model": self.spec.process.force_model},
        }
        if self.learned is not None:
            doc["learned"] = self.learned.record()
        elif self.refused is not None:
            doc["learned"] = {"refused": self.refused}
        if self.model_out is not None:
            doc["model_out"] = self.model_out
        if self.figure is not None:
            doc["report"] = [self.figure]
        return doc


def discrepancy_task(request: DiscrepancyRequest, note: Note = silent) -> DiscrepancyReport:
    """Search the run's gap on the twin its request resolves to (`twin.analysis.resolve.resolve_spec`), learn
    from the run where no family explains it, and write the model file and the figure if asked.

    Raises:
        InputError: Another robot than the run's, a bad declaration, an output over an input.
        RunFormatError: A bad run folder (naming the file and row).
    """
    measured = read_run(request.run_dir)
    require_forming_contact(measured, "`discrepancy`")
    declared, _ = request.history.load()
    spec = resolve_spec(cell=request.cell, model=request.model, robot=request.robot, run=measured, declaration=request.declaration,
                        force_model_name=request.force_model, history=declared,
                        p_sheet_m=measured.commanded.values, note=note)
    floor = None if request.model is None else _floor(request.model)
    result = find_discrepancy(measured, spec, floor=floor)
    learned, refused = None, None
    if learns_from_run(result.verdict) and measured.forces is not None and request.learn:
        try:
            learned = learn_from_run(measured, spec.replace(effects=result.effects), request.held_out)
        except InputError as exc:  # the run cannot teach the twin (a silent sensor, ...): the search still stands
            refused = str(exc)
            note(f"note: no family explains the gap, and the run cannot teach the twin: {exc}")
    if request.model_out is not None:
        inputs = (request.run_dir, request.model, request.history.path, request.held_out)
        model_spec, words = _model_file(request.run_dir, spec.replace(effects=result.effects), result, learned)
        write_model_file(request.model_out, model_spec, note=words, protect=[p for p in inputs if p is not None])
    figure = None
    if request.report is not None:
        from twin.viz.deflection_figures import plot_residual_before_after

        request.report.mkdir(parents=True, exist_ok=True)
        figure = plot_residual_before_after(
            request.report / FIGURE, measured.tracker.t_s, result.residual_before["position"],
            result.residual_after["position"], label_before="twin as given",
            label_after=f"twin + {', '.join(result.found) or 'nothing'}",
        )
    return DiscrepancyReport(request.run_dir, spec, result, learned, refused, request.model_out, figure)


def _floor(model: Path) -> Floor | None:
    """The floor a model file records (`learn` with two runs or more), or None."""
    entry = read_floor_entry(model)
    return None if entry is None else Floor.from_json(entry, str(model))


def learn_from_run(measured: Run, spec: TwinSpec, held_out: Path | None = None) -> LearnedFromRun:
    """Learn the robot and the sheet from the run; the sentences naming them and the gaps before and after.

    Raises:
        InputError: The run cannot teach the twin (no forces, no forming contact, ...).
    """
    from twin.analysis.learn import learn  # looked up when called (a test replaces it)
    from twin.analysis.learn.cell import replay_gap
    from twin.analysis.learn.signatures import robot_sentences, sheet_sentences, springback_sentences

    result = learn([measured], spec)
    named = sheet_sentences(measured, spec) + springback_sentences(result) + robot_sentences(result)
    other = None
    if held_out is not None:
        run = read_run(held_out)
        other = _gaps(replay_gap(run, spec), replay_gap(run, result.spec))
    return LearnedFromRun(result.spec, named, _gaps(result.before[0], result.after[0]), other)


def _gaps(before: Gap, after: Gap) -> dict[str, float]:
    """A gap before and after [mm, N rms]."""
    return {"before_mm": before.position_rms_mm, "after_mm": after.position_rms_mm,
            "before_n": before.force_rms_n, "after_n": after.force_rms_n}


def _model_file(run_dir: Path, augmented: TwinSpec, result: DiscrepancyResult,
                learned: LearnedFromRun | None) -> tuple[TwinSpec, str]:
    """The model file's twin and its note: the twin learned from the run, else the one with the effects found."""
    if learned is not None:
        return learned.spec, (f"tx200-twin discrepancy on {run_dir}: unexplained by the families; robot and sheet "
                              "learned from the run (fitted)")
    return augmented, (f"tx200-twin discrepancy on {run_dir}: found {list(result.found) or result.verdict}"
                       + ("" if result.model_complete else "; families without an effect of their own are not in "
                          "this file"))
