"""What one more run of the same cone buys: the cone formed with its learned compensation, then learned from too.

A lab that has learned its cell from a nominal cone (`experiments/learn_cell.py`: seed 1 learned from, the cone
compensated with the learned twin and formed with seed 3) has a second run of the same part for free: the
compensated one, in which the tool stood where the design puts it (a nominal run's lagging tip forms a shallower
wall, docs/learning.md). `learn NOMINAL COMPENSATED` learns from both; the wider cone and the pyramid, which
neither run formed, are compensated with that model and formed (seed 3, the cell's knobs), and each is judged
against its ideal path beside the one-run model's (`learn_cell.py`'s learned twin): `check`'s residual on the
tracker, and the plant's true tip (`truth_tip.csv`, read here on the experiment's side only). Writes
OUT/learn_again.json, OUT/learn_again.md and with `--doc` the table between the page's learn-again markers:

    .venv/bin/python experiments/learn_cell.py L1 --variants cone-tx200,cone-kr210,cone-irb6640
    .venv/bin/python experiments/learn_cell.py L2 --variants cone-tx200,cone-kr210,cone-irb6640 \\
        --plant-set sheet_law=2
    .venv/bin/python experiments/learn_again.py OUT --law1 L1 --law2 L2 [--doc docs/learning.md]
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from experiments_cli import cli, cli_json, write_study
from learn_cell import OTHER_NAMES, VARIANTS, cone_cells, cone_cells_parser
from online_study import rms_mm, true_tip_miss_mm


def _judged(run_dir: Path, ideal: Path) -> dict[str, float]:
    """A formed run's residual against its ideal path: `check`'s on the tracker and the true tip's [mm]."""
    return {"tracker_mm": float(cli_json("check", str(run_dir), "--ideal", str(ideal))["residual_rms_mm"]),
            "true_tip_mm": rms_mm(true_tip_miss_mm(run_dir, ideal))}


def cell_again(folder: Path, out: Path, robot: str, plant_set: tuple[str, ...]) -> list[dict[str, Any]]:
    """One cell's rows (module docstring): `folder` is a learn_cell cone variant's, `out` this study's."""
    _, _, knobs, _ = VARIANTS[f"cone-{robot}"]
    knobs = [*knobs, *(arg for item in plant_set for arg in ("--set", item))]
    out.mkdir(parents=True, exist_ok=True)
    model = out / "learned_twice.json"
    model.unlink(missing_ok=True)
    cli("learn", str(folder / "nominal1"), str(folder / "learned_formed"), "--write-model", str(model))
    rows = []
    for prefix, part in OTHER_NAMES.items():
        ideal, command, formed = folder / f"{prefix}path.csv", out / f"{prefix}twice.csv", out / f"{prefix}twice_formed"
        for old in (command, command.with_suffix(".compensation.json")):
            old.unlink(missing_ok=True)
        cli("compensate", "--method", "twin", "--model", str(model), "--ideal", str(ideal), "--out", str(command))
        if formed.exists():
            shutil.rmtree(formed)
        cli("lab", "--plant", "dynamic", *knobs, "--scenario", "compensated", "--commanded", str(command), "--seed",
            "3", "--robot", robot, "--out", str(formed))
        rows.append({"part": part, "once": _judged(folder / f"{prefix}learned_formed", ideal),
                     "twice": _judged(formed, ideal)})
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = ["Residual of each part compensated with the twin learned from the nominal cone (once) and from it and "
             "the cone's compensated run (twice), formed with seed 3: tracker (`check`) / true tip [mm].", "",
             "| cell | part | learned once | learned twice |", "|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['cell']} | {r['part']} | {r['once']['tracker_mm']:.3f} / {r['once']['true_tip_mm']:.3f} | "
                     f"{r['twice']['tracker_mm']:.3f} / {r['twice']['true_tip_mm']:.3f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    args = cone_cells_parser(__doc__.splitlines()[0]).parse_args()
    rows: list[dict[str, Any]] = []
    for cell, robot, folder, plant_set in cone_cells(args.law1, args.law2):
        for row in cell_again(folder, args.out / cell.split(" (")[0].replace(", sheet law ", "-law"), robot, plant_set):
            rows.append({"cell": cell, **row})
            print(table(rows[-1:]).splitlines()[-1], flush=True)
    write_study(args.out, "learn_again", rows, table(rows), args.doc, "learn-again")


if __name__ == "__main__":
    main()
