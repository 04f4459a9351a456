"""Compensation with the dynamic twin (`compensate --dynamic`) against the quasi-static one, formed on the plant.

Reads the output folder of `experiments/dynamic_twin_study.py` (per cell: its 40 x 6 mm pyramid, the model learned
from run 1 and the servo fitted on run 1's tracker) and, per cell, writes the model with that servo
(`dynamic_servo`); makes two groove cells of its own (`GROOVES`: the groove formed with seed 1 and learned with
`learn --dynamic`, which fits the servo as a user's would); and compensates each part twice through the CLI
(`compensate --method twin`, then the same with `--dynamic`), forms each command on the dynamic plant (`lab --plant
dynamic --scenario compensated --seed 3`, the cell's knobs: a run neither learned from) and scores it against the
part's path with `check`'s residual: on the
tracker, and on the plant's true tip (its `truth_tip.csv`, read here on the experiment's side only), over the whole
run and within `CORNER_RADIUS_M` of a corner or reversal; with the mean height of the true tip over the ideal
path above and below `DEEP_M` (where the sheet's force is largest). The dynamic twin's own rms before (on the
quasi-static command) and after its iteration, and each compensation's wall, come from `compensate --json`. A
second table gives what is left on the pyramids: on the quasi-static compensation's formed run, the measured Fz and
the learned twin's (`replay` with the learned model) by the ideal path's depth, in 1 mm bins. A third gives each
groove command formed again with the controller compensating online on top, with the same model ("both": the
force the command did not assume, docs/online.md): the dynamic twin's feed-forward and the online correction
together.

    .venv/bin/python experiments/dynamic_twin_study.py DTS
    .venv/bin/python experiments/dynamic_compensation_study.py OUT --from DTS [--doc docs/dynamic-twin.md]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from dynamic_twin_study import CELLS, CORNER_RADIUS_M, ROBOT
from experiments_cli import cli, cli_json, write_between_markers
from online_study import true_tip_residual_mm

from twin.analysis.check import check_run
from twin.analysis.learn.servo_fit import near_corners
from twin.analysis.replay import replay
from twin.analysis.resolve import resolve_spec
from twin.runs.read import read_commanded_csv, read_run
from twin.sim.dynamic_servo import ServoModel
from twin.sim.model_file import read_model_file, write_model_file

#: Depth below which the true tip's mean height is reported apart [m] (half the pyramid's 6 mm).
DEEP_M = 3e-3
SEED = 3
#: The groove cells (name -> the plant's knob arguments): learned from their own nominal run with `learn --dynamic`.
GROOVES: dict[str, tuple[str, ...]] = {"TX200 groove, neutral knobs": ("--neutral",),
                                       "TX200 groove, plant's default knobs": ()}


def _score(run_dir: Path, ideal: Path) -> dict[str, float]:
    """The formed run's residual to the ideal path (module docstring) [mm]; the true tip is at the tracker's stamps."""
    cmd, run = read_commanded_csv(ideal), read_run(run_dir)
    rms = lambda e: float(np.sqrt(np.mean(np.sum(e**2, axis=1)))) if len(e) else math.nan  # noqa: E731
    tracker = 1e3 * check_run(run, cmd.t_s, cmd.values).residual_m
    true = true_tip_residual_mm(run_dir, run, cmd)
    if true is None:
        raise SystemExit(f"{run_dir}: no truth_tip.csv (a run of the dynamic plant writes one)")
    near = near_corners(run, CORNER_RADIUS_M)
    deep = np.interp(run.tracker.t_s, cmd.t_s, cmd.values[:, 2]) <= -DEEP_M
    return {"tracker_mm": rms(tracker), "tracker_corners_mm": rms(tracker[near]), "true_mm": rms(true),
            "true_corners_mm": rms(true[near]), "true_z_shallow_mm": float(np.mean(true[~deep, 2])),
            "true_z_deep_mm": float(np.mean(true[deep, 2]))}


def _force_by_depth(run_dir: Path, model: Path) -> list[dict[str, float]]:
    """Mean measured and replayed Fz per 1 mm of the commanded depth [N] (module docstring)."""
    run = read_run(run_dir)
    replayed = replay(run, resolve_spec(model=model, run=run))
    assert run.forces is not None and replayed.forces_pred_n is not None  # the plant's runs carry their F/T
    depth_mm = -1e3 * np.interp(run.forces.t_s, run.commanded.t_s, run.commanded.values[:, 2])
    rows = []
    for low in range(int(np.ceil(depth_mm.max()))):
        inside = (depth_mm >= low) & (depth_mm < low + 1)
        if inside.sum() >= 10:
            rows.append({"depth_mm": float(low), "measured_fz_n": float(np.mean(run.forces.values[inside, 2])),
                         "twin_fz_n": float(np.mean(replayed.forces_pred_n[inside, 2]))})
    return rows


def _compensate_and_form(out: Path, ideal: Path, model: Path, knobs: list[str],
                         online: bool = False) -> list[dict[str, Any]]:
    """The two compensations of `ideal` with `model` (its servo carried), each formed and scored; with `online`,
    each formed again with the controller compensating online, with the same model, the force its command did not
    assume ("both", docs/online.md)."""
    rows = []
    for name, extra in (("quasi-static", []), ("dynamic", ["--dynamic"])):
        command = out / f"{name}.csv"
        start = time.perf_counter()
        report = cli_json("compensate", "--method", "twin", "--model", str(model), "--ideal", str(ideal), *extra,
                          "--out", str(command))
        wall = time.perf_counter() - start
        cli("lab", "--plant", "dynamic", "--robot", ROBOT, "--scenario", "compensated", "--seed", str(SEED),
            "--commanded", str(command), "--out", str(out / f"{name}_formed"), "--overwrite", *knobs)
        history, dyn = report["residual_rms_per_iteration_mm"], report["dynamic"] is not None
        row = {"compensation": name, "wall_s": wall, "predicted_mm": report["predicted_residual_rms_mm"],
               "dynamic_start_mm": history[0] if dyn else math.nan,
               "dynamic_iterations": len(history) - 1 if dyn else 0, **_score(out / f"{name}_formed", ideal)}
        if online:
            cli("lab", "--plant", "dynamic", "--robot", ROBOT, "--scenario", "compensated", "--seed", str(SEED),
                "--commanded", str(command), "--online", "--model", str(model), "--out",
                str(out / f"{name}_online_formed"), "--overwrite", *knobs)
            row["online"] = _score(out / f"{name}_online_formed", ideal)
        rows.append(row)
    return rows


def pyramid_study(out: Path, source: Path, cell: dict[str, Any]) -> dict[str, Any]:
    """A pyramid cell of dynamic_twin_study.py: its learned model with the servo it fitted (module docstring)."""
    out.mkdir(parents=True, exist_ok=True)
    ideal, model = source / "pyramid.csv", out / "learned_dynamic.json"
    servo = ServoModel(**{f.name: cell["fit"][f.name] for f in fields(ServoModel)})
    model.unlink(missing_ok=True)
    write_model_file(model, replace(read_model_file(source / "learned.json"), dynamic_servo=servo))
    rows = _compensate_and_form(out, ideal, model, [arg for knob in cell["knobs"] for arg in ("--set", knob)])
    return {"cell": cell["cell"], "knobs": cell["knobs"], "rows": rows,
            "force_by_depth": _force_by_depth(out / "quasi-static_formed", model)}


def groove_study(out: Path, name: str, knobs: list[str]) -> dict[str, Any]:
    """A groove cell: its nominal run (seed 1) learned with `learn --dynamic` (module docstring)."""
    out.mkdir(parents=True, exist_ok=True)
    ideal, model = out / "groove.csv", out / "learned_dynamic.json"
    cli("path", "--shape", "groove", "--robot", ROBOT, "--out", str(ideal))
    cli("lab", "--plant", "dynamic", "--robot", ROBOT, "--scenario", "nominal", "--seed", "1", "--commanded",
        str(ideal), "--out", str(out / "nominal1"), "--overwrite", *knobs)
    model.unlink(missing_ok=True)
    cli("learn", str(out / "nominal1"), "--dynamic", "--write-model", str(model))
    return {"cell": name, "knobs": knobs, "rows": _compensate_and_form(out, ideal, model, knobs, online=True)}


def table(cells: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = [f"Each part compensated with the model learned from run 1 (the pyramids: dynamic-twin study's; the "
             f"grooves: `learn --dynamic` on their nominal run), formed with seed {SEED}; corners: within "
             f"{1e3 * CORNER_RADIUS_M:.0f} mm of a corner or reversal; true tip height over the ideal path, mean, "
             f"shallower / deeper than {1e3 * DEEP_M:.0f} mm.", "",
             "| cell | compensation | dynamic twin's rms, quasi-static command -> its own [mm] | iterations | "
             "compensate wall [s] | tracker rms, all / corners [mm] | true tip rms, all / corners [mm] | "
             "true tip height, shallow / deep [mm] |", "|---|---|---|---|---|---|---|---|"]
    for c in cells:
        for r in c["rows"]:
            dyn = ("-" if math.isnan(r["dynamic_start_mm"]) else
                   f"{r['dynamic_start_mm']:.3f} -> {r['predicted_mm']:.3f}")
            lines.append(f"| {c['cell']} | {r['compensation']} | {dyn} | {r['dynamic_iterations']} | "
                         f"{r['wall_s']:.1f} | {r['tracker_mm']:.3f} / {r['tracker_corners_mm']:.3f} | "
                         f"{r['true_mm']:.3f} / {r['true_corners_mm']:.3f} | "
                         f"{r['true_z_shallow_mm']:+.3f} / {r['true_z_deep_mm']:+.3f} |")
    pyramids = [c for c in cells if "force_by_depth" in c]
    depths = [f"{b['depth_mm']:.0f}-{b['depth_mm'] + 1:.0f}" for b in pyramids[0]["force_by_depth"]]
    lines += ["", "The quasi-static compensation's formed run: Fz measured / the learned twin's replay [N], mean by "
              "the ideal path's depth [mm]:", "", "| cell | " + " | ".join(depths) + " |",
              "|---|" + "---|" * len(depths)]
    for c in pyramids:
        cols = [f"{b['measured_fz_n']:.0f} / {b['twin_fz_n']:.0f}" for b in c["force_by_depth"]][:len(depths)]
        lines.append(f"| {c['cell']} | " + " | ".join(cols + ["-"] * (len(depths) - len(cols))) + " |")
    grooves = [c for c in cells if any("online" in r for r in c["rows"])]
    if grooves:
        lines += ["", "The grooves' commands formed again with the controller compensating online on top (\"both\": "
                  "`lab --online --model`, the force the command did not assume, docs/online.md):", "",
                  "| groove | command | tracker rms, all / reversals [mm] | true tip rms, all / reversals [mm] |",
                  "|---|---|---|---|"]
        for c in grooves:
            for r in c["rows"]:
                o = r["online"]
                lines.append(f"| {c['cell']} | {r['compensation']}, online on top | {o['tracker_mm']:.3f} / "
                             f"{o['tracker_corners_mm']:.3f} | {o['true_mm']:.3f} / {o['true_corners_mm']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--from", dest="source", type=Path, required=True,
                        help="the output folder of experiments/dynamic_twin_study.py")
    parser.add_argument("--doc", type=Path, help="write the table into this page between its markers")
    args = parser.parse_args()
    studied = json.loads((args.source / "dynamic_twin.json").read_text(encoding="utf-8"))
    if [c["cell"] for c in studied] != list(CELLS):
        raise SystemExit(f"{args.source}: its cells are not dynamic_twin_study.py's {list(CELLS)}")
    cells = []
    for i, cell in enumerate(studied):
        cells.append(pyramid_study(args.out / f"cell{i + 1}", args.source / f"cell{i + 1}", cell))
        print(table(cells), flush=True)
    for i, (name, knobs) in enumerate(GROOVES.items()):
        cells.append(groove_study(args.out / f"groove{i + 1}", name, list(knobs)))
    print(table(cells), flush=True)
    (args.out / "dynamic_compensation.json").write_text(json.dumps(cells, indent=1))
    (args.out / "dynamic_compensation.md").write_text(table(cells))
    if args.doc is not None:
        write_between_markers(args.doc, "dynamic-compensation", table(cells))


if __name__ == "__main__":
    main()
