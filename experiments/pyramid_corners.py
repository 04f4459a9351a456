"""Where a compensated pyramid's miss comes from: its corners or the controller's stops at them, and whether the
arm's answer to the corners' force is a static one.

On `experiments/learn_cell.py`'s cone variants (the twin learned from the nominal 60 x 10 mm cone, seed 1; the
40 x 6 mm pyramid compensated with it and formed with seed 3, neutral knobs), per cell:

- **the corners without the stops**: the controller stops wherever the program turns by more than 30 deg
  (docs/dynamic-plant.md, "Stops at sharp corners"; a CS8C's `movel` without blending). Each corner of the ideal
  path is rounded here by a quadratic Bezier curve tangent to both sides `ROUND_MM` either side of it, on the same
  samples at the same times, so that no sample turns by 30 deg; that path is compensated with the same learned twin
  and formed. Both runs are scored on the plant's true tip against the sharp ideal path (the rounding's own
  deviation counts as a miss), and the seconds each run took beyond its program's are its stops. The compensation
  turns some corners of the rounded path sharp again (its offsets change there), so the compensated run keeps some
  stops; the nominal runs, sharp and rounded (none), show the robot's part with and without them;
- **where the sharp run misses**: the share of its true tip's mean square within `NEAR_CORNER_MM` of a corner
  (along the path; about the tool's radius), beside the samples' share there;
- **the arm's answer to the measured force**: the learned robot driven by the run's measured forces
  (`twin.analysis.learn.split.measured_force_tip`: springs, sticking friction, servo transient) against the true
  tip; then with a linear dynamic term added: each joint's torque from the measured force, as it was `TAP_S` to
  (`TAPS` - 1) x `TAP_S` earlier less as it is now (the arm's answer over 0.4 s, its servo's and modes' included;
  nothing at rest, so the springs keep the static part), fitted by ridge regression (an offset per axis free) on
  the tracker of another run and predicting this one: the nominal run of a 60 x 8 mm pyramid (another part, with
  corners; seed 1) and the nominal cone the twin learned from (no corner);
- **the next pyramid from this run's measured forces** (`compensate --forces-from`, `twin.analysis.next_part`): the
  command moved by the learned robot's predicted miss with the forces this run measured, without and with the
  dynamic term fitted on the 60 x 8 mm pyramid, and formed (seed 3): what a sheet known exactly, the last part's,
  leaves with that robot.

The plant's `truth_tip.csv` is read on the experiment's side only. Writes OUT/pyramid_corners.json,
OUT/pyramid_corners.md and with `--doc` the table between the page's pyramid-corners markers:

    .venv/bin/python experiments/learn_cell.py L1 --variants cone-tx200,cone-kr210,cone-irb6640
    .venv/bin/python experiments/learn_cell.py L2 --variants cone-tx200,cone-kr210,cone-irb6640 \\
        --plant-set sheet_law=2
    .venv/bin/python experiments/pyramid_corners.py OUT --law1 L1 --law2 L2 [--doc docs/learning.md]

(about 2 minutes on top of `learn_cell.py`'s runs).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from experiments_cli import cli, lab_neutral
from learn_cell import cone_cells_parser, cone_study
from online_study import rms_mm, true_tip_miss_mm

from twin.analysis.check import ideal_times
from twin.analysis.learn.robot import robot_rows
from twin.analysis.learn.servo_fit import corner_indices
from twin.analysis.learn.split import measured_force_tip
from twin.analysis.next_part import next_command
from twin.analysis.replay import spec_for_run
from twin.base.signals import arc_length, interp_rows
from twin.runs.format import Stream
from twin.runs.read import read_commanded_csv, read_run
from twin.runs.write import write_path_csv
from twin.sim.model_file import read_model_file

#: How far either side of a corner the rounded path leaves the sharp one [mm].
ROUND_MM = 1.0
#: How near a corner along the path counts as at it [mm] (about the tool's radius, 7.5 mm).
NEAR_CORNER_MM = 8.0
#: The other pyramid the dynamic term is fitted on (`path`'s arguments): another part with corners.
OTHER_PYRAMID = ("--shape", "pyramid", "--top-width-mm", "60", "--depth-mm", "8")
#: The dynamic term's taps: how many, and how far apart [s].
TAPS, TAP_S = 20, 0.02
#: Its ridge: this share of the mean diagonal of the normal equations.
RIDGE = 1e-4


def turns_deg(p: np.ndarray) -> np.ndarray:
    """The turn at each inner sample of a polyline [deg], (n - 2,)."""
    d = np.diff(p, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    return np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0)))


def rounded(p_mm: np.ndarray, reach_mm: float = ROUND_MM) -> np.ndarray:
    """The path with each corner replaced, on the same samples, by the quadratic Bezier curve from the point
    `reach_mm` before it along the path, through the corner as control point, to the point `reach_mm` after it."""
    s, q = arc_length(p_mm), p_mm.copy()
    for k in corner_indices(p_mm):
        if s[k] - reach_mm < 0.0 or s[k] + reach_mm > s[-1]:
            continue
        p0, p2 = (np.array([np.interp(s[k] + sign * reach_mm, s, p_mm[:, i]) for i in range(3)]) for sign in (-1, 1))
        for j in np.nonzero(np.abs(s - s[k]) < reach_mm)[0]:
            t = (s[j] - s[k] + reach_mm) / (2.0 * reach_mm)
            q[j] = (1 - t) ** 2 * p0 + 2 * t * (1 - t) * p_mm[k] + t**2 * p2
    return q


def write_rounded(ideal: Path, out: Path) -> float:
    """Write `ideal` (a `path` file) with its corners `rounded` to `out`, every other column as it was; return the
    rounded path's rms deviation from the sharp one [mm]. Raises SystemExit where a sample still turns past
    `CORNER_TURN_DEG` (the controller would stop there, `twin.analysis.learn.servo_fit.corner_indices`)."""
    lines = ideal.read_text(encoding="utf-8").splitlines()
    header, rows = lines[0], [line.split(",") for line in lines[1:]]
    cols = [header.split(",").index(c) for c in ("x_mm", "y_mm", "z_mm")]
    p = np.array([[float(r[c]) for c in cols] for r in rows])
    q = rounded(p)
    if len(corner_indices(q)):
        raise SystemExit(f"{ideal}: rounded by {ROUND_MM} mm a sample still turns by {np.max(turns_deg(q)):.1f} deg")
    for r, x in zip(rows, q, strict=True):
        for c, v in zip(cols, x, strict=True):
            r[c] = f"{v:.4f}"
    out.write_text("\n".join([header, *(",".join(r) for r in rows)]) + "\n", encoding="utf-8")
    return float(np.sqrt(np.mean(np.sum((q - p) ** 2, axis=1))))


def stop_seconds(run_dir: Path, ideal: Path) -> float:
    """How much longer the run took than its program [s]: the controller's stops."""
    run, t_program = read_run(run_dir), read_commanded_csv(ideal).t_s
    return float(run.commanded.t_s[-1] - t_program[-1])


def near_corner_shares(run_dir: Path, ideal: Path, miss_mm: np.ndarray) -> tuple[float, float]:
    """(the share of the miss's mean square within `NEAR_CORNER_MM` of a corner along the path, the samples'
    share there) [-]; the tracker's samples placed on the ideal path by the run's clock (`ideal_times`)."""
    run, cmd = read_run(run_dir), read_commanded_csv(ideal)
    p_mm = 1e3 * cmd.values
    s = arc_length(p_mm)
    s_tr = np.interp(run.tracker.t_s, ideal_times(run.commanded.t_s, cmd.t_s), s)
    near = np.min(np.abs(s_tr[:, None] - s[corner_indices(p_mm)][None, :]), axis=1) < NEAR_CORNER_MM
    square = np.sum(miss_mm**2, axis=1)
    return float(np.sum(square[near]) / np.sum(square)), float(np.mean(near))


class Arm(NamedTuple):
    """A run as the dynamic term sees it."""

    miss_m: np.ndarray  # the true tip or the tracker less it, (m, 3) [m]
    columns: np.ndarray  # the dynamic term's columns, (3m, dof * (TAPS - 1)), stacked x, y, z
    tracker_t_s: np.ndarray  # the tracker's times [s], (m,)


def _arm(run_dir: Path, model: Path, truth: bool) -> Arm:
    """The learned robot's miss of the run's true tip (`truth`; the experiment's side only) or of its tracker (what a
    lab has), and the dynamic term's columns on that run."""
    run = read_run(run_dir)
    twin = spec_for_run(run, read_model_file(model)).build()
    if truth:
        tip = read_commanded_csv(run_dir / "truth_tip.csv")
        seen = interp_rows(run.tracker.t_s, tip.t_s, tip.values)
    else:
        seen = run.tracker.values
    rows = robot_rows(run, twin)
    dof = rows.jacobian.shape[2]
    now = np.einsum("nij,ni->nj", rows.jacobian, interp_rows(rows.t_s, rows.force_t_s, rows.force_n))
    cols = []
    for j in range(dof):
        for k in range(1, TAPS):
            then = np.einsum("ni,ni->n", rows.jacobian[:, :, j], interp_rows(rows.t_s - k * TAP_S, rows.force_t_s,
                                                                            rows.force_n))
            cols.append((rows.jacobian[:, :, j] * (then - now[:, j])[:, None]).T.reshape(-1))
    return Arm(seen - measured_force_tip(run, twin), np.array(cols).T, run.tracker.t_s)


def dynamic_term(arm: Arm) -> np.ndarray:
    """The dynamic term's coefficients, fitted by ridge regression on a run's miss (`_arm`), its offset per axis
    free."""
    m = len(arm.tracker_t_s)
    x = np.hstack([arm.columns, np.kron(np.eye(3), np.ones((m, 1)))])
    gram = x.T @ x
    ridge = RIDGE * np.mean(np.diag(gram)) * np.eye(len(gram))
    ridge[-3:, -3:] = 0.0
    return np.linalg.solve(gram + ridge, x.T @ arm.miss_m.T.reshape(-1))[:-3]


def _robot_mm(arm: Arm, coef: np.ndarray | None) -> float:
    """The rms of the robot's miss [mm], less the dynamic term with `coef` where given."""
    miss = arm.miss_m if coef is None else arm.miss_m - (arm.columns @ coef).reshape(3, -1).T
    return rms_mm(1e3 * miss)


def next_part(ideal: Path, run_dir: Path, model: Path, arm: Arm, coef: np.ndarray | None, out: Path) -> Path:
    """The next part's command from `run_dir`'s measured forces (`twin.analysis.next_part`, `compensate
    --forces-from`), less the dynamic term with `coef` where given, written as `out`."""
    run, cmd = read_run(run_dir), read_commanded_csv(ideal)
    following = next_command(run, cmd.t_s, cmd.values, spec_for_run(run, read_model_file(model)).build())
    p = following.p_cmd_sheet_m
    if coef is not None:
        t_run = ideal_times(run.commanded.t_s, cmd.t_s)
        p = p - interp_rows(t_run, arm.tracker_t_s, (arm.columns @ coef).reshape(3, -1).T)
    write_path_csv(Stream(cmd.t_s, p), out)
    return out


def cell_row(out: Path, robot: str, folder: Path, plant_set: tuple[str, ...]) -> dict[str, Any]:
    """One cell's numbers (module docstring)."""
    ideal, model, sharp = folder / "pyramid_path.csv", folder / "learned.json", folder / "pyramid_learned_formed"
    out.mkdir(parents=True, exist_ok=True)
    path, command, formed = out / "rounded_path.csv", out / "rounded_learned.csv", out / "rounded_learned_formed"
    deviation = write_rounded(ideal, path)
    for old in (command, command.with_suffix(".compensation.json")):
        old.unlink(missing_ok=True)
    cli("compensate", "--method", "twin", "--model", str(model), "--ideal", str(path), "--out", str(command))

    def lab(program: Path, run_dir: Path, scenario: str, seed: int) -> Path:
        return lab_neutral(robot, program, run_dir, seed, scenario, plant_set)

    lab(command, formed, "compensated", 3)
    lab(path, out / "rounded_nominal", "nominal", 3)
    other = out / "pyramid60.csv"
    cli("path", *OTHER_PYRAMID, "--robot", robot, "--out", str(other))
    terms = {"pyramid60": dynamic_term(_arm(lab(other, out / "pyramid60_nominal", "nominal", 1), model, False)),
             "cone": dynamic_term(_arm(folder / "nominal1", model, False))}
    miss = true_tip_miss_mm(sharp, ideal)
    near, samples = near_corner_shares(sharp, ideal, miss)
    target = _arm(sharp, model, True)
    row = {"sharp_mm": rms_mm(miss), "sharp_stops_s": stop_seconds(sharp, ideal),
           "rounded_mm": rms_mm(true_tip_miss_mm(formed, ideal)), "rounded_stops_s": stop_seconds(formed, path),
           "rounding_mm": deviation, "near_corner": near, "samples_near_corner": samples,
           "nominal_arm_mm": _robot_mm(_arm(folder / "pyramid_nominal", model, True), None),
           "nominal_stops_s": stop_seconds(folder / "pyramid_nominal", ideal),
           "rounded_nominal_arm_mm": _robot_mm(_arm(out / "rounded_nominal", model, True), None),
           "rounded_nominal_stops_s": stop_seconds(out / "rounded_nominal", path),
           "arm_mm": _robot_mm(target, None),
           **{f"arm_dynamic_{name}_mm": _robot_mm(target, coef) for name, coef in terms.items()}}
    for name, coef in (("static", None), ("dynamic", terms["pyramid60"])):
        program = next_part(ideal, sharp, model, target, coef, out / f"next_{name}.csv")
        row[f"next_{name}_mm"] = rms_mm(true_tip_miss_mm(lab(program, out / f"next_{name}", "compensated", 3), ideal))
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = [f"The pyramid compensated with the twin learned from the nominal cone, formed with seed 3 (neutral knobs)"
             f": its sharp corners, and each rounded {ROUND_MM:g} mm either side so that the controller does not stop "
             f"there (true tip against the sharp ideal path); where the sharp run misses; the learned robot driven by "
             f"a run's measured forces against its true tip: on the nominal runs, sharp and rounded; on the "
             f"compensated sharp run, alone and with a linear dynamic term of the force fitted on another run's "
             f"tracker; and the next pyramid, its command moved by that robot's predicted miss with the forces the "
             f"compensated run measured.", "",
             "| cell | true tip, sharp corners [mm] (stops [s]) | rounded [mm] (stops [s]; the rounding alone [mm]) "
             "| nominal runs, robot with the run's forces [mm]: sharp (stops [s]) / rounded (stops [s]) "
             f"| share of the sharp run's mean square within {NEAR_CORNER_MM:g} mm of a corner, of the samples' | "
             "robot with the run's forces [mm]: learned / + dynamic term fitted on a 60 x 8 pyramid / "
             "on the nominal cone | the next pyramid from the run's forces, true tip [mm]: learned robot / + dynamic "
             "term |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['cell']} | {r['sharp_mm']:.3f} ({r['sharp_stops_s']:.1f}) | {r['rounded_mm']:.3f} "
                     f"({r['rounded_stops_s']:.1f}; {r['rounding_mm']:.3f}) | {r['nominal_arm_mm']:.3f} "
                     f"({r['nominal_stops_s']:.1f}) / {r['rounded_nominal_arm_mm']:.3f} "
                     f"({r['rounded_nominal_stops_s']:.1f}) | {r['near_corner']:.2f} of "
                     f"{r['samples_near_corner']:.2f} | {r['arm_mm']:.3f} / {r['arm_dynamic_pyramid60_mm']:.3f} / "
                     f"{r['arm_dynamic_cone_mm']:.3f} | {r['next_static_mm']:.3f} / {r['next_dynamic_mm']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    cone_study(cone_cells_parser(__doc__.splitlines()[0]).parse_args(), "pyramid_corners", "pyramid-corners",
               lambda work, robot, folder, plant_set: [cell_row(work, robot, folder, plant_set)], table)


if __name__ == "__main__":
    main()
