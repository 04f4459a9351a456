"""Online and offline compensation of parts the learned model never formed, on the dynamic plant, on three robots.

For each robot: one nominal cone (60 x 10 mm, seed 1) is formed and `learn`ed from; then each target part (a wider,
shallower cone 80 x 8 mm, a pyramid 40 x 6 mm, and the thesis's groove) is formed with seed 3 from
its ideal path (nominal), from the twin's offline compensation (`compensate --method twin`, default or learned
model), with the controller compensating online (`lab --online`, default or learned model), and both: the learned
offline command with the learned online correction on top (it corrects only the force the command did not assume).
The learned model never saw these parts (predicted, not fitted). Default knobs (the tracker's registration error
included); each residual is `check`'s as in `experiments/online_study.py` (rms / max [mm], in brackets less the tracker offset
`learn` found, and the plant's true tip's rms: its `truth_tip.csv`, read on the experiment's side only). Writes
OUT/online_other_part.json, OUT/online_other_part.md and with `--doc` the table between the online-other-part
markers of that page (docs/online.md; `tests/test_online_interface.py` reads it):

    .venv/bin/python experiments/online_other_part.py OUT [--robots tx200,kr210,irb6640] [--doc docs/online.md]
        [--plant-set sheet_law=2 --marker online-other-part-law2] [--merge OUT1/online_other_part.json ...]

`--plant-set NAME=VALUE` (repeatable) adds a plant knob to every run (the second sheet law, say); `--marker` names
the page's markers the table goes between; `--merge` joins the rows of runs made a robot per process (`--robots`);
`--tracker-errors` (`--tracker-late`) learns with `learn --tracker-errors` (`learn --tracker-late`).

Every online run may correct up to `ONLINE_LIMIT_MM` (`--max-correction-mm`; the default is less): the IRB 6640's
arm bends on the groove as far as the default limit, where its online correction sat through the deepest passes, and
that was the limit's miss, not the compensator's (CHANGELOG 0.16.0). A run whose correction still sits at the limit
ends the experiment, naming it. Its correction may move `ONLINE_RATE_MM_S` (`--max-rate-mm-s`; the default is less):
at a groove's reversal the sheet's friction turns, and the correction with it, by a millimetre at once.

The IRB 6640 rows were added after the online compensator's side-force share (`OnlineSettings.side_share`) was
chosen on the TX200 and KR 210 cells: they are its held-out robot.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from experiments_cli import add_tracker_options, cli, cli_json, tracker_options, write_between_markers
from online_study import _residual, true_tip_miss_mm

LEARN_FROM = ["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"]
TARGETS = {"cone 80 x 8": ["--shape", "cone", "--top-width-mm", "80", "--depth-mm", "8"],
           "pyramid": ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "6"],
           "groove": ["--shape", "groove"]}
#: The parts each robot forms (the groove: the thesis's path, in each robot's own cell).
ROBOT_TARGETS = {robot: ("cone 80 x 8", "pyramid", "groove") for robot in ("tx200", "kr210", "irb6640")}
#: The online correction's size limit in these runs [mm]: twice the largest deflection of these cells' parts.
ONLINE_LIMIT_MM = 10.0
#: The online correction's rate limit in these runs [mm/s]: the sheet's friction turning at a groove's reversal steps
#: the correction by up to ~1.1 mm (the IRB 6640's deepest passes), taken in ~10 ms at this rate (the default's 20
#: mm/s spreads it over ~55 ms, while the tool lags the turned command; CHANGELOG).
ONLINE_RATE_MM_S = 100.0
COLUMNS = ("nominal", "offline_default", "offline_learned", "online_default", "online_learned", "both_learned")


def lab_run(robot: str, command: Path, out: Path, seed: int, scenario: str = "nominal", *extra: str,
            plant_set: tuple[str, ...] = ()) -> Path:
    """Form `command` on the dynamic plant (`lab --plant dynamic`) into `out`; an online run (`--online` in
    `extra`) may correct up to `ONLINE_LIMIT_MM`, and one whose correction sat at it ends the experiment."""
    online = "--online" in extra
    report = cli_json("lab", "--plant", "dynamic", "--scenario", scenario, "--commanded", str(command), "--seed",
                      str(seed), "--robot", robot, "--out", str(out), *extra,
                      *(("--max-correction-mm", f"{ONLINE_LIMIT_MM:g}", "--max-rate-mm-s", f"{ONLINE_RATE_MM_S:g}")
                        if online else ()),
                      *(a for item in plant_set for a in ("--set", item)))
    if online and report["online"]["at_limit_share"] > 0.0:
        raise SystemExit(f"{out}: the online correction sat at its {ONLINE_LIMIT_MM:g} mm limit in "
                         f"{100.0 * report['online']['at_limit_share']:.1f} % of the cycles (the limit's miss)")
    return out


def learn_cone(out: Path, robot: str, plant_set: tuple[str, ...] = (),
               learn_args: tuple[str, ...] = ()) -> tuple[Path, dict[str, Any]]:
    """Form the nominal cone `LEARN_FROM` (seed 1) in `out` and `learn` from it (with `learn_args`, `learn`'s own
    options): (the model file, `learn`'s document)."""
    out.mkdir(parents=True, exist_ok=True)
    learn_path, model = out / "learn_cone.csv", out / "learned.json"
    cli("path", *LEARN_FROM, "--robot", robot, "--out", str(learn_path))
    learned = cli_json("learn", str(lab_run(robot, learn_path, out / "learn_nominal1", 1, plant_set=plant_set)),
                       "--write-model", str(model), *learn_args)
    return model, learned


def target_ideal(out: Path, robot: str, part: str) -> Path:
    """The part's ideal path (`TARGETS[part]`, in `robot`'s cell), written as OUT/<part without spaces>.csv."""
    ideal = out / f"{part.replace(' ', '')}.csv"
    cli("path", *TARGETS[part], "--robot", robot, "--out", str(ideal))
    return ideal


def offline_command(robot: str, ideal: Path, twin: str, *model_args: str) -> Path:
    """The `twin` twin's offline command for `ideal` (`compensate --method twin`; `model_args`: its `--model FILE`,
    none for the default twin), written beside it as <ideal>_offline_<twin>.csv; a refusal (`compensate`'s exit 2:
    the twin cannot hold the path) ends in `SystemExit`, naming it."""
    command = ideal.with_name(f"{ideal.stem}_offline_{twin}.csv")
    cli("compensate", "--method", "twin", "--robot", robot, *model_args, "--ideal", str(ideal), "--out", str(command))
    return command


class LearnedPart(NamedTuple):
    """A part of `ROBOT_TARGETS` with what a model learned from the cone gives it (`learned_parts`)."""

    part: str
    ideal: Path  # its ideal path (`target_ideal`)
    command: Path  # the learned twin's offline command for it (`offline_command`)
    model: Path  # the model file learned from the nominal cone (`learn_cone`)


def learned_parts(out: Path, robot: str, plant_set: tuple[str, ...] = ()) -> Iterator[LearnedPart]:
    """Learn the nominal cone in `out` (`learn_cone`, on the plant with knobs `plant_set`), then each of the robot's
    parts with its learned offline command: the loop of the studies that form those parts online again
    (`online_timestep.py`, `online_seeds.py`)."""
    model, _ = learn_cone(out, robot, plant_set)
    for part in ROBOT_TARGETS[robot]:
        ideal = target_ideal(out, robot, part)
        yield LearnedPart(part, ideal, offline_command(robot, ideal, "learned", "--model", str(model)), model)


def learned_online_miss(robot: str, model: Path, formed: Path, ideal: Path, out: Path, seed: int = 3,
                        scenario: str = "nominal", plant_set: tuple[str, ...] = ()) -> np.ndarray:
    """Form `formed` on the plant with the controller compensating online with the learned `model` (`lab_run`, into
    `out`) and return its true tip's miss of `ideal` [mm], shape (m, 3)."""
    run = lab_run(robot, formed, out, seed, scenario, "--online", "--model", str(model), plant_set=plant_set)
    return true_tip_miss_mm(run, ideal)


def robot_study(out: Path, robot: str, plant_set: tuple[str, ...] = (),
                learn_args: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """One robot's rows (module docstring); `plant_set`: plant knobs NAME=VALUE added to every run's; `learn_args`:
    `learn`'s options."""
    model, learned = learn_cone(out, robot, plant_set, learn_args)
    offset = learned["robot"]["tracker_offset_mm"]
    rows = []
    for part in ROBOT_TARGETS[robot]:
        ideal = target_ideal(out, robot, part)
        tag = ideal.stem
        row: dict[str, Any] = {"robot": robot, "part": part, "nominal": _residual(
            lab_run(robot, ideal, out / f"{tag}_nominal3", 3, plant_set=plant_set), ideal, offset)}
        for twin, extra in (("default", []), ("learned", ["--model", str(model)])):
            try:
                command = offline_command(robot, ideal, twin, *extra)
            except SystemExit as refused:  # the twin cannot hold the path: `compensate` says so (exit 2)
                print(refused, flush=True)
                row[f"offline_{twin}"] = None
            else:
                row[f"offline_{twin}"] = _residual(lab_run(robot, command, out / f"{tag}_offline_{twin}", 3,
                                                        "compensated", plant_set=plant_set), ideal, offset)
            row[f"online_{twin}"] = _residual(lab_run(robot, ideal, out / f"{tag}_online_{twin}", 3, "nominal",
                                                   "--online", *extra, plant_set=plant_set), ideal, offset)
        row["both_learned"] = None if row["offline_learned"] is None else _residual(
            lab_run(robot, out / f"{tag}_offline_learned.csv", out / f"{tag}_both_learned", 3, "compensated", "--online",
                 "--model", str(model), plant_set=plant_set), ideal, offset)
        rows.append(row)
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table: rms / max (rms less the tracker offset; the true tip's rms, to a micrometre: the
    headline) [mm]; "refused" where the twin's compensation diverged (`compensate` exits 2 naming it)."""
    lines = ["| robot | part (never formed) | nominal | offline, default | offline, learned | online, default | "
             "online, learned | both, learned |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cells = ["refused" if r[c] is None else f"{r[c]['rms_mm']:.2f} / {r[c]['max_mm']:.2f} "
                 f"({r[c]['less_offset_rms_mm']:.2f}; true {r[c]['true_tip_rms_mm']:.3f})" for c in COLUMNS]
        lines.append(f"| {r['robot']} | {r['part']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def merged_rows(paths: list[Path]) -> list[dict[str, Any]]:
    """The rows of runs made a robot per process (their JSON files), each robot's parts in their order."""
    rows = [row for path in paths for row in json.loads(path.read_text())]
    return sorted(rows, key=lambda r: list(ROBOT_TARGETS).index(r["robot"]))  # stable


def per_robot_main(description: str, name: str,
                   robot_rows: Callable[[Path, str, tuple[str, ...]], list[dict[str, Any]]],
                   table: Callable[[list[dict[str, Any]]], str]) -> None:
    """The command line of a study formed robot by robot (`online_timestep.py`, `online_seeds.py`): OUT, `--robots`
    (a robot per process, then `--merge` their OUT/NAME.json files), `--plant-set NAME=VALUE` (a plant knob added to
    every run, repeatable), `--doc` (the table between the page's `--marker` markers, by default NAME with `_` read
    as `-`); writes OUT/NAME.json and OUT/NAME.md."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("out", type=Path)
    parser.add_argument("--robots", default=",".join(ROBOT_TARGETS))
    parser.add_argument("--merge", type=Path, nargs="*", default=None,
                        help=f"instead of running, join these robots' {name}.json files")
    parser.add_argument("--doc", type=Path, help="write the table into this page between its markers")
    parser.add_argument("--plant-set", action="append", default=[], metavar="NAME=VALUE",
                        help="a plant knob added to every run, repeatable")
    parser.add_argument("--marker", default=name.replace("_", "-"), help="the page's markers (default: %(default)s)")
    args = parser.parse_args()
    if args.merge is not None:
        rows = merged_rows(args.merge)
    else:
        rows = [row for robot in args.robots.split(",")
                for row in robot_rows(args.out / robot, robot, tuple(args.plant_set))]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / f"{name}.json").write_text(json.dumps(rows, indent=1))
    (args.out / f"{name}.md").write_text(table(rows))
    print(table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, args.marker, table(rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--robots", default=",".join(ROBOT_TARGETS))
    parser.add_argument("--doc", type=Path, help="write the table into this page between its markers")
    parser.add_argument("--plant-set", action="append", default=[], metavar="NAME=VALUE",
                        help="a plant knob added to every run, repeatable")
    parser.add_argument("--marker", default="online-other-part", help="the page's markers (default: %(default)s)")
    parser.add_argument("--merge", type=Path, nargs="*", default=None,
                        help="instead of running, join these runs' online_other_part.json files (a robot per process)")
    add_tracker_options(parser)
    args = parser.parse_args()
    plant_set = tuple(args.plant_set)
    learn_args = tracker_options(args)
    if args.merge is not None:
        rows = merged_rows(args.merge)
    else:
        rows = [row for robot in args.robots.split(",") for row in robot_study(args.out / robot, robot, plant_set,
                                                                                 learn_args)]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "online_other_part.json").write_text(json.dumps(rows, indent=1))
    (args.out / "online_other_part.md").write_text(table(rows))
    print(table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, args.marker, table(rows))


if __name__ == "__main__":
    main()
