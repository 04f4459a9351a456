"""Online compensation on the dynamic plant, against offline: nominal / offline / online residuals, with the twin's
default model and with a model `learn`ed from one nominal run of that plant (issue #39's comparison).

For each variant: a nominal run (seed 1) to learn from (`tx200-twin learn`); then with seed 3 the part formed
from its ideal path (nominal), from the twin's offline compensation of it (`compensate --method twin`, default or
learned model), and from its ideal path with the controller compensating online (`--online`, default or learned
model). Each residual is `check`'s (tracker minus ideal, rms and max), and again with the tracker offset `learn`
found taken off, over the whole run and away from the path's reversals (0.1 s either side); and "both": the offline command with the controller compensating online only the force that
command did not assume (its compensation record's forces, looked up by where along the command the
controller's joints are: not the plant's own re-timing, which a PC beside a controller does not know).
Writes OUT/online_study.json and OUT/online_study.md, and with `--doc` the table between the online-table markers
of that page (docs/online.md; `tests/test_online.py::test_the_study_table_is_what_the_study_gives`, slow, reruns a
row):

    .venv/bin/python experiments/online_study.py OUT [--variants groove-default,...] [--doc docs/online.md]
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

#: Samples this close to a reversal of the path are left out of the "away" rms [s].
REVERSAL_WINDOW_S = 0.1
VARIANTS: dict[str, tuple[list[str], float]] = {
    "groove-default": (["--shape", "groove"], 1.0),
    "groove-stronger": (["--shape", "groove"], 1.3),
    "cone-default": (["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"], 1.0),
    "cone-stronger": (["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"], 1.3),
}


#: Plant knobs every run of the study takes (`--plant-set NAME=VALUE`: the sheet law, say); empty: the defaults.
PLANT_KNOBS: dict[str, float] = {}


def _lab(strength: float, command: Path, out: Path, seed: int, scenario: str = "nominal",
         online: Path | bool | None = False, settings: Any = None) -> Path:
    """Form `command` on the plant (default knobs), the sheet `strength` x the declared one; `online`: False, or
    True / a model file for the online compensator, with `settings` (an `OnlineSettings`; None: the defaults)."""
    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.run import run_dynamic_lab
    from twin.process.description import Process
    from twin.runs.read import read_commanded_csv
    from twin.runs.write import write_run
    from twin.sim.model_file import read_model_file
    from twin.sim.online import OnlineCompensator
    from twin.sim.spec import TwinSpec

    cmd = read_commanded_csv(command)
    model = "table" if "groove" in str(out) else "isf"  # the groove's FE table; any other part: the ISF model
    corrector = None
    if online is not False:
        from twin.analysis.compensation_record import read_record
        from twin.apps.tasks.lab_dynamic import assumed_forces

        assumed = assumed_forces(read_record(command), cmd) if scenario == "compensated" else None
        corrector = OnlineCompensator(read_model_file(online) if isinstance(online, Path) else TwinSpec(),
                                      settings, assumed=assumed)
    run, truth, log = run_dynamic_lab(cmd.t_s, cmd.values, scenario=scenario, knobs=Knobs(PLANT_KNOBS), seed=seed,
                                    process=Process(tensile_strength_mpa=strength * 275.0, force_model=model),
                                    declared=Process(force_model=model),
                                    corrector=corrector)
    write_run(out, run, truth=truth, overwrite=True)
    if log.online is not None:
        from twin.apps.tasks.lab_dynamic import ONLINE_LOG, write_online_log

        write_online_log(out / ONLINE_LOG, log.online)
    return out


def reversal_times(t_s: np.ndarray, p: np.ndarray) -> np.ndarray:
    """When a path turns back on itself: the times where the direction of successive distinct points turns by more
    than 90 deg (a groove's pass ends; a cone's contour has none)."""
    step = np.diff(p, axis=0)
    moving = np.linalg.norm(step, axis=1) > 1e-9
    index, u = np.nonzero(moving)[0], step[moving] / np.linalg.norm(step[moving], axis=1)[:, None]
    back = np.sum(u[1:] * u[:-1], axis=1) < 0.0
    return t_s[index[1:][back]]


def true_tip_residual_mm(run_dir: Path, run: Any, cmd: Any) -> np.ndarray | None:
    """`check`'s residual of the plant's true tip against the command `cmd` [mm], at the tracker's stamps (its
    `truth_tip.csv`, read here on the experiment's side only), or None for a run without one."""
    from twin.analysis.check import check_run
    from twin.runs.read import read_commanded_csv
    from twin.runs.write import TRUTH_TIP

    if not (run_dir / TRUTH_TIP).exists():
        return None
    tip = read_commanded_csv(run_dir / TRUTH_TIP)
    return 1e3 * check_run(replace(run, tracker=tip), cmd.t_s, cmd.values).residual_m


def true_tip_miss_mm(run_dir: Path, ideal: Path) -> np.ndarray:
    """`true_tip_residual_mm` of a dynamic-plant run against the ideal path file `ideal` [mm], shape (m, 3)."""
    from twin.runs.read import read_commanded_csv, read_run

    miss = true_tip_residual_mm(run_dir, read_run(run_dir), read_commanded_csv(ideal))
    if miss is None:
        raise SystemExit(f"{run_dir}: no truth_tip.csv (a run of the dynamic plant writes one)")
    return miss


def rms_mm(miss_mm: np.ndarray) -> float:
    """The rms of a miss's length [mm], shape (m, 3)."""
    return float(np.sqrt(np.mean(np.sum(miss_mm**2, axis=1))))


def _residual(run_dir: Path, ideal: Path, offset_mm: list[float]) -> dict[str, float]:
    from twin.analysis.check import check_run
    from twin.runs.read import read_commanded_csv, read_run

    cmd = read_commanded_csv(ideal)
    run = read_run(run_dir)
    r = 1e3 * check_run(run, cmd.t_s, cmd.values).residual_m
    less = r - np.asarray(offset_mm)
    turns = reversal_times(run.commanded.t_s, run.commanded.values)
    away = np.all(np.abs(run.tracker.t_s[:, None] - turns[None, :]) > REVERSAL_WINDOW_S, axis=1)
    e = true_tip_residual_mm(run_dir, run, cmd)
    true = math.nan if e is None else rms_mm(e)
    return {"rms_mm": float(np.sqrt(np.mean(np.sum(r**2, axis=1)))), "max_mm": float(np.max(np.linalg.norm(r, axis=1))),
            "less_offset_rms_mm": float(np.sqrt(np.mean(np.sum(less**2, axis=1)))),
            "away_rms_mm": float(np.sqrt(np.mean(np.sum(less[away] ** 2, axis=1)))), "true_tip_rms_mm": true}


def variant_study(out: Path, name: str) -> dict[str, Any]:
    """One variant's row (module docstring)."""
    from experiments_cli import cli, cli_json

    path_args, strength = VARIANTS[name]
    out.mkdir(parents=True, exist_ok=True)
    ideal = out / "ideal.csv"
    cli("path", *path_args, "--out", str(ideal))
    model = out / "learned.json"
    learned = cli_json("learn", str(_lab(strength, ideal, out / "nominal1", 1)), "--write-model", str(model))
    offset = learned["robot"]["tracker_offset_mm"]
    row: dict[str, Any] = {"variant": name, "strength": strength,
                           "nominal": _residual(_lab(strength, ideal, out / "nominal3", 3), ideal, offset)}
    for twin, extra, online in (("default", [], True), ("learned", ["--model", str(model)], model)):
        command = out / f"offline_{twin}.csv"
        cli("compensate", "--method", "twin", *extra, "--ideal", str(ideal), "--out", str(command))
        formed = _lab(strength, command, out / f"offline_{twin}", 3, "compensated")
        row[f"offline_{twin}"] = _residual(formed, ideal, offset)
        row[f"online_{twin}"] = _residual(_lab(strength, ideal, out / f"online_{twin}", 3, online=online), ideal,
                                          offset)
        both = _lab(strength, command, out / f"both_{twin}", 3, "compensated", online=online)
        row[f"both_{twin}"] = _residual(both, ideal, offset)
    return row


def figure(variant_dir: Path, out_png: Path) -> None:
    """The online correction against the deflection it answers, over the part: the nominal run's measured
    deviation (tracker minus command) and minus the correction of the online run with the default model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from twin.base.csvio import read_table
    from twin.base.signals import interp_rows
    from twin.runs.read import read_run

    nominal = read_run(variant_dir / "nominal3")
    deviation = 1e3 * (nominal.tracker.values - interp_rows(nominal.tracker.t_s, nominal.commanded.t_s,
                                                             nominal.commanded.values))
    log = read_table(variant_dir / "online_default" / "online.csv", ("t_s", "dx_mm", "dy_mm", "dz_mm"))
    fig, axes = plt.subplots(3, 1, figsize=(9, 6), sharex=True)
    for i, (ax, name) in enumerate(zip(axes, "xyz", strict=True)):
        ax.plot(nominal.tracker.t_s, deviation[:, i], lw=0.8, label="nominal run: measured - commanded")
        ax.plot(log["t_s"], -log[f"d{name}_mm"], lw=0.8, label="online run: minus its correction")
        ax.set_ylabel(f"{name} [mm]")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"{variant_dir.name}: the online correction against the deflection (seed 3)")
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    plt.close(fig)


def table(rows: list[dict[str, Any]]) -> str:
    head = ("| variant | nominal | offline, default | offline, learned | online, default | online, learned | both, "
            "default | both, learned |\n|---|---|---|---|---|---|---|---|\n")
    cells = ("nominal", "offline_default", "offline_learned", "online_default", "online_learned", "both_default",
             "both_learned")
    return head + "".join(
        f"| {r['variant']} | " + " | ".join(f"{r[c]['rms_mm']:.2f} / {r[c]['max_mm']:.2f} ({r[c]['less_offset_rms_mm']:.2f}; "
                                             f"{r[c]['away_rms_mm']:.2f})" for c in cells) + " |\n" for r in rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--doc", type=Path, help="a page whose online-table markers get the table")
    parser.add_argument("--figure", type=Path, help="write the groove's correction-against-deflection figure (PNG)")
    parser.add_argument("--marker", default="online-table", help="the page's markers (default online-table)")
    parser.add_argument("--plant-set", action="append", default=[], metavar="NAME=VALUE",
                        help="a plant knob for every run (repeat), e.g. sheet_law=2")
    args = parser.parse_args()
    PLANT_KNOBS.update({k: float(v) for k, v in (item.split("=", 1) for item in args.plant_set)})
    rows = [variant_study(args.out / name, name) for name in args.variants.split(",")]
    (args.out / "online_study.json").write_text(json.dumps(rows, indent=1))
    md = table(rows)
    (args.out / "online_study.md").write_text(md)
    if args.doc is not None:
        text = args.doc.read_text()
        start = text.index(f"<!-- {args.marker}:begin")
        begin, end = text.index("-->", start) + 3, text.index(f"<!-- {args.marker}:end")
        args.doc.write_text(text[:begin] + "\n" + md + text[end:])
    if args.figure is not None and "groove-default" in args.variants.split(","):
        figure(args.out / "groove-default", args.figure)
    print(md)


if __name__ == "__main__":
    main()
