"""What was learned, named by its physical signature: the words `discrepancy` and `learn` print.

Each sentence compares the learned cell with the twin it started from, in the quantities an engineer checks:
how hard the sheet pushes and drags against the travel, how much softer or stiffer each joint is, the friction
against a joint's motion, the servo's lag, the tracker's offset.
"""

from __future__ import annotations

import numpy as np

from twin.analysis.learn.cell import LearnResult
from twin.analysis.replay import replay
from twin.base.signals import interp_rows
from twin.runs.format import Run, run_placement
from twin.sim.spec import TwinSpec

#: A joint's compliance change below this fraction is not named [-].
NAMED_CHANGE = 0.10
#: Nor one within this many of its standard deviations of the prior [-].
NAMED_SIGMAS = 2.0


def sheet_sentences(run: Run, prior: TwinSpec) -> list[str]:
    """How the run's measured force differs from the prior twin's along the run (its axial push and its drag
    against the travel)."""
    if run.forces is None:
        return []
    replayed = replay(run, prior.replace(placement=run_placement(run.meta)))
    model = replayed.forces_pred_n
    assert model is not None
    measured = run.forces.values
    velocity = np.gradient(run.commanded.values[:, :2], run.commanded.t_s, axis=0)
    v = interp_rows(run.forces.t_s, run.commanded.t_s, velocity)
    speed = np.linalg.norm(v, axis=1)
    moving = speed > 0.2 * np.median(speed)
    unit = v[moving] / speed[moving, None]
    drag_m = float(np.mean(-np.sum(measured[moving, :2] * unit, axis=1)))
    drag_t = float(np.mean(-np.sum(model[moving, :2] * unit, axis=1)))
    fz_m, fz_t = float(np.mean(measured[:, 2])), float(np.mean(model[:, 2]))
    return [
        f"the sheet pushes {abs(fz_m - fz_t):.0f} N {'more' if fz_m > fz_t else 'less'} along the tool axis than "
        f"the model (mean Fz {fz_m:.0f} N measured, {fz_t:.0f} N modelled)",
        f"the sheet drags {abs(drag_m - drag_t):.0f} N {'more' if drag_m > drag_t else 'less'} against the travel "
        f"than the model (mean {drag_m:.0f} N measured, {drag_t:.0f} N modelled)",
    ]


def springback_sentences(result: LearnResult) -> list[str]:
    """How far the part springs back against the model, where the runs had a part profile."""
    spring = result.springback
    if spring is None:
        return []
    return [f"the part springs back {spring.recovery_scale:.2f} x the model's elastic recovery and keeps "
            f"{100 * spring.depth_ratio:.1f} % of its depth (profile gap "
            + ", ".join(f"{a:.2f} -> {b:.2f} mm" for a, b in zip(spring.rms_before_mm, spring.rms_after_mm,
                                                                   strict=True)) + ")"]


def robot_sentences(result: LearnResult) -> list[str]:
    """The joints that changed, the friction, the lag and the tracker offset learned."""
    robot = result.robot
    joints = []  # the largest change first: what a user reads first is what changed most
    for j, (k, k0, k_std, seen) in enumerate(zip(robot.k_q_nm_per_rad, robot.prior_nm_per_rad, robot.std_nm_per_rad,
                                                  robot.observable, strict=True)):
        change = k0 / k - 1.0
        if seen and abs(change) >= NAMED_CHANGE and abs(k - k0) > NAMED_SIGMAS * k_std:
            joints.append((abs(change), f"joint {j + 1} is {100 * abs(change):.0f} % "
                           f"{'softer' if change > 0 else 'stiffer'} than its K_q prior at the process's frequencies "
                           f"(gear and servo in series: K_q,eff {k / 1e3:.0f} ± {k_std / 1e3:.0f} kN·m/rad, prior "
                           f"{k0 / 1e3:.0f})"))
    words = [sentence for _, sentence in sorted(joints, key=lambda item: -item[0])]
    for j, (f, f0, seen) in enumerate(zip(robot.friction_nm, robot.prior_friction_nm, robot.observable,
                                          strict=True)):
        if seen and abs(f - f0) >= max(0.25 * f0, 20.0):
            words.append(f"joint {j + 1} carries {f:.0f} N·m of friction against its motion (the twin had {f0:.0f})")
    unseen = [str(j + 1) for j, seen in enumerate(robot.observable) if not seen]
    if unseen:
        words.append(f"joint(s) {', '.join(unseen)}: not observed by the run(s), held at their priors")
    if robot.servo is not None:
        seen = [f"joint {j + 1} {100 * cs / c:.0f} %" for j, (cs, c, ok) in enumerate(zip(
            robot.servo.compliance_rad_per_nm, 1.0 / robot.k_q_nm_per_rad, robot.observable, strict=True))
            if ok and cs != 0]
        words.append(f"the servo gives way while the force changes and recovers over "
                     f"{1e3 * robot.servo.time_constant_s:.0f} ms: its transient compliance is "
                     f"{', '.join(seen)} of the joint's (negative: the deflection lags the force)")
    if float(np.linalg.norm(robot.offset_mm)) > 0.05:
        words.append(f"the tracker reads ({', '.join(f'{v:.2f}' for v in robot.offset_mm)}) mm off the tool "
                     "(a registration error of the tracker, not the robot's: the model carries it as the "
                     "instruments' registration, `twin.analysis.learn.instruments`)")
    return words
