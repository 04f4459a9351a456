"""Learn the cell: from one or more nominal runs of a cell the twin did not build, a twin of that cell.

`learn` fits the robot (`twin.analysis.learn.robot`: joint stiffness, joint friction, the servo's transient,
tracker offset), the tracker's registration and the F/T bias (`twin.analysis.learn.instruments`, carried as the instruments') and the sheet (`twin.analysis.learn.sheet`: the `learned` force model's weights and in-plane
ratios) and returns the twin's spec with them, which `twin.sim.model_file.write_model_file` saves. It reports,
per run, the replay gap before and after (the twin's own simulation of the run's command: what compensation
relies on), and given several runs, the gap on each run left out of its own learning (`held_out`): what a user
should expect on the next part. It reads the runs' commanded paths, trackers and forces only; `truth.json`,
the plant's knobs and its code never (a test holds it to that).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from twin.analysis.learn.instruments import fit_instruments
from twin.analysis.learn.robot import RobotFit, fit_robot
from twin.analysis.learn.sheet import SheetFit, fit_sheet
from twin.analysis.learn.springback import SpringbackFit, fit_springback
from twin.analysis.learn.tracker import TrackerErrors
from twin.analysis.replay import replay
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.learned import RADIAL_RISE_KEY, WEIGHT_KEYS
from twin.process.force.registry import FORCE_MODELS, auto_force_model
from twin.process.force.span import SPAN_KEYS
from twin.runs.format import Run, run_placement, run_process, run_robot
from twin.sim.measure import predict_part_profile
from twin.sim.spec import TwinSpec


class Gap(NamedTuple):
    """A run's replay gap [mm, N]: tool tip, force, and the part's profile (nan without one)."""

    run: str
    position_rms_mm: float
    force_rms_n: float
    profile_rms_mm: float = float("nan")


class LearnResult(NamedTuple):
    """`learn`'s result.

    Attributes:
        spec: The learned twin (the input spec with the learned K_q, friction and force model).
        robot: The robot's fit.
        sheet: The sheet's fit.
        springback: The springback's fit from the runs' part profiles, None where they have none.
        before: Per run, the replay gap of the input spec.
        after: Per run, the replay gap of the learned spec, on the runs it learned from (fitted).
        held_out: Per run, the gap of a spec learned from the other runs only (predicted; empty for one run).
        held_specs: Per run, that spec (the twin each run was held out from; empty for one run).
        declared_sheets: The force models the runs declare, each once (several: runs of parts whose declared
            sheets differ, and the learned one is taken, the one that covers them all).
        sheet_kept: Whether the declared sheet was kept (`sheet_kept`, and the runs declare one).
    """

    spec: TwinSpec
    robot: RobotFit
    sheet: SheetFit
    springback: SpringbackFit | None
    before: tuple[Gap, ...]
    after: tuple[Gap, ...]
    held_out: tuple[Gap, ...]
    held_specs: tuple[TwinSpec, ...] = ()
    declared_sheets: tuple[str, ...] = ()
    sheet_kept: bool = False


def learned_spec(runs: list[Run], spec: TwinSpec, tracker: TrackerErrors = TrackerErrors.OFFSET,
                 declared: list[Process] | None = None,
                 one_sheet: bool = True) -> tuple[TwinSpec, RobotFit, SheetFit, SpringbackFit | None]:
    """The spec with the robot, the sheet and its springback learned from `runs` (no gaps computed);
    `tracker`: `fit_robot`'s, and beyond the offset the tracker's lateness carried (`fit_instruments`' `lateness`);
    `declared`: per run, the sheet it declares (default `spec`'s for every run); `one_sheet`: False where the
    cell's runs (these and any held out) declare several sheets, so the learned one is taken."""
    base = spec.replace(placement=run_placement(runs[0].meta))
    declared = declared or [base.process] * len(runs)
    # the robot is fitted on the ISF model's twin: a learned prior's weights are no ISF constants (they are
    # learned again from these runs: a model learned twice from the same runs is the same sheet)
    isf_fit = tuple((k, v) for k, v in base.process.force_fit if k not in (*WEIGHT_KEYS, RADIAL_RISE_KEY, *SPAN_KEYS))
    robot = fit_robot(runs, replace(base, process=replace(base.process, force_model="isf", force_fit=isf_fit)).build(),
                      tracker)
    sheet = fit_sheet(runs, base.process, declared)
    friction = np.where(robot.observable, robot.friction_nm, robot.prior_friction_nm)
    # the learned sheet replaces the declared force model only where it forces nearer the measured force along the
    # measured tip (fitted, so a learned sheet that does not is of the wrong form: a lab's FE history, say)
    # (runs of parts that declare different sheets, a groove's FE history and a cone's formula, say: none covers them
    # all, and the learned one is taken)
    kept = one_sheet and sheet_kept(sheet)
    process = base.process if kept else replace(base.process, force_model="learned", force_fit=sheet.force_fit)
    learned = base.replace(process=process, joint_stiffness_nm_per_rad=tuple(float(k) for k in robot.k_q_nm_per_rad),
                           joint_friction_nm=tuple(float(f) for f in friction), servo=robot.servo)
    springback = None if kept else fit_springback(runs, learned)
    if springback is not None:
        fit = (*sheet.force_fit, ("recovery_scale", springback.recovery_scale),
               ("depth_ratio", springback.depth_ratio))
        learned = learned.replace(process=replace(process, force_fit=fit))
    instruments = fit_instruments(runs, learned, lateness=tracker is not TrackerErrors.OFFSET).instruments
    learned = learned.replace(effects=learned.effects.with_instruments(instruments))
    return learned.replace(placement=spec.placement), robot, sheet, springback


def sheet_kept(sheet: SheetFit) -> bool:
    """Whether the declared force model is kept: the learned sheet forces no nearer the measured force along the
    measured tip than it (`SheetFit.rms_before_n` against `rms_after_n`, over the runs)."""
    return float(np.mean(sheet.rms_after_n)) >= float(np.mean(sheet.rms_before_n))


def learn(runs: list[Run], spec: TwinSpec | None = None, tracker: TrackerErrors = TrackerErrors.OFFSET) -> LearnResult:
    """Learn the cell's robot and sheet from its runs (module docstring).

    Args:
        runs: Nominal runs of the cell, each with tracker and F/T streams, made by one robot at one placement.
        spec: The declared twin (robot, process: the priors); None: the first run's robot in its cell.
        tracker: Which of each run's tracker errors are fitted beside the robot (`fit_robot`); beyond its offset,
            the lateness is carried as the tracker's clock (`learn --tracker-errors`, `--tracker-late`).

    Raises:
        InputError: No run, runs of different robots or placements, or runs without forces.
    """
    if not runs:
        raise InputError("learn needs at least one run")
    robot = run_robot(runs[0].meta, (runs[0].directory or Path(".")) / "meta.json")
    placement = run_placement(runs[0].meta)
    for run in runs[1:]:
        if run_robot(run.meta, (run.directory or Path(".")) / "meta.json").source != robot.source or run_placement(run.meta) != placement:
            raise InputError(f"run {run.directory} was made by another robot or at another placement than "
                             f"{runs[0].directory}: learn from one cell's runs at a time")
    from twin.analysis.tool_choice import (
        resolve_tool_spec,  # the tool the runs were made with, over the prior's
    )

    tools = [resolve_tool_spec(robot, run=run, model=None if spec is None else spec.tool) for run in runs]
    for run, tool in zip(runs[1:], tools[1:], strict=True):
        if tool != tools[0]:
            raise InputError(f"run {run.directory} was made with another tool than {runs[0].directory} "
                             f"({tool} vs {tools[0]}; None: the robot model's): learn from one cell's runs at a time")
    # without a declared twin each run's sheet is the one it records (runs of several parts may record several)
    declared = [declared_process(run) for run in runs] if spec is None else [spec.process] * len(runs)
    spec = (spec or TwinSpec(robot=robot, process=declared[0])).replace(placement=placement, tool=tools[0])
    one_sheet = all(process == declared[0] for process in declared)
    learned, robot_fit, sheet_fit, springback_fit = learned_spec(runs, spec, tracker, declared, one_sheet)
    before = tuple(replay_gap(run, spec.replace(process=process)) for run, process in zip(runs, declared, strict=True))
    after = tuple(replay_gap(run, learned) for run in runs)
    held: list[Gap] = []
    held_specs: list[TwinSpec] = []
    if len(runs) > 1:
        for k, run in enumerate(runs):
            others = [r for i, r in enumerate(runs) if i != k]
            held_specs.append(learned_spec(others, spec, tracker, [d for i, d in enumerate(declared) if i != k],
                                           one_sheet)[0])
            held.append(replay_gap(run, held_specs[-1]))
    models = tuple(dict.fromkeys(process.force_model for process in declared))
    return LearnResult(learned, robot_fit, sheet_fit, springback_fit, before, after, tuple(held), tuple(held_specs),
                       models, one_sheet and sheet_kept(sheet_fit))


def declared_process(run: Run) -> Process:
    """The process a run records (`meta.json`), with the force model it records, else the first that applies."""
    process = run_process(run.meta, Process(), (run.directory or Path(".")) / "meta.json")
    recorded = run.meta.get("force_model")
    name = recorded if isinstance(recorded, str) and recorded in FORCE_MODELS else auto_force_model(
        process, run.commanded.values)
    return replace(process, force_model=name)


def replay_gap(run: Run, spec: TwinSpec) -> Gap:
    """The run replayed on `spec` (at the run's placement): tool tip, force and profile gaps."""
    twin = spec.replace(placement=run_placement(run.meta)).build()
    try:
        replayed = replay(run, twin)
    except InputError as exc:  # a declared FE history shorter than the run's passes, say
        raise InputError(f"run {run.directory}: the twin's sheet ({spec.process.force_model}) cannot be driven "
                         f"along it: {exc}") from exc
    metrics = replayed.metrics
    profile = float("nan")
    if run.part_profile is not None:
        x, z = predict_part_profile(twin, replayed.sim, twin.effects)
        profile = 1e3 * float(np.sqrt(np.mean((np.interp(run.part_profile[0], x, z) - run.part_profile[1]) ** 2)))
    return Gap(str(run.directory), float(metrics["position_rms_mm"]), float(metrics.get("force_rms_n", np.nan)),
               profile)
