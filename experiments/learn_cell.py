"""Learn a cell the twin did not build (the dynamic plant), then compensate the next part with what it learned.

For each plant variant: nominal runs with seeds 1 (learned from) and 2 (held out); the untaught twin's and the
learned twin's replay gaps on seed 2; each twin's compensation (`compensate --method twin`) formed on the plant
with seed 3, and its residual (`check`). The learned twin learns from seed 1's run only, through `tx200-twin
learn`; nothing here reads the plant's truth, knobs or code on the twin's side. Writes OUT/learn_cell.json and
OUT/learn_cell.md (the table in docs/learning.md):

    .venv/bin/python experiments/learn_cell.py OUT [--variants groove-neutral,...] [--reuse] [--tracker-errors | --tracker-late]

`--reuse` keeps the runs an earlier call left under OUT that do not depend on what `learn` gives (the nominal runs
and the untaught twin's compensated ones: a run is its seed's) and forms the learned twin's again, for a change of
the learner alone.
"""

from __future__ import annotations

import argparse
import json
import shutil
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from experiments_cli import (
    add_tracker_options,
    cli,
    cli_json,
    tracker_options,
    write_between_markers,
    write_study,
)

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.run import run_dynamic_lab
from twin.process.description import Process
from twin.runs.read import read_commanded_csv
from twin.runs.write import write_run

#: name -> (robot, path arguments, plant knob arguments, R_m factor of the plant's sheet over the declared one)
VARIANTS: dict[str, tuple[str, list[str], list[str], float]] = {
    "groove-neutral": ("tx200", ["--shape", "groove"], ["--neutral"], 1.0),
    "groove-default": ("tx200", ["--shape", "groove"], [], 1.0),
    "groove-stronger": ("tx200", ["--shape", "groove"], ["--neutral"], 1.3),
    "groove-backlash": ("tx200", ["--shape", "groove"], ["--neutral", "--set", "backlash_j3_mrad=0.3"], 1.0),
    "cone-kr210": ("kr210", ["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"], ["--neutral"], 1.0),
    "cone-tx200": ("tx200", ["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"], ["--neutral"], 1.0),
    "cone-irb6640": ("irb6640", ["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"], ["--neutral"], 1.0),
}
#: Cross-part: learned from the cone variant's nominal run, compensating these parts (prefix -> path arguments).
OTHER_PARTS = {"pyramid_": ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "6"],
               "cone80_": ["--shape", "cone", "--top-width-mm", "80", "--depth-mm", "8"]}
#: Their names in the table.
OTHER_NAMES = {"pyramid_": "pyramid", "cone80_": "cone 80 x 8"}
#: The cone variants' robots in the order of the studies that read this one's output, and whether the learner was
#: built on each (`offline_limits.py`, `learn_again.py`).
CONE_CELLS = (("tx200", "development"), ("kr210", "held out"), ("irb6640", "held out"))


def cone_cells_parser(description: str) -> argparse.ArgumentParser:
    """The command line of a study of this one's cone variants: OUT, `--law1 L1`, `--law2 L2`, `--doc PAGE`."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("out", type=Path)
    parser.add_argument("--law1", type=Path, required=True, help="learn_cell.py's output on the plant's law 1")
    parser.add_argument("--law2", type=Path, help="learn_cell.py's output with --plant-set sheet_law=2")
    parser.add_argument("--doc", type=Path, help="write the table into this page between its markers")
    return parser


def cone_cells(law1: Path, law2: Path | None) -> Iterator[tuple[str, str, Path, tuple[str, ...]]]:
    """The cone variants of this study's outputs on the plant's two laws (`law2` None: the first alone), in the
    order of `CONE_CELLS`: (the cell's name in a table, its robot, the variant's folder, the plant knobs its runs
    took)."""
    for law, source in ((1, law1), (2, law2)):
        if source is not None:
            for robot, role in CONE_CELLS:
                yield (f"{robot}, sheet law {law} ({role})", robot, source / f"cone-{robot}",
                       () if law == 1 else ("sheet_law=2",))


def cone_study(args: argparse.Namespace, stem: str, marker: str,
               rows_of: Callable[[Path, str, Path, tuple[str, ...]], Iterable[dict[str, Any]]],
               table: Callable[[list[dict[str, Any]]], str]) -> None:
    """A study of these cone variants, `args` its command line (`cone_cells_parser`'s): each cell's rows from
    `rows_of(work, robot, folder, plant_set)` (work: OUT/ROBOT_lawN, for the runs it forms), each printed as its
    table line as it comes, then OUT/STEM.json and .md and the page's `marker` table (`write_study`)."""
    rows: list[dict[str, Any]] = []
    for cell, robot, folder, plant_set in cone_cells(args.law1, args.law2):
        for row in rows_of(args.out / f"{robot}_law{2 if plant_set else 1}", robot, folder, plant_set):
            rows.append({"cell": cell, **row})
            print(table(rows[-1:]).splitlines()[-1], flush=True)
    write_study(args.out, stem, rows, table(rows), args.doc, marker)


def _lab(robot: str, knobs: list[str], strength: float, command: Path, out: Path, seed: int,
         scenario: str = "nominal", reuse: bool = False) -> Path:
    """Form `command` on the plant; a sheet stronger than declared goes through the API (the CLI records the
    process it forms, so the twin would read it). `reuse`: a run already at `out` is kept."""
    if reuse and (out / "truth.json").is_file():
        return out
    if out.exists():
        shutil.rmtree(out)
    if strength == 1.0:
        cli("lab", "--plant", "dynamic", *knobs, "--scenario", scenario, "--commanded", str(command), "--seed",
             str(seed), "--robot", robot, "--out", str(out))
        return out
    cmd = read_commanded_csv(command)
    values = dict(item.split("=") for item in knobs[knobs.index("--set") + 1::2]) if "--set" in knobs else {}
    plant_knobs = Knobs({k: float(v) for k, v in values.items()}, neutral="--neutral" in knobs)
    run, truth, _ = run_dynamic_lab(cmd.t_s, cmd.values, scenario=scenario, knobs=plant_knobs, seed=seed,
                                    process=Process(tensile_strength_mpa=strength * 275.0), declared=Process(),
                                    robot=robot)
    write_run(out, run, truth=truth)
    return out


def variant_study(out: Path, name: str, plant_set: tuple[str, ...] = (), reuse: bool = False,
                  learn_options: tuple[str, ...] = ()) -> dict[str, Any]:
    """One variant's row (module docstring); `plant_set`: plant knobs NAME=VALUE added to every run's (the sheet
    law, say); `reuse`: the runs that do not depend on the learned model kept where an earlier call left them;
    `learn_options`: `learn`'s (`--tracker-errors`)."""
    robot, path_args, knobs, strength = VARIANTS[name]
    knobs = [*knobs, *(arg for item in plant_set for arg in ("--set", item))]
    out.mkdir(parents=True, exist_ok=True)
    ideal = out / "ideal.csv"
    cli("path", *path_args, "--robot", robot, "--out", str(ideal))
    runs = {seed: _lab(robot, knobs, strength, ideal, out / f"nominal{seed}", seed, reuse=reuse) for seed in (1, 2)}
    model = out / "learned.json"
    model.unlink(missing_ok=True)
    learned = cli_json("learn", str(runs[1]), "--write-model", str(model), *learn_options)
    row: dict[str, Any] = {"variant": name, "robot": robot,
                           "nominal": cli_json("check", str(runs[1]), "--ideal", str(ideal)),
                           "replay_untaught": cli_json("replay", str(runs[2]), "--forces", "measured"),
                           "replay_learned": cli_json("replay", str(runs[2]), "--model", str(model), "--forces",
                                                   "measured"),
                           "learn": learned}
    targets = [("", ideal, path_args)]
    if name.startswith("cone-"):
        for prefix, part in OTHER_PARTS.items():
            target = out / f"{prefix}path.csv"
            cli("path", *part, "--robot", robot, "--out", str(target))
            targets.append((prefix, target, part))
            nominal = _lab(robot, knobs, strength, target, out / f"{prefix}nominal", 3, reuse=reuse)
            row[f"{prefix}nominal"] = cli_json("check", str(nominal), "--ideal", str(target))
            row[f"{prefix}replay_untaught"] = cli_json("replay", str(nominal), "--forces", "measured")
            row[f"{prefix}replay_learned"] = cli_json("replay", str(nominal), "--model", str(model), "--forces",
                                                      "measured")
    for prefix, target, _ in targets:
        for twin, extra in (("untaught", ["--robot", robot]), ("learned", ["--model", str(model)])):
            command = out / f"{prefix}{twin}.csv"
            for old in (command, command.with_suffix(".compensation.json")):
                old.unlink(missing_ok=True)
            cli("compensate", "--method", "twin", *extra, "--ideal", str(target), "--out", str(command))
            formed = _lab(robot, knobs, strength, command, out / f"{prefix}{twin}_formed", 3, "compensated",
                          reuse and twin == "untaught")
            row[f"{prefix}{twin}"] = cli_json("check", str(formed), "--ideal", str(target))
            row[f"{prefix}{twin}"]["less_tracker_offset_mm"] = _less_offset(
                formed, target, learned["robot"]["tracker_offset_mm"])
            row[f"{prefix}{twin}"]["away_from_stops_mm"] = _away_from_stops(formed, target)
    return row


def _away_from_stops(run_dir: Path, ideal: Path) -> float:
    """RMS residual [mm] over the tracker samples more than 0.3 s from any stop of the controller
    (`twin.analysis.learn.split.near_stops`): where a quasi-static compensation can reach."""
    import numpy as np

    from twin.analysis.check import check_run
    from twin.analysis.learn.split import near_stops
    from twin.runs.read import read_run

    run, cmd = read_run(run_dir), read_commanded_csv(ideal)
    residual = check_run(run, cmd.t_s, cmd.values).residual_m
    far = ~near_stops(run, run.tracker.t_s)
    return 1e3 * float(np.sqrt(np.mean(np.sum(residual[far] ** 2, axis=1))))


def _less_offset(run_dir: Path, ideal: Path, offset_mm: list[float]) -> float:
    """RMS residual [mm] once the tracker offset `learn` found is taken off the tracker's reading."""
    import numpy as np

    from twin.analysis.check import check_run
    from twin.runs.read import read_run

    cmd = read_commanded_csv(ideal)
    residual = check_run(read_run(run_dir), cmd.t_s, cmd.values).residual_m - 1e-3 * np.asarray(offset_mm)
    return 1e3 * float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of the study."""
    lines = ["| variant | nominal residual | untaught twin: replay gap; compensated | learned twin: replay gap "
             "(predicted); compensated | the same less the tracker offset `learn` found |", "|---|---|---|---|---|"]
    def res(r: dict[str, Any], key: str) -> str:
        return f"{r[key]['residual_rms_mm']:.3f} mm (max {r[key]['residual_max_mm']:.2f})"

    def gap(r: dict[str, Any], key: str) -> str:
        return f"{r[key]['position_rms_mm']:.3f} mm / {r[key]['force_rms_n']:.0f} N"

    for r in rows:
        lines.append(f"| {r['variant']} | {res(r, 'nominal')} | {gap(r, 'replay_untaught')}; {res(r, 'untaught')} | "
                     f"{gap(r, 'replay_learned')}; {res(r, 'learned')} | {r['learned']['less_tracker_offset_mm']:.3f} mm |")
        for prefix, part in OTHER_NAMES.items():
            if f"{prefix}nominal" in r:
                lines.append(f"| {r['variant']} -> {part} (never formed) | {res(r, prefix + 'nominal')} | "
                             f"{gap(r, prefix + 'replay_untaught')}; {res(r, prefix + 'untaught')} | "
                             f"{gap(r, prefix + 'replay_learned')}; {res(r, prefix + 'learned')} | "
                             f"{r[prefix + 'learned']['less_tracker_offset_mm']:.3f} mm |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--doc", type=Path, help="write the table into this page between its learn-table markers")
    parser.add_argument("--marker", default="learn-table", help="the page's markers (default learn-table)")
    parser.add_argument("--plant-set", action="append", default=[], metavar="NAME=VALUE",
                        help="a plant knob for every run (repeat), e.g. sheet_law=2")
    parser.add_argument("--reuse", action="store_true", help="keep the runs an earlier call left that do not depend on "
                        "the learned model")
    add_tracker_options(parser)
    args = parser.parse_args()
    rows = []
    for name in args.variants.split(","):
        rows.append(variant_study(args.out / name, name, tuple(args.plant_set), args.reuse,
                                  tracker_options(args)))
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    (args.out / "learn_cell.json").write_text(json.dumps(rows, indent=1, default=str))
    (args.out / "learn_cell.md").write_text(table(rows))
    print(table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, args.marker, table(rows))


if __name__ == "__main__":
    main()
