"""`learn`: a twin of a cell it did not build, from its nominal runs (`twin.analysis.learn.learn`): the robot's K_q,
joint friction, servo transient and tracker offset, the sheet's `learned` force model and its springback, each replay
gap before and after (fitted) and on a run left out (predicted); optionally the twin saved as a model file."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.analysis.discrepancy.floor import Floor, mean_floor, measure_floor
from twin.analysis.learn import Gap, LearnResult, RobotFit, SheetFit, learn
from twin.analysis.learn.robot import TrackerErrors
from twin.analysis.learn.sheet import SHAPE_GAIN
from twin.apps.tasks.base import Note, Report, silent
from twin.base.outputs import repeated_input
from twin.errors import InputError
from twin.process.force.learned import RADIAL_RISE_KEY, RISE_KEYS
from twin.runs.read import read_run
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.spec import TwinSpec

if TYPE_CHECKING:
    from twin.analysis.learn.servo_fit import ServoFit


@dataclass(frozen=True)
class LearnRequest:
    """What to learn from.

    Attributes:
        runs: Nominal runs of one cell (tracker and F/T streams), one robot at one placement; with two or more,
            each is also replayed on a twin learned from the others.
        model: The declared twin (a model file) whose robot and process are the priors, or None for the runs'
            recorded robot and process.
        write_model: Where to write the learned twin (a model file), or None.
        dynamic: Also learn the dynamic mode's joint servo from the first run (`fit_servo`, docs/dynamic-twin.md),
            carried in the model file for `replay --dynamic`.
        tracker: Which of each run's tracker errors are fitted beside the robot, beyond its offset the lateness
            carried as the tracker's clock (`twin.analysis.learn.cell.learn`; `learn --tracker-errors`: TURNED,
            `--tracker-late`: LATE).
    """

    runs: tuple[Path, ...]
    model: Path | None = None
    write_model: Path | None = None
    dynamic: bool = False
    tracker: TrackerErrors = TrackerErrors.OFFSET

    def __post_init__(self) -> None:
        object.__setattr__(self, "runs", tuple(self.runs))
        if not self.runs:
            raise InputError(f"runs {self.runs!r}: expected one run folder or more")
        twice = repeated_input(self.runs)
        if twice is not None:
            raise InputError(f"run {twice[0]} given twice (as {twice[0]} and {twice[1]}): give each run once (a run "
                             "given twice is learned twice and, with two runs, held out from itself)")
        if not isinstance(self.tracker, TrackerErrors):
            raise InputError(f"tracker {self.tracker!r}: expected one of {', '.join(e.name for e in TrackerErrors)}")


@dataclass(frozen=True)
class LearnReport(Report):
    """What was learned, and the gaps.

    Attributes:
        result: The learned twin, the robot's, sheet's and springback's fits and the replay gaps.
        model_file: The model file written, or None.
        run_tool_mm: The tool length the runs record (their `cell` tool, else `tool_length_m`) [mm], or None.
        floor: With two runs or more, what the learned cell leaves on its own clean runs (each held out), or None.
        servo_fit: With dynamic, the dynamic mode's servo learned from the first run, else None.
        servo_refused: With dynamic, why it was not learned (the learned arm does not step stably), else None.
    """

    result: LearnResult
    model_file: Path | None = None
    run_tool_mm: float | None = None
    floor: Floor | None = None
    servo_fit: ServoFit | None = None
    servo_refused: str | None = None

    def fitted_words(self) -> str:
        """The robot, the sheet placement and the tool the twin was fitted for, in one line."""
        spec = self.result.spec
        place = spec.placement
        origin = (f"robot {spec.robot.name}'s default sheet origin" if place.origin_base_m is None else
                  "sheet origin (" + ", ".join(f"{1e3 * v:g}" for v in place.origin_base_m) + ") mm")
        tool = f"tool {1e3 * spec.tool_length_m:.2f} mm " + ("(the robot model's)" if spec.tool is None else
                                                            "(the runs' declared tool)")
        if self.run_tool_mm is not None and abs(self.run_tool_mm - 1e3 * spec.tool_length_m) > 1e-6:
            tool += f"; the runs record a {self.run_tool_mm:g} mm tool"
        sheet = spec.process
        return (f"  fitted for robot {spec.robot.name} ({spec.robot.vendor} {spec.robot.model}), {origin}, yaw "
                f"{math.degrees(place.yaw_rad):g} deg (the runs' placement), {tool}; sheet {sheet.material} "
                f"{1e3 * sheet.thickness_m:g} mm, tool radius {1e3 * sheet.tool_radius_m:g} mm")

    def lines(self) -> list[str]:
        """What was learned, for the screen."""
        result = self.result
        robot, sheet = result.robot, result.sheet
        friction = ", ".join(f"j{j + 1} {f:.0f}" for j, f in enumerate(robot.friction_nm) if f > 0) or "none"
        lines = [
            f"learned from {len(result.before)} run(s) (fitted: the robot, the sheet and its springback come from "
            "these runs)",
            self.fitted_words(),
            f"  robot: K_q [kN·m/rad] {'; '.join(_stiffness_words(robot))}",
            f"  robot: joint friction [N·m] {friction}; {_servo_words(robot)}; tracker offset "
            f"({', '.join(f'{v:.3f}' for v in robot.offset_mm)}) mm" + _tracker_words(robot),
            "  instruments carried in the model: tracker registration (rotation about the sheet origin, shift) "
            + _registration_words(result.spec),
            "  robot's part of the gap (the twin's robot driven by the measured forces): "
            + ", ".join(f"{a:.3f} -> {b:.3f} mm" for a, b in zip(robot.rms_prior_mm, robot.rms_after_mm, strict=True))
            + _grew_words(robot),
            ("  sheet ('learned' force model" + _several(result.declared_sheets) + "): " + _sheet_words(sheet))
            if not result.sheet_kept else
            f"  sheet: the declared force model ({result.spec.process.force_model}) kept: the one learned ("
            + _sheet_words(sheet) + ") forces no nearer the measured force",
            "  sheet's force along the measured tip: "
            + ", ".join(f"{a:.0f} -> {b:.0f} N" for a, b in zip(sheet.rms_before_n, sheet.rms_after_n, strict=True)),
            _springback_words(result),
        ]
        for before, after in zip(result.before, result.after, strict=True):
            worse = after.position_rms_mm > before.position_rms_mm
            lines.append(f"  replay {before.run}: {_gap(before)} -> {_gap(after)} (fitted)" + (
                " WORSE: the learned twin replays the run it learned from worse than the declared one; do not "
                "compensate with it, look for an effect the learner has no term for (`tx200-twin discrepancy`)"
                if worse else ""))
        lines += [f"  left out {h.run}: {_gap(h)} (predicted: learned from the other runs)" for h in result.held_out]
        if self.floor is not None:
            lines.append("  floor on its own clean runs (predicted; what `discrepancy --model` judges a change above): "
                         + ", ".join(f"{s} {v:.3g}" for s, v in self.floor.excess.items())
                         + " x the noise's variance per sample")
        if self.servo_refused is not None:
            lines.append(f"  dynamic mode's servo: not learned ({self.servo_refused}); the model has none")
        if self.servo_fit is not None:
            fit, servo = self.servo_fit, self.servo_fit.servo
            drive = "its measured forces" if fit.measured_forces else "the twin's sheet"
            lines.append(f"  dynamic mode's servo (fitted on the first run): bandwidth {servo.bandwidth_over_mode:.2f} x "
                         f"each joint's mode, damping {servo.damping_ratio:.2f}, delay {1e3 * servo.delay_s:.1f} ms, "
                         f"feed-forward {servo.feedforward:.2f}, load fed forward {servo.load_feedforward:.2f}, the arm "
                         f"driven by {drive}; its "
                         f"replay {fit.rms_rigid_mm:.3f} -> {fit.rms_mm:.3f} mm against a rigid servo")
        if self.model_file is not None:
            lines.append(f"-> {self.model_file}")
        return lines

    def record(self) -> dict[str, Any]:
        """The robot's and the sheet's fits, the springback's, and the gaps before, after and held out."""
        result = self.result
        robot, sheet = result.robot, result.sheet
        spec = result.spec
        return {
            "fitted_for": {"robot": spec.robot.name, "placement": spec.placement.to_json(),
                           "tool_length_mm": 1e3 * spec.tool_length_m, "run_tool_length_mm": self.run_tool_mm},
            "robot": {
                "k_q_nm_per_rad": robot.k_q_nm_per_rad, "k_q_std_nm_per_rad": robot.std_nm_per_rad,
                "prior_k_q_nm_per_rad": robot.prior_nm_per_rad, "observable": np.asarray(robot.observable).tolist(),
                "friction_nm": robot.friction_nm, "tracker_offset_mm": robot.offset_mm,
                "tracker_rotation_mrad": list(robot.rotation_mrad), "tracker_late_ms": robot.late_ms,
                "servo": None if robot.servo is None else {
                    "compliance_rad_per_nm": list(robot.servo.compliance_rad_per_nm),
                    "time_constant_s": robot.servo.time_constant_s},
                "gap_measured_forces_prior_mm": list(robot.rms_prior_mm),
                "gap_measured_forces_learned_mm": list(robot.rms_after_mm),
            },
            "sheet": {"force_model": "learned", "declared_kept": result.sheet_kept,
                      "declared_sheets": list(result.declared_sheets),
                      "force_fit": dict(sheet.force_fit), "std": dict(sheet.std),
                      "force_rms_before_n": list(sheet.rms_before_n), "force_rms_after_n": list(sheet.rms_after_n),
                      "samples": sheet.samples, "terms": list(sheet.terms),
                      "validation_rms_n": sheet.validation_rms_n,
                      "published_formula_validation_rms_n": sheet.prior_validation_rms_n,
                      "walls_rise_share": sheet.shape_share},
            "springback": None if result.springback is None else result.springback._asdict(),
            "before": [g._asdict() for g in result.before], "after_fitted": [g._asdict() for g in result.after],
            "held_out_predicted": [g._asdict() for g in result.held_out],
            "floor": None if self.floor is None else self.floor.to_json(),
            "dynamic_servo": self.servo_refused if self.servo_fit is None else {
                **self.servo_fit.servo.to_json(),
                "rms_rigid_mm": self.servo_fit.rms_rigid_mm, "rms_mm": self.servo_fit.rms_mm,
                "measured_forces": self.servo_fit.measured_forces},
        }


def learn_task(request: LearnRequest, note: Note = silent) -> LearnReport:
    """Learn the cell from its runs, and write the learned twin if asked.

    Raises:
        InputError: Runs of different robots or placements, runs without forces or forming contact.
        RunFormatError: A bad run folder (naming the file and row).
    """
    runs = [read_run(path) for path in request.runs]
    prior = read_model_file(request.model) if request.model is not None else None
    result = learn(runs, prior, request.tracker)
    servo_fit, refused = None, None
    if request.dynamic:
        from twin.analysis.learn.servo_fit import fit_servo

        note("learn: the dynamic mode's servo, fitted on the first run")
        try:
            servo_fit = fit_servo(runs[0], result.spec)
            result = result._replace(spec=result.spec.replace(dynamic_servo=servo_fit.servo))
        except InputError as exc:  # the learned arm does not step stably: the model is written without it
            refused = str(exc)
    floor = None
    if len(runs) > 1:  # the floor the cell leaves on a clean run it was not learned from (predicted), for discrepancy
        note("learn: the floor the learned cell leaves on its own clean runs (each run held out)")
        floor = mean_floor([measure_floor(run, spec) for run, spec in zip(runs, result.held_specs, strict=True)])
    if request.write_model is not None:
        names = ", ".join(str(p) for p in request.runs)
        write_model_file(request.write_model, result.spec,
                         protect=[*request.runs, *([request.model] if request.model is not None else [])],
                         note=f"learned by `tx200-twin learn` from {names}: K_q, joint friction and the sheet's "
                         "force model are fitted to those runs", floor=None if floor is None else floor.to_json())
    return LearnReport(result, request.write_model, _run_tool_mm(runs[0].meta), floor, servo_fit, refused)


def _run_tool_mm(meta: Mapping[str, Any]) -> float | None:
    """The tool a run records [mm]: its cell's tool, else its `tool_length_m`."""
    declared = ((meta.get("cell") or {}).get("tool") or {}).get("length_mm")
    if isinstance(declared, int | float):
        return float(declared)
    length = meta.get("tool_length_m")
    return 1e3 * float(length) if isinstance(length, int | float) else None


def _stiffness_words(robot: RobotFit) -> list[str]:
    """Each joint's learned K_q [kN·m/rad]: with its spread and change of compliance, a lower bound, or the prior."""
    joints = []
    for j, (k, s, k0, seen) in enumerate(zip(robot.k_q_nm_per_rad, robot.std_nm_per_rad, robot.prior_nm_per_rad,
                                              robot.observable, strict=True)):
        if not seen:
            joints.append(f"j{j + 1} {k0 / 1e3:.0f} (prior: not observed)")
        elif s > 0.5 * k:  # its compliance is not told from 0: a lower bound
            joints.append(f"j{j + 1} > {k / (1 + 2 * s / k) / 1e3:.0f} (stiffer than the run resolves)")
        else:
            joints.append(f"j{j + 1} {k / 1e3:.0f} ± {s / 1e3:.0f} ({100 * (k0 / k - 1):+.0f} % compliance)")
    return joints


def _springback_words(result: LearnResult) -> str:
    """The springback learned from the part profiles, or why none was."""
    spring = result.springback
    if spring is None:
        return "  springback: no part profile in the runs (a 3-D scan: `identify --springback RUN --design STL`)"
    bound = f" (at its bound: {', '.join(spring.at_bound)})" if spring.at_bound else ""
    return (f"  springback (from the part profiles): recovery {spring.recovery_scale:.3f} x the model's "
            f"F/k_unload, depth kept {spring.depth_ratio:.3f}{bound}; profile "
            + ", ".join(f"{a:.3f} -> {b:.3f} mm" for a, b in zip(spring.rms_before_mm, spring.rms_after_mm,
                                                                  strict=True)))


def _gap(gap: Gap) -> str:
    """A replay gap: tool tip [mm] / force [N], and the part's profile [mm] where there is one."""
    profile = "" if np.isnan(gap.profile_rms_mm) else f", profile {gap.profile_rms_mm:.3f} mm"
    return f"{gap.position_rms_mm:.3f} mm / {gap.force_rms_n:.0f} N{profile}"


#: A servo transient's compliance beyond this multiple of its joint's is no position loop's (flagged) [-].
SERVO_SHARE_PLAUSIBLE = 3.0


def _grew_words(robot: RobotFit) -> str:
    """A flag when the learned robot fits its runs worse than the prior did (its bounds cost more than it gains)."""
    if all(b <= a for a, b in zip(robot.rms_prior_mm, robot.rms_after_mm, strict=True)):
        return ""
    return (" (WORSE than the prior: the robot's terms do not describe these runs; its K_q and friction are not "
            "to be trusted, look for an effect the learner has no term for: `tx200-twin discrepancy`)")


def _registration_words(spec: TwinSpec) -> str:
    """The carried tracker registration (and lateness) and the F/T bias, in words."""
    inst = spec.effects.instruments
    late = inst.tracker_time_offset_s[0]
    return (f"({', '.join(f'{v:.3f}' for v in inst.tracker_rotation_mrad)}) mrad, "
            f"({', '.join(f'{v:.3f}' for v in inst.tracker_shift_mm)}) mm"
            + (f", its clock read {1e3 * late:.1f} ms late" if late else "")
            + f"; F/T bias ({', '.join(f'{v:.1f}' for v in inst.force_bias_n)}) N")


def _tracker_words(robot: RobotFit) -> str:
    """The tracker's errors the robot's fit took apart, in words (`learn --tracker-errors`: turned and late too)."""
    if not any(robot.rotation_mrad) and not robot.late_ms:
        return " (not a robot effect: a registration error of the tracker)"
    turned = f", turned ({', '.join(f'{v:.2f}' for v in robot.rotation_mrad)}) mrad" if any(robot.rotation_mrad) else ""
    return (f"{turned}, {robot.late_ms:.1f} ms late (not robot effects: the tracker's registration and clock, or the "
            "robot's lag along the path)")


def _servo_words(robot: RobotFit) -> str:
    """The servo transient learned, its compliance as a share of each joint's."""
    if robot.servo is None:
        return "no servo transient seen"
    share = ", ".join(f"j{j + 1} {cs * k:.2f}" for j, (cs, k) in enumerate(
        zip(robot.servo.compliance_rad_per_nm, robot.k_q_nm_per_rad, strict=True)) if cs != 0)
    odd = [f"j{j + 1}" for j, (cs, k) in enumerate(zip(robot.servo.compliance_rad_per_nm, robot.k_q_nm_per_rad,
                                                        strict=True)) if abs(cs * k) > SERVO_SHARE_PLAUSIBLE]
    flag = "" if not odd else (f"; IMPLAUSIBLE for {', '.join(odd)}: over {SERVO_SHARE_PLAUSIBLE:g}x the joint's "
                               "own compliance is no position loop's, likely another effect (a tracker's clock, the "
                               "sheet) taken up by the servo term")
    return (f"servo transient over {1e3 * robot.servo.time_constant_s:.0f} ms, its compliance over the joint's "
            f"{share} (negative: the deflection lags the force){flag}")


def _several(models: tuple[str, ...]) -> str:
    """Words for runs that declare several sheets (the learned one is taken)."""
    return "" if len(models) < 2 else (f"; the runs declare several sheets ({', '.join(models)}): the learned one, which "
                                       "covers them all, is taken")


def _sheet_words(sheet: SheetFit) -> str:
    """The selected terms with their weights and bootstrap spread, the in-plane ratios, and the look-ahead check."""
    fit, std = dict(sheet.force_fit), dict(sheet.std)
    terms = ", ".join(f"{k} {fit[k]:.4g} ± {std[k]:.2g}" for k in sheet.terms)
    parts = []
    if fit["mu_radial"] > 0.0:
        parts.append(f"{fit['mu_radial']:.3f}")
    if fit.get(RADIAL_RISE_KEY, 0.0) > 0.0:
        parts.append(f"{fit[RADIAL_RISE_KEY]:.3f} x the side walls' rise")
    radial = f"mu_r {' + '.join(parts)}" if parts else "mu_r 0 (no radial force the data support)"
    rise = "taken" if set(sheet.terms) & set(RISE_KEYS) else f"not taken, under {100.0 * SHAPE_GAIN:.0f} %"
    return (f"terms chosen from the data: {terms}; mu_t {fit['mu_eff']:.3f}, {radial}; predicting each run's later "
            f"material from its earlier: {sheet.validation_rms_n:.0f} N rms (the published formula: "
            f"{sheet.prior_validation_rms_n:.0f} N); the walls' rise around the tool takes "
            f"{100.0 * sheet.shape_share:.0f} % off the tip terms' error ({rise})")
