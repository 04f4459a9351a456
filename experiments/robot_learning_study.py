"""The learned robot against the plant's own joint stiffness: does `learn`'s K_q land on it within its stated spread?

For each cell (robot, part; the dynamic plant with neutral knobs, its sheet law 1), one nominal run (seed 1) is
formed and learned from with `tx200-twin learn` (the twin side reads the run only); here, on the experiment's side,
each observable joint's learned K_q and its stated standard deviation (the larger of the posterior's and a
moving-block bootstrap's, `twin.analysis.learn.robot`) are set against the plant's K_q from the run's
`truth.json`. Writes OUT/robot_learning.json, OUT/robot_learning.md and with `--doc` the table between the
robot-learning markers of that page (docs/learning.md; `tests/test_learn_study.py` reads it):

    .venv/bin/python experiments/robot_learning_study.py OUT [--cells tx200:groove,...] [--doc docs/learning.md]
        [--plant-set link_friction_scale=0 --marker robot-learning-no-friction] [--reuse]

A cell of several runs names its parts with `+` (`kr210:cone+pyramid`: the cone formed with seed 1, the pyramid with
seed 2, both learned from in one `learn`), as `--cells` of `TWO_RUNS` with `--marker robot-learning-two-runs`.

`--reuse` learns again from the runs an earlier call left under OUT (a run is its seed's: formed again, it is the
same run), for a change of the learner alone.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from experiments_cli import cli, cli_json, write_between_markers

#: robot:part
CELLS = ("tx200:groove", "tx200:cone", "kr210:cone", "irb6640:cone")
#: The same robots, each learned from a cone and a pyramid (the groove's TX200 from the groove and the cone).
TWO_RUNS = ("tx200:groove+cone", "tx200:cone+pyramid", "kr210:cone+pyramid", "irb6640:cone+pyramid")
PARTS = {"groove": ["--shape", "groove"], "cone": ["--shape", "cone", "--top-width-mm", "60", "--depth-mm", "10"],
         "pyramid": ["--shape", "pyramid", "--top-width-mm", "40", "--depth-mm", "6"]}


def cell_study(out: Path, cell: str, plant_set: tuple[str, ...] = (), reuse: bool = False) -> dict[str, Any]:
    """One cell's joints (module docstring); `plant_set`: plant knobs NAME=VALUE for the run (a diagnosis: which of
    the plant's effects the learner's model does not hold); `reuse`: the run an earlier call left, where it is."""
    robot, parts = cell.split(":")
    out.mkdir(parents=True, exist_ok=True)
    runs = []
    for seed, part in enumerate(parts.split("+"), start=1):
        path, run = out / f"path{'' if seed == 1 else f'_{part}'}.csv", out / f"nominal{seed}"
        runs.append(run)
        if not (reuse and (run / "truth.json").exists()):
            cli("path", *PARTS[part], "--robot", robot, "--out", str(path))
            cli("lab", "--plant", "dynamic", "--neutral", *(a for item in plant_set for a in ("--set", item)),
                "--scenario", "nominal", "--commanded", str(path), "--seed", str(seed), "--robot", robot,
                "--out", str(run))
    learned = cli_json("learn", *map(str, runs))["robot"]
    plants = [json.loads((run / "truth.json").read_text())["joint_stiffness_nm_per_rad"] for run in runs]
    assert all(p == plants[0] for p in plants), plants  # one robot: its runs' plant the same
    plant = plants[0]
    joints = [{"joint": j + 1, "learned_knm": 1e-3 * k, "std_knm": 1e-3 * s, "plant_knm": 1e-3 * p,
               "prior_knm": 1e-3 * k0}
              for j, (k, s, p, k0, seen) in enumerate(zip(learned["k_q_nm_per_rad"], learned["k_q_std_nm_per_rad"],
                                                          plant, learned["prior_k_q_nm_per_rad"],
                                                          learned["observable"], strict=True)) if seen]
    return {"cell": cell, "joints": joints}


def table(rows: list[dict[str, Any]]) -> str:
    """Per observable joint: learned ± stated spread, the plant's, their ratio, the miss in spreads."""
    lines = ["| cell | joint | prior [kN·m/rad] | learned ± spread | plant | learned / plant | miss / spread |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        for j in r["joints"]:
            miss = abs(j["learned_knm"] - j["plant_knm"]) / j["std_knm"]
            lines.append(f"| {r['cell']} | j{j['joint']} | {j['prior_knm']:.0f} | {j['learned_knm']:.0f} ± "
                         f"{j['std_knm']:.0f} ({100 * j['std_knm'] / j['learned_knm']:.0f} %) | {j['plant_knm']:.0f} | "
                         f"{j['learned_knm'] / j['plant_knm']:.2f} | {miss:.1f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--cells", default=",".join(CELLS))
    parser.add_argument("--doc", type=Path, help="write the table into this page between its markers")
    parser.add_argument("--marker", default="robot-learning", help="the page's markers (default robot-learning)")
    parser.add_argument("--plant-set", action="append", default=[], metavar="NAME=VALUE",
                        help="a plant knob for every run (repeat), e.g. link_friction_scale=0")
    parser.add_argument("--reuse", action="store_true", help="learn again from the runs an earlier call left in OUT")
    args = parser.parse_args()
    rows = [cell_study(args.out / cell.replace(":", "-"), cell, tuple(args.plant_set), args.reuse)
            for cell in args.cells.split(",")]
    (args.out / "robot_learning.json").write_text(json.dumps(rows, indent=1))
    (args.out / "robot_learning.md").write_text(table(rows))
    print(table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, args.marker, table(rows))


if __name__ == "__main__":
    main()
