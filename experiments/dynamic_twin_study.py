"""The dynamic twin (`twin.sim.dynamic`) against the quasi-static one on pyramid runs of the dynamic plant.

For each cell (the TX200 with the plant's default servo, and a plant variant whose servo differs: its position
loop at 0.35 of the joint's mode and damping 0.7, set by the lab's knobs), a 40 x 6 mm pyramid (corner stops every
side) is formed twice (seeds 1 and 2) by `tx200-twin lab --plant dynamic`. Run 1 is `learn`ed (`--write-model`)
and the dynamic twin's servo is fitted to run 1's tracker (`twin.analysis.learn.servo_fit.fit_servo`); run 2,
which neither saw, is replayed by the learned quasi-static twin (`replay`, its learned servo transient included),
by the dynamic twin with a rigid servo and with the fitted one. Each is scored against run 2's tracker and against
the plant's true tip, over the whole run and within `CORNER_RADIUS_M` of a corner, with each replay's wall time.

The plant is run through the CLI; its true tip is not in the run directory, so the same run is made again through
`run_dynamic_lab` (same knobs and seed; its tracker is checked to be the CLI run's) and only its true tip is read.
Nothing on the twin's side reads the plant's code, knobs or truth. Writes OUT/dynamic_twin.json, OUT/dynamic_twin.md
and with `--doc` the tables between the dynamic-twin markers of that page:

    .venv/bin/python experiments/dynamic_twin_study.py OUT [--doc docs/dynamic-twin.md]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from experiments_cli import cli, write_between_markers

from twin.analysis.learn.servo_fit import dynamic_replay, fit_servo, near_corners, prepare
from twin.analysis.replay import replay
from twin.analysis.resolve import resolve_spec
from twin.base.signals import interp_rows
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.run import run_dynamic_lab
from twin.runs.format import Run
from twin.runs.read import read_commanded_csv, read_run
from twin.sim.dynamic import ServoModel

ROBOT = "tx200"
PART = ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "6"]
#: The cells: the plant's knobs set on each (NAME=VALUE).
CELLS: dict[str, tuple[str, ...]] = {
    "TX200, plant's default servo": (),
    "TX200, servo variant (bandwidth 0.35 of mode, damping 0.7)": ("servo_bandwidth_over_mode=0.35",
                                                                   "servo_damping_ratio=0.7"),
}
#: A sample is at a corner within this distance of the commanded tip from the nearest corner or reversal [m]
#: (the 40 mm pyramid's sides leave no sample 30 mm from a corner; 5 mm is the stop ramps and what follows them).
CORNER_RADIUS_M = 5e-3


def _lab(command: Path, out: Path, seed: int, knobs: tuple[str, ...]) -> Run:
    sets = [arg for knob in knobs for arg in ("--set", knob)]
    cli("lab", "--plant", "dynamic", "--robot", ROBOT, "--scenario", "nominal", "--seed", str(seed), "--commanded",
        str(command), "--out", str(out), "--overwrite", *sets)
    return read_run(out)


def _true_tip(command: Path, seed: int, knobs: tuple[str, ...], run: Run) -> tuple[np.ndarray, np.ndarray]:
    """The plant's true tip of the run the CLI made (the same run made again; its tracker checked)."""
    cmd = read_commanded_csv(command)
    values = {k: float(v) for k, v in (item.split("=") for item in knobs)}
    again, _, log = run_dynamic_lab(cmd.t_s, cmd.values, scenario="nominal", knobs=Knobs(values), seed=seed,
                                    robot=ROBOT)
    if not np.allclose(again.tracker.values, run.tracker.values, rtol=0, atol=1e-9):
        raise SystemExit("the run made again is not the CLI's run: its true tip would not be this run's")
    return log.t_s, log.p_tip_sheet_m


def _rms_mm(e: np.ndarray) -> float:
    return 1e3 * float(np.sqrt(np.mean(np.sum(e**2, axis=1)))) if len(e) else math.nan


def _scores(run: Run, tracker_pred: np.ndarray, t_sim: np.ndarray, tip: np.ndarray, truth: tuple) -> dict:
    near = near_corners(run, CORNER_RADIUS_M)
    e = run.tracker.values - tracker_pred
    t_true, p_true = truth
    inside = (t_true >= t_sim[0]) & (t_true <= t_sim[-1])
    et = interp_rows(t_true[inside], t_sim, tip) - p_true[inside]
    near_t = near_corners(run, CORNER_RADIUS_M, t_true[inside])
    return {"tracker_mm": _rms_mm(e), "tracker_corners_mm": _rms_mm(e[near]), "true_mm": _rms_mm(et),
            "true_corners_mm": _rms_mm(et[near_t]), "corner_share": float(near.mean())}


def cell_study(out: Path, name: str, knobs: tuple[str, ...]) -> dict[str, Any]:
    """One cell's rows (module docstring)."""
    out.mkdir(parents=True, exist_ok=True)
    path, model = out / "pyramid.csv", out / "learned.json"
    cli("path", *PART, "--robot", ROBOT, "--out", str(path))
    run1, run2 = (_lab(path, out / f"run{seed}", seed, knobs) for seed in (1, 2))
    cli("learn", str(out / "run1"), "--write-model", str(model))
    fit = fit_servo(run1, resolve_spec(model=model, run=run1))
    spec2 = resolve_spec(model=model, run=run2)
    truth = _true_tip(path, 2, knobs, run2)
    rows = []
    start = time.perf_counter()
    qs = replay(run2, spec2)
    wall = time.perf_counter() - start
    rows.append({"twin": "quasi-static (learned, its servo transient)", "wall_s": wall,
                 **_scores(run2, qs.tracker_pred_m, qs.sim.t_s, qs.sim.p_sheet_m, truth)})
    start = time.perf_counter()
    dyn = dynamic_replay(run2, spec2, fit.servo)
    wall = time.perf_counter() - start
    rigid = dynamic_replay(run2, prepare(run2, spec2), ServoModel(math.inf, 1.0, 0.0))
    rows.append({"twin": "dynamic, rigid servo", "wall_s": math.nan,
                 **_scores(run2, rigid.tracker_pred_m, rigid.sim.t_s, rigid.sim.p_sheet_m, truth)})
    rows.append({"twin": "dynamic, servo fitted on run 1", "wall_s": wall,
                 **_scores(run2, dyn.tracker_pred_m, dyn.sim.t_s, dyn.sim.p_sheet_m, truth)})
    s = fit.servo
    return {"cell": name, "knobs": list(knobs), "rows": rows, "steps": int(1e3 * (run2.commanded.t_s[-1])) + 1,
            "fit": {"bandwidth_over_mode": s.bandwidth_over_mode, "damping_ratio": s.damping_ratio,
                    "delay_s": s.delay_s, "feedforward": s.feedforward, "load_feedforward": s.load_feedforward,
                    "bandwidth_hz": [w / (2 * math.pi) for w in fit.bandwidth_rad_s], "stop_lag_s": fit.stop_lag_s,
                    "rms_rigid_mm": fit.rms_rigid_mm, "rms_mm": fit.rms_mm, "evaluations": fit.evaluations,
                    "wall_s": fit.wall_s}}


def table(cells: list[dict[str, Any]]) -> str:
    """The two markdown tables (module docstring)."""
    lines = [f"Run 2 (seed 2, never learned from) replayed; corners: samples within {1e3 * CORNER_RADIUS_M:.0f} mm of "
             "a corner or reversal.", "",
             "| cell | twin | tracker rms, all / corners [mm] | true tip rms, all / corners [mm] | replay wall [s] |",
             "|---|---|---|---|---|"]
    for c in cells:
        for r in c["rows"]:
            wall = "-" if math.isnan(r["wall_s"]) else f"{r['wall_s']:.2f}"
            lines.append(f"| {c['cell']} | {r['twin']} | {r['tracker_mm']:.3f} / {r['tracker_corners_mm']:.3f} | "
                         f"{r['true_mm']:.3f} / {r['true_corners_mm']:.3f} | {wall} |")
    lines += ["", "Servo fitted on run 1 (`fit_servo`; mj_steps per dynamic replay: the run's milliseconds):", "",
              "| cell | beta | zeta | delay [ms] | feed-forward | load fed forward | bandwidth j1-j3 [Hz] | "
              "stop lag [ms] | run 1 tracker rms, rigid -> fitted [mm] | replays | fit wall [s] | mj_steps |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in cells:
        f = c["fit"]
        hz = ", ".join(f"{w:.1f}" for w in f["bandwidth_hz"][:3])
        lines.append(f"| {c['cell']} | {f['bandwidth_over_mode']:.2f} | {f['damping_ratio']:.2f} | "
                     f"{1e3 * f['delay_s']:.1f} | {f['feedforward']:.2f} | {f['load_feedforward']:.2f} | {hz} | "
                     f"{1e3 * f['stop_lag_s']:.0f} | "
                     f"{f['rms_rigid_mm']:.3f} -> {f['rms_mm']:.3f} | {f['evaluations']} | {f['wall_s']:.0f} | "
                     f"{c['steps']} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--doc", type=Path, help="write the tables into this page between its markers")
    args = parser.parse_args()
    cells = []
    for i, (name, knobs) in enumerate(CELLS.items()):
        cells.append(cell_study(args.out / f"cell{i + 1}", name, knobs))
        print(table(cells[-1:]), flush=True)
    (args.out / "dynamic_twin.json").write_text(json.dumps(cells, indent=1))
    (args.out / "dynamic_twin.md").write_text(table(cells))
    print(table(cells))
    if args.doc is not None:
        write_between_markers(args.doc, "dynamic-twin", table(cells))


if __name__ == "__main__":
    main()
