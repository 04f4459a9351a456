"""The pyramid's robot part with the arm moving: the dynamic twin's arm driven by the measured forces.

The learned quasi-static robot, driven by a compensated pyramid's own measured forces, misses the plant's true tip
by 0.17-0.25 mm (docs/learning.md, "What the offline targets ask"), at the corners. This study drives the dynamic
twin's arm (`twin.sim.dynamic.DynamicTwin`, its loop taking the sheet's load through its integral) by those forces
instead, with its servo learned from the nominal cone the twin learned from:

- **the servo** (β, ζ; delay 0, the inertia fed forward): the grid β in `BETAS` by ζ in `ZETAS`, each the cone's
  tracker against the dynamic arm driven by the cone's forces, less their mean (the tracker's offset); the least
  rms is taken (fitted on the cone);
- **the pyramid** (compensated with the twin learned from the cone, formed with seed 3): its true tip against the
  quasi-static robot and the dynamic arm under that servo and under a rigid one (predicted);
- **two sensors**: the runs the learn_cell study formed (the thesis's 30 Hz F/T stream), and the same parts formed
  again with the plant's sensor at 1 kHz (`--set ft_rate_hz=1000`; cone seed 1, pyramid seed 3), its stream
  low-passed on the twin's side (`LOWPASS_HZ`, zero-phase Butterworth, second order) as a user filters a fast one;
  the fast stream's content above that (rms of the three axes) is what a 30 Hz stream folds into the arm's band.

The forces are taken as the sheet pushed (`twin.analysis.next_part.sheet_forces`: the model's F/T calibration
undone). The true tip (`truth_tip.csv`) is read here, on the experiment's side only. Writes OUT/pyramid_dynamic_arm
.json and .md, and with `--doc` the table between the page's `pyramid-dynamic-arm` markers:

    .venv/bin/python experiments/pyramid_dynamic_arm.py OUT --law1 L1 [--law2 L2] [--doc docs/dynamic-twin.md]

With `--commands` it takes the same path through the commands a user runs instead, on the 1 kHz runs: `learn CONE
--dynamic --write-model` (the cone's learned robot and sheet, and the servo fitted with the arm driven by the
cone's measured forces, `twin.analysis.learn.servo_fit`), then `replay PYRAMID --model --dynamic --forces measured`
(the robot's part quasi-static and with the arm moving, on the tracker; neutral knobs: the true tip and its noise),
into OUT/pyramid_dynamic_commands.json and .md and the page's `pyramid-dynamic-commands` markers.
"""

from __future__ import annotations

import math
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
from experiments_cli import cli_json, lab_neutral
from learn_cell import cone_cells_parser, cone_study
from scipy.signal import butter, filtfilt

from twin.analysis.learn.robot import rms_norm_mm
from twin.analysis.learn.servo_fit import force_rate_hz
from twin.analysis.learn.split import measured_force_tip
from twin.analysis.next_part import sheet_forces
from twin.analysis.replay import spec_for_run
from twin.base.signals import interp_rows
from twin.runs.format import Run
from twin.runs.read import read_commanded_csv, read_run
from twin.sim.dynamic import DynamicTwin, without_servo
from twin.sim.dynamic_servo import ServoModel
from twin.sim.model_file import read_model_file
from twin.sim.spec import TwinSpec

#: The servo grid fitted on the cone: β (bandwidth over the joint's first mode) and ζ.
BETAS, ZETAS = (0.35, 0.5, 0.7, 1.0), (0.6, 1.0, 2.0)
#: The fast sensor's rate [Hz] and the low-pass its stream takes on the twin's side [Hz].
FAST_HZ, LOWPASS_HZ = 1000.0, 20.0


def driven_arm(run: Run, spec: TwinSpec, lowpass_hz: float | None) -> DynamicTwin:
    """The dynamic arm along `run`'s command, driven by its measured forces (low-passed at `lowpass_hz`)."""
    twin = without_servo(spec_for_run(run, spec).build())
    forces = sheet_forces(run.forces, float(run.commanded.t_s[0]), twin.spec.effects.instruments)
    values = forces.values
    if lowpass_hz is not None:
        rate = 1.0 / float(np.median(np.diff(forces.t_s)))
        values = filtfilt(*butter(2, 2.0 * lowpass_hz / rate), values, axis=0)
    return DynamicTwin(twin, twin.simulate(run.commanded.t_s, run.commanded.values), forces=(forces.t_s, values))


def tip_at(arm: DynamicTwin, servo: ServoModel, t_s: np.ndarray) -> np.ndarray:
    """The stepped arm's tool tip under `servo` at the times `t_s`, sheet frame [m], (m, 3)."""
    result = arm.simulate(servo)
    return interp_rows(t_s, result.t_s, result.p_sheet_m)


def cone_servo(cone: Run, spec: TwinSpec, lowpass_hz: float | None) -> tuple[ServoModel, float]:
    """The grid's servo that drives the arm nearest the cone's tracker (less the mean), and that rms [mm]."""
    arm, best = driven_arm(cone, spec, lowpass_hz), (ServoModel(), math.inf)
    for beta, zeta in product(BETAS, ZETAS):  # bounded: the grid's points
        miss = cone.tracker.values - tip_at(arm, ServoModel(beta, zeta, 0.0, 1.0), cone.tracker.t_s)
        rms = rms_norm_mm(miss - miss.mean(axis=0))
        if rms < best[1]:
            best = (ServoModel(beta, zeta, 0.0, 1.0), rms)
    return best


def sensor_row(cone_dir: Path, pyramid_dir: Path, spec: TwinSpec, lowpass_hz: float | None) -> dict[str, Any]:
    """One sensor's numbers (module docstring)."""
    cone, pyramid = read_run(cone_dir), read_run(pyramid_dir)
    servo, cone_mm = cone_servo(cone, spec, lowpass_hz)
    truth = read_commanded_csv(pyramid_dir / "truth_tip.csv")
    t = pyramid.tracker.t_s
    true_tip = interp_rows(t, truth.t_s, truth.values)
    arm = driven_arm(pyramid, spec, lowpass_hz)
    fast = np.nan
    if lowpass_hz is not None:  # the stream's own content above the low-pass: what a 30 Hz stream folds back
        high = filtfilt(*butter(2, 2.0 * lowpass_hz / force_rate_hz(pyramid), "high"), pyramid.forces.values, axis=0)
        fast = float(np.sqrt(np.mean(np.sum(high**2, axis=1))))
    return {"beta": servo.bandwidth_over_mode, "zeta": servo.damping_ratio, "cone_mm": cone_mm, "above_n": fast,
            "quasi_static_mm": rms_norm_mm(true_tip - measured_force_tip(pyramid, spec_for_run(pyramid, spec).build())),
            "dynamic_mm": rms_norm_mm(true_tip - tip_at(arm, servo, t)),
            "rigid_mm": rms_norm_mm(true_tip - tip_at(arm, ServoModel(math.inf, 1.0, 0.0, 0.0), t))}


def fast_runs(out: Path, robot: str, folder: Path, plant_set: tuple[str, ...]) -> tuple[Path, Path]:
    """The learn_cell variant's nominal cone (seed 1) and its learned twin's compensated pyramid (seed 3) formed
    again with the plant's F/T sensor at `FAST_HZ` (neutral knobs), into `out`: (cone, pyramid)."""
    fast = (*plant_set, f"ft_rate_hz={FAST_HZ:g}")
    return (lab_neutral(robot, folder / "ideal.csv", out / "cone_fast", 1, "nominal", fast),
            lab_neutral(robot, folder / "pyramid_learned.csv", out / "pyramid_fast", 3, "compensated", fast))


def cell_rows(out: Path, robot: str, folder: Path, plant_set: tuple[str, ...]) -> list[dict[str, Any]]:
    """Both sensors' rows of one learn_cell variant; the fast sensor's runs formed into `out`."""
    spec = read_model_file(folder / "learned.json")
    cone_fast, pyramid_fast = fast_runs(out, robot, folder, plant_set)
    return [{"sensor": "30 Hz (the thesis's)", **sensor_row(folder / "nominal1", folder / "pyramid_learned_formed",
                                                          spec, None)},
            {"sensor": f"{FAST_HZ:g} Hz, low-passed {LOWPASS_HZ:g} Hz",
             **sensor_row(cone_fast, pyramid_fast, spec, LOWPASS_HZ)}]


def command_rows(out: Path, robot: str, folder: Path, plant_set: tuple[str, ...]) -> list[dict[str, Any]]:
    """The `--commands` row of one learn_cell variant (module docstring), its 1 kHz runs formed into `out`."""
    cone, pyramid = fast_runs(out, robot, folder, plant_set)
    model = out / "learned_dynamic.json"
    model.unlink(missing_ok=True)
    learned = cli_json("learn", str(cone), "--dynamic", "--write-model", str(model))["dynamic_servo"]
    split = cli_json("replay", str(pyramid), "--model", str(model), "--dynamic", "--forces", "measured")
    return [{"beta": learned["bandwidth_over_mode"], "zeta": learned["damping_ratio"],
             "delay_ms": 1e3 * learned["delay_s"], "measured_forces": learned["measured_forces"],
             "quasi_static_mm": split["robot_gap_rms_mm"], "moving_mm": split["robot_gap_moving_rms_mm"]}]


def command_table(rows: list[dict[str, Any]]) -> str:
    """The `--commands` markdown table (module docstring)."""
    lines = ["Each cell's nominal cone and compensated pyramid formed with the plant's F/T sensor at "
             f"{FAST_HZ:g} Hz (neutral knobs; seeds 1 and 3): `learn CONE --dynamic`, then `replay PYRAMID --dynamic "
             "--forces measured` with that model.", "",
             "| cell | servo `learn --dynamic` fitted: beta / zeta / delay [ms]; arm driven by | pyramid, robot part "
             "on the tracker [mm]: quasi-static / the arm moving |", "|---|---|---|"]
    for r in rows:
        drive = "its measured forces" if r["measured_forces"] else "the twin's sheet"
        lines.append(f"| {r['cell']} | {r['beta']:.2f} / {r['zeta']:.2f} / {r['delay_ms']:.1f}; {drive} | "
                     f"{r['quasi_static_mm']:.3f} / {r['moving_mm']:.3f} |")
    return "\n".join(lines) + "\n"


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = ["Each pyramid compensated with the twin learned from the nominal cone (neutral knobs, seed 3); the "
             "robot driven by the run's measured forces against the plant's true tip; the servo fitted on the "
             "cone's tracker.", "",
             f"| cell | F/T sensor | its pyramid stream above {LOWPASS_HZ:g} Hz, rms [N] | servo fitted on the cone: "
             "beta / zeta; cone tracker rms [mm] | pyramid, robot part [mm]: quasi-static / dynamic arm, the cone's "
             "servo / dynamic arm, rigid servo |",
             "|---|---|---|---|---|"]
    for r in rows:
        above = "-" if math.isnan(r["above_n"]) else f"{r['above_n']:.0f}"
        lines.append(f"| {r['cell']} | {r['sensor']} | {above} | {r['beta']:g} / {r['zeta']:g}; {r['cone_mm']:.3f} | "
                     f"{r['quasi_static_mm']:.3f} / {r['dynamic_mm']:.3f} / {r['rigid_mm']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = cone_cells_parser(__doc__.splitlines()[0])
    parser.add_argument("--commands", action="store_true",
                        help="the 1 kHz path through `learn --dynamic` and `replay --forces measured` instead")
    args = parser.parse_args()
    if args.commands:
        cone_study(args, "pyramid_dynamic_commands", "pyramid-dynamic-commands", command_rows, command_table)
    else:
        cone_study(args, "pyramid_dynamic_arm", "pyramid-dynamic-arm", cell_rows, table)


if __name__ == "__main__":
    main()
