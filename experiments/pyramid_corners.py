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
  tip, each axis less its mean; then with a linear dynamic term added, each joint's torque from the measured force
  through `TAPS` taps `TAP_S` apart (the arm's answer over 0.4 s, its servo's and modes' included), fitted by
  ridge regression on another run and predicting this one: on the nominal run of the same pyramid (a run with the
  same corners) and on the nominal cone the twin learned from (no corner).

The plant's `truth_tip.csv` is read on the experiment's side only. Writes OUT/pyramid_corners.json,
OUT/pyramid_corners.md and with `--doc` the table between the page's pyramid-corners markers:

    .venv/bin/python experiments/learn_cell.py L1 --variants cone-tx200,cone-kr210,cone-irb6640
    .venv/bin/python experiments/learn_cell.py L2 --variants cone-tx200,cone-kr210,cone-irb6640 \\
        --plant-set sheet_law=2
    .venv/bin/python experiments/pyramid_corners.py OUT --law1 L1 --law2 L2 [--doc docs/learning.md]
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from experiments_cli import cli, write_between_markers
from learn_cell import cone_cells, cone_cells_parser
from online_study import rms_mm, true_tip_miss_mm

from twin.analysis.check import ideal_times
from twin.analysis.learn.robot import robot_rows
from twin.analysis.learn.split import measured_force_tip
from twin.analysis.replay import spec_for_run
from twin.base.signals import interp_rows
from twin.runs.read import read_commanded_csv, read_run
from twin.sim.model_file import read_model_file

#: How far either side of a corner the rounded path leaves the sharp one [mm].
ROUND_MM = 1.0
#: A turn of the program past this is a corner the controller stops at [deg] (docs/dynamic-plant.md).
STOP_TURN_DEG = 30.0
#: How near a corner along the path counts as at it [mm] (about the tool's radius, 7.5 mm).
NEAR_CORNER_MM = 8.0
#: The dynamic term's taps: how many, and how far apart [s].
TAPS, TAP_S = 20, 0.02
#: Its ridge: this share of the mean diagonal of the normal equations.
RIDGE = 1e-4


def turns_deg(p: np.ndarray) -> np.ndarray:
    """The turn at each inner sample of a polyline [deg], (n - 2,)."""
    d = np.diff(p, axis=0)
    u = d / np.linalg.norm(d, axis=1)[:, None]
    return np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1.0, 1.0)))


def _arc(p: np.ndarray) -> np.ndarray:
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]


def corners(p_mm: np.ndarray) -> np.ndarray:
    """The indices of the samples where the path turns by more than `STOP_TURN_DEG`."""
    return np.nonzero(turns_deg(p_mm) > STOP_TURN_DEG)[0] + 1


def rounded(p_mm: np.ndarray, reach_mm: float = ROUND_MM) -> np.ndarray:
    """The path with each corner replaced, on the same samples, by the quadratic Bezier curve from the point
    `reach_mm` before it along the path, through the corner as control point, to the point `reach_mm` after it."""
    s, q = _arc(p_mm), p_mm.copy()
    for k in corners(p_mm):
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
    `STOP_TURN_DEG` (the controller would stop there)."""
    lines = ideal.read_text(encoding="utf-8").splitlines()
    header, rows = lines[0], [line.split(",") for line in lines[1:]]
    cols = [header.split(",").index(c) for c in ("x_mm", "y_mm", "z_mm")]
    p = np.array([[float(r[c]) for c in cols] for r in rows])
    q = rounded(p)
    if np.max(turns_deg(q)) >= STOP_TURN_DEG:
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
    s = _arc(p_mm)
    s_tr = np.interp(run.tracker.t_s, ideal_times(run.commanded.t_s, cmd.t_s), s)
    near = np.min(np.abs(s_tr[:, None] - s[corners(p_mm)][None, :]), axis=1) < NEAR_CORNER_MM
    square = np.sum(miss_mm**2, axis=1)
    return float(np.sum(square[near]) / np.sum(square)), float(np.mean(near))


def _arm(run_dir: Path, model: Path) -> tuple[np.ndarray, np.ndarray]:
    """(the learned robot's miss of the true tip with the run's measured forces, each axis less its mean [m],
    (m, 3); the dynamic term's columns on that run, (3m, dof * TAPS), each less its mean per axis)."""
    run = read_run(run_dir)
    twin = spec_for_run(run, read_model_file(model)).build()
    truth = read_commanded_csv(run_dir / "truth_tip.csv")
    miss = interp_rows(run.tracker.t_s, truth.t_s, truth.values) - measured_force_tip(run, twin)
    rows = robot_rows(run, twin)
    m, dof = len(rows.t_s), rows.jacobian.shape[2]
    cols = []
    for j in range(dof):
        for k in range(TAPS):
            force = interp_rows(rows.t_s - k * TAP_S, rows.force_t_s, rows.force_n)
            torque = np.einsum("nij,ni->n", rows.jacobian[:, :, j:j + 1], force)
            cols.append((rows.jacobian[:, :, j] * torque[:, None]).T.reshape(-1))
    x = np.array(cols).T.reshape(3, m, -1)
    return miss - miss.mean(axis=0), (x - x.mean(axis=1, keepdims=True)).reshape(3 * m, -1)


def dynamic_term(train: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The dynamic term's coefficients fitted by ridge regression on runs' (`_arm`) misses."""
    x = np.vstack([cols for _, cols in train])
    y = np.concatenate([miss.T.reshape(-1) for miss, _ in train])
    gram = x.T @ x
    return np.linalg.solve(gram + RIDGE * np.mean(np.diag(gram)) * np.eye(len(gram)), x.T @ y)


def cell_row(out: Path, robot: str, folder: Path, plant_set: tuple[str, ...]) -> dict[str, Any]:
    """One cell's numbers (module docstring)."""
    ideal, model, sharp = folder / "pyramid_path.csv", folder / "learned.json", folder / "pyramid_learned_formed"
    out.mkdir(parents=True, exist_ok=True)
    path, command, formed = out / "rounded_path.csv", out / "rounded_learned.csv", out / "rounded_learned_formed"
    deviation = write_rounded(ideal, path)
    for old in (command, command.with_suffix(".compensation.json")):
        old.unlink(missing_ok=True)
    cli("compensate", "--method", "twin", "--model", str(model), "--ideal", str(path), "--out", str(command))
    knobs = ("--plant", "dynamic", "--neutral", *(a for item in plant_set for a in ("--set", item)))
    cli("lab", *knobs, "--scenario", "compensated", "--commanded", str(command), "--seed", "3", "--robot", robot,
        "--out", str(formed), "--overwrite")
    cli("lab", *knobs, "--scenario", "nominal", "--commanded", str(path), "--seed", "3", "--robot", robot, "--out",
        str(out / "rounded_nominal"), "--overwrite")
    miss = true_tip_miss_mm(sharp, ideal)
    near, samples = near_corner_shares(sharp, ideal, miss)
    target = _arm(sharp, model)
    predicted = {name: target[0].T.reshape(-1) - target[1] @ dynamic_term([_arm(folder / run, model)])
                 for name, run in (("pyramid", "pyramid_nominal"), ("cone", "nominal1"))}
    return {"sharp_mm": rms_mm(miss), "sharp_stops_s": stop_seconds(sharp, ideal),
            "rounded_mm": rms_mm(true_tip_miss_mm(formed, ideal)), "rounded_stops_s": stop_seconds(formed, path),
            "rounding_mm": deviation, "near_corner": near, "samples_near_corner": samples,
            "arm_mm": rms_mm(1e3 * target[0]),
            "nominal_arm_mm": rms_mm(1e3 * _arm(folder / "pyramid_nominal", model)[0]),
            "nominal_stops_s": stop_seconds(folder / "pyramid_nominal", ideal),
            "rounded_nominal_arm_mm": rms_mm(1e3 * _arm(out / "rounded_nominal", model)[0]),
            "rounded_nominal_stops_s": stop_seconds(out / "rounded_nominal", path),
            **{f"arm_dynamic_{name}_mm": rms_mm(1e3 * e.reshape(3, -1).T) for name, e in predicted.items()}}


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = [f"The pyramid compensated with the twin learned from the nominal cone, formed with seed 3 (neutral knobs)"
             f": its sharp corners, and each rounded {ROUND_MM:g} mm either side so that the controller does not stop "
             f"there (true tip against the sharp ideal path); where the sharp run misses; the learned robot driven by "
             f"a run's measured forces against its true tip, each axis less its mean: on the nominal runs, sharp and "
             f"rounded; on the compensated sharp run, alone and with a linear dynamic term of the force fitted on "
             f"another run.", "",
             "| cell | true tip, sharp corners [mm] (stops [s]) | rounded [mm] (stops [s]; the rounding alone [mm]) "
             "| nominal runs, robot with the run's forces [mm]: sharp (stops [s]) / rounded (stops [s]) "
             f"| share of the sharp run's mean square within {NEAR_CORNER_MM:g} mm of a corner, of the samples' | "
             "robot with the run's forces [mm]: learned / + dynamic term fitted on the nominal pyramid / "
             "on the nominal cone |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['cell']} | {r['sharp_mm']:.3f} ({r['sharp_stops_s']:.1f}) | {r['rounded_mm']:.3f} "
                     f"({r['rounded_stops_s']:.1f}; {r['rounding_mm']:.3f}) | {r['nominal_arm_mm']:.3f} "
                     f"({r['nominal_stops_s']:.1f}) / {r['rounded_nominal_arm_mm']:.3f} "
                     f"({r['rounded_nominal_stops_s']:.1f}) | {r['near_corner']:.2f} of "
                     f"{r['samples_near_corner']:.2f} | {r['arm_mm']:.3f} / {r['arm_dynamic_pyramid_mm']:.3f} / "
                     f"{r['arm_dynamic_cone_mm']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    args = cone_cells_parser(__doc__.splitlines()[0]).parse_args()
    rows: list[dict[str, Any]] = []
    for cell, robot, folder, plant_set in cone_cells(args.law1, args.law2):
        tag = f"{robot}_law{2 if plant_set else 1}"
        rows.append({"cell": cell, **cell_row(args.out / tag, robot, folder, plant_set)})
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    (args.out / "pyramid_corners.json").write_text(json.dumps(rows, indent=1))
    (args.out / "pyramid_corners.md").write_text(table(rows))
    print(table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, "pyramid-corners", table(rows))


if __name__ == "__main__":
    main()
