"""The formed part against its design, on both plants, with the plant's sheet other than the twin's: nominal,
path-compensated, part-compensated, and one and two learning iterations from the scans.

The plant's sheet is 20 % stronger than declared and springs back otherwise: the quasi-static lab hides
`force_scale=1.2` and `sheet_springback=0.05` (5 % more of the depth lost on unclamping); the dynamic plant forms
its own sheet (`twin.lab.dynamic.sheet`: its own force model and springback) with R_m 1.2 x 275 MPa while its runs
record the declared process (the twin is told nothing). Each number is the scan (`part_scan.csv`) against the design, normal to it,
rms over the formed part and its rim (`twin.analysis.part_compensation.part_stats`). Both compensations are made
twice: with the declared sheet, and with the sheet's forces identified from the nominal part's F/T stream
(`identify --forces RUN --write-model`; the springback stays the declared one: forces do not show it), and
with the springback then identified from the nominal part's scan too (`identify --springback RUN --design DESIGN`:
two global constants of the twin's springback model, fitted, not learned point by point; path compensation does
not use the springback, so its command repeats the identified-forces one). Figures
and rerun recordings in OUT: `twin_stages.png|.rrd` (the twin's predicted part at each part-compensation iteration) and
`<plant>_stages.png|.rrd` (the scan of each formed part: nominal, path-, part-compensated, each learning iteration).

Run: `.venv/bin/python experiments/part_to_design.py OUT [--shape cone|pyramid] [--width-mm 80 --depth-mm 20]
[--plants quasi-static,dynamic] [--learn 2] [--learn-at twin|formed|tip]`. Prints a JSON summary.
"""

from __future__ import annotations

import argparse
import json
import sys
from contextlib import redirect_stdout
from io import StringIO
from pathlib import Path
from typing import Any

from twin.analysis.part_compensation import PartStage, part_stats
from twin.analysis.surface_check import DesignIndex, RegionDeviation, read_target_mesh, region_deviation
from twin.cli import main as cli
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.run import run_dynamic_lab
from twin.process.description import Process
from twin.runs.read import read_commanded_csv, read_run
from twin.runs.write import write_run
from twin.viz.part_recording import record_part
from twin.viz.surface_figures import plot_part_stages

HIDDEN_QS = ["--effect", "force_scale=1.2", "--effect", "sheet_springback=0.05"]
PLANT_PROCESS = Process(tensile_strength_mpa=1.2 * 275.0, force_model="isf")


def _cli(*argv: str) -> None:
    with redirect_stdout(StringIO()):
        code = cli(list(argv))
    if code != 0:
        raise SystemExit(f"`tx200-twin {' '.join(argv)}` exited with {code}")


def _lab(plant: str, command: Path, out: Path, seed: int) -> Path:
    """Form `command` on `plant` with the plant's own sheet; the run records the declared one."""
    if plant == "quasi-static":
        _cli("lab", "--scenario", "nominal", "--commanded", str(command), *HIDDEN_QS, "--seed", str(seed),
             "--force-model", "isf", "--out", str(out))
        return out
    cmd = read_commanded_csv(command)
    run, truth, _ = run_dynamic_lab(cmd.t_s, cmd.values, scenario="nominal", knobs=Knobs(neutral=True), seed=seed,
                                    process=PLANT_PROCESS, declared=Process())
    write_run(out, run, truth=truth)
    return out


def _scan(run: Path, design: DesignIndex) -> RegionDeviation:
    """The run's part scan against the design."""
    scan = read_run(run).part_scan
    if scan is None:
        raise SystemExit(f"{run}: the run has no part_scan.csv")
    return region_deviation(scan, design)


def _identified_springback(out: Path, plant: str, ideal: Path, design: Path, forces: Path,
                           scans: dict[str, RegionDeviation], index: DesignIndex) -> dict[str, Any]:
    """The springback identified from the nominal part's scan (`identify --springback`, on top of the identified
    forces), then both compensations with that model: model identification, two global constants, no learning."""
    model, report = out / f"{plant}_identified_springback.json", out / f"{plant}_identified_springback_fit.json"
    _cli("identify", "--springback", str(out / f"{plant}_nominal"), "--design", str(design), "--model", str(forces),
         "--write-model", str(model), "--json", str(report))
    for name, extra in (("path-compensated, identified forces and springback", []),
                        ("part-compensated, identified forces and springback", ["--target-stl", str(design)])):
        stem = name.split(",")[0]
        command = out / f"{plant}_cmd_{stem}_identified_springback.csv"
        _cli("compensate", "--method", "twin", "--ideal", str(ideal), "--model", str(model), *extra,
             "--out", str(command))
        scans[name] = _scan(_lab(plant, command, out / f"{plant}_{stem}_identified_springback", seed=1), index)
    fit = json.loads(report.read_text())
    return {"springback_fit": fit["springback_fit"], "force_fit": fit["force_fit_used"],
            "scan_rms_mm": [round(fit["scan_rms_before_mm"], 4), round(fit["scan_rms_after_mm"], 4)]}


def part_study(out: Path, path_args: list[str], plants: tuple[str, ...] = ("quasi-static", "dynamic"),
               learn: int = 2, learn_at: str = "twin") -> dict[str, Any]:
    """The study for one part (`path_args`: the `tx200-twin path` options that make it) in `out`; `learn_at`:
    `compensate --learn-at`."""
    out.mkdir(parents=True, exist_ok=True)
    ideal, design = out / "ideal.csv", out / "design.stl"
    _cli("path", *path_args, "--out", str(ideal), "--no-reach-check", "--design-stl", str(design))
    _cli("compensate", "--method", "twin", "--ideal", str(ideal), "--force-model", "isf", "--out",
         str(out / "cmd_path.csv"))
    _cli("compensate", "--method", "twin", "--ideal", str(ideal), "--force-model", "isf", "--target-stl", str(design),
         "--out", str(out / "cmd_part.csv"), "--json", str(out / "part.json"), "--figure", str(out / "twin_stages.png"),
         "--rrd", str(out / "twin_stages.rrd"))
    mesh = read_target_mesh(design)
    summary: dict[str, Any] = {"path": path_args, "twin_predicted_rms_mm": [
        round(e["part"], 4) for e in json.loads((out / "part.json").read_text())["predicted_surface_rms_mm_per_iteration"]]}
    index = DesignIndex(mesh)
    for plant in plants:
        scans: dict[str, RegionDeviation] = {}
        for name, command in (("nominal", ideal), ("path-compensated", out / "cmd_path.csv"),
                              ("part-compensated", out / "cmd_part.csv")):
            run = _lab(plant, command, out / f"{plant}_{name}", seed=1)
            scans[name] = _scan(run, index)
        # The sheet's forces identified from the nominal part's F/T stream, then both compensations again.
        model = out / f"{plant}_identified_forces.json"
        _cli("identify", "--forces", str(out / f"{plant}_nominal"), "--write-model", str(model))
        for name, extra in (("path-compensated, identified forces", []),
                            ("part-compensated, identified forces", ["--target-stl", str(design)])):
            command = out / f"{plant}_cmd_{name.split(',')[0]}_identified.csv"
            _cli("compensate", "--method", "twin", "--ideal", str(ideal), "--model", str(model), *extra,
                 "--out", str(command))
            scans[name] = _scan(_lab(plant, command, out / f"{plant}_{name.split(',')[0]}_identified", seed=1), index)
        # Learning starts from the best the twin alone could do: the part compensated with the identified model.
        last, identified = out / f"{plant}_part-compensated_identified_springback", out / f"{plant}_identified_springback.json"
        try:
            summary.setdefault("identified", {})[plant] = _identified_springback(out, plant, ideal, design, model,
                                                                                  scans, index)
        except SystemExit as refused:  # identify refuses a scan that does not fit the design: say so, go on
            summary["identified"][plant] = {"springback_refused": str(refused)}
            last, identified = out / f"{plant}_part-compensated_identified", model
        for k in range(1, learn + 1):
            nxt = out / f"{plant}_cmd_learn{k}.csv"
            _cli("compensate", "--method", "twin", "--ideal", str(ideal), "--model", str(identified), "--target-stl",
                 str(design), "--learn-from", str(last), "--learn-at", learn_at, "--out", str(nxt))
            last = _lab(plant, nxt, out / f"{plant}_learn{k}", seed=1 + k)
            scans[f"learn {k}"] = _scan(last, index)
        stages = [PartStage(f"scan: {name}", "scanned", deviation) for name, deviation in scans.items()]
        plot_part_stages(out / f"{plant}_stages.png", stages, title=f"{plant} plant, its sheet not the twin's")
        record_part(out / f"{plant}_stages.rrd", mesh, stages)
        rows = {name: part_stats(deviation) for name, deviation in scans.items()}
        summary[plant] = {name: {"rms_mm": {r: round(v["rms_mm"], 4) for r, v in e.items()},
                                 "mean_mm": {r: round(v["mean_mm"], 4) for r, v in e.items()}}
                          for name, e in rows.items()}
    return summary


def stage_table(summary: dict[str, Any]) -> str:
    """The study's part rms [mm] per stage (rows) and plant (columns), as a markdown table."""
    plants = [p for p in ("quasi-static", "dynamic") if p in summary]
    lines = ["| stage | " + " | ".join(f"{p} plant, part rms [mm]" for p in plants) + " |",
             "|---|" + "---|" * len(plants)]
    for stage in summary[plants[0]]:
        lines.append(f"| {stage} | " + " | ".join(f"{summary[p][stage]['rms_mm']['part']:.3f}" if stage in summary[p]
                                                  else "refused" for p in plants) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--shape", default="cone")
    parser.add_argument("--gcode", type=Path, help="a G-code part instead of --shape")
    parser.add_argument("--width-mm", type=float, default=80.0)
    parser.add_argument("--depth-mm", type=float, default=20.0)
    parser.add_argument("--plants", default="quasi-static,dynamic")
    parser.add_argument("--learn", type=int, default=2)
    parser.add_argument("--learn-at", choices=("twin", "formed", "tip"), default="twin")
    args = parser.parse_args()
    path_args = (["--gcode", str(args.gcode)] if args.gcode is not None else
                 ["--shape", args.shape, "--top-width-mm", f"{args.width_mm:g}", "--depth-mm", f"{args.depth_mm:g}"])
    summary = part_study(args.out, path_args, tuple(args.plants.split(",")), args.learn, args.learn_at)
    json.dump(summary, sys.stdout, indent=1)
    print()
    print(stage_table(summary), file=sys.stderr)


if __name__ == "__main__":
    main()
