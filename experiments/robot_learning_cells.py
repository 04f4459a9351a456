"""The learned robot against the plant's on the plant-change cells: every cell `tests.plant_changes` learned under
WORK (the plant's default knobs, not the neutral ones of `robot_learning_study.py`), learned again here from its
two clean runs with `tx200-twin learn` (the twin side reads the runs only); on the experiment's side each joint's
learned K_q and stated spread are set against the plant's (`truth.json`). Prints one line per cell and a count:
the observed joints within two stated spreads of the plant's, with a spread of at most 15 % (issue #48's target),
and at the bound of the learner's range. Writes OUT (JSON):

    .venv/bin/python experiments/robot_learning_cells.py WORK OUT [--tracker-errors | --tracker-late]

`--tracker-errors` (`--tracker-late`): `learn --tracker-errors` (`--tracker-late`): each run's tracker rotation and
lateness (its lateness alone) fitted beside the robot.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
from experiments_cli import add_tracker_options, cli_json, tracker_options

from twin.analysis.learn.stick_slip import COMPLIANCE_RANGE


def cell_row(cell: Path, *options: str) -> dict[str, Any]:
    """One cell's learned joints against the plant's (`options`: `learn`'s)."""
    robot = cli_json("learn", str(cell / "clean1"), str(cell / "clean2"), *options)["robot"]
    plant = json.loads((cell / "clean1" / "truth.json").read_text())["joint_stiffness_nm_per_rad"]
    return {"cell": f"{cell.parent.name}/{cell.name}", "k": robot["k_q_nm_per_rad"],
            "std": robot["k_q_std_nm_per_rad"], "prior": robot["prior_k_q_nm_per_rad"],
            "observable": robot["observable"], "plant": plant}


def summary(rows: list[dict[str, Any]]) -> str:
    """The counts over every observed joint (module docstring)."""
    n = within = narrow = both = bound = 0
    ratios = []
    for r in rows:
        k, s, p, k0 = (np.asarray(r[key], dtype=float) for key in ("k", "std", "plant", "prior"))
        for j in np.flatnonzero(r["observable"]):
            close, tight = abs(k[j] - p[j]) <= 2.0 * s[j], s[j] <= 0.15 * k[j]
            n, within, narrow, both = n + 1, within + close, narrow + tight, both + (close and tight)
            bound += not (k0[j] / COMPLIANCE_RANGE[1] * 1.001 < k[j] < k0[j] / COMPLIANCE_RANGE[0] * 0.999)
            ratios.append(k[j] / p[j])
    return (f"{n} observed joints over {len(rows)} cells: within two stated spreads of the plant's {within}, spread "
            f"<= 15 % {narrow}, both {both}; at the learner's range bound {bound}; learned / plant "
            f"{min(ratios):.2f}-{max(ratios):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("work", type=Path)
    parser.add_argument("out", type=Path)
    add_tracker_options(parser)
    args = parser.parse_args()
    rows = []
    for cell in sorted(p.parent for p in args.work.glob("*/*/clean1")):
        row = cell_row(cell, *tracker_options(args))
        rows.append(row)
        joints = " ".join(f"{'*' if seen else ' '}{1e-6 * k:.2f}/{1e-6 * p:.2f}({s / k:.0%})" for k, s, p, seen in
                          zip(row["k"], row["std"], row["plant"], row["observable"], strict=True))
        print(f"{row['cell']:32s} {joints}", flush=True)
    args.out.write_text(json.dumps(rows, indent=1))
    print(summary(rows))


if __name__ == "__main__":
    main()
