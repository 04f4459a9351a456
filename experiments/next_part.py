"""The next part from the last part's measured forces (`compensate --forces-from RUN`), part after part.

On `experiments/learn_cell.py`'s cone variants (the twin learned from the nominal 60 x 10 mm cone, seed 1), for each
part the twin never formed (the 80 x 8 mm cone and the 40 x 6 mm pyramid): the first part is learn_cell's, compensated
with the learned twin and formed with seed 3; each next part's command is `compensate --method twin --model
LEARNED --ideal PART --forces-from LAST_RUN` (the last command moved by the learned robot's predicted miss with the
forces the last part measured; `twin.analysis.next_part`), formed on a new sheet (the next seed), as a cell forms a
batch. Scored by `check` (the tracker) and on the plant's true tip (`truth_tip.csv`, read on the experiment's side
only). The parts after the first learn from a run of the same part: issue #48's targets ask a part the twin never
formed, so these are footnotes to them, and what a batch of one part gets.

Writes OUT/next_part.json, OUT/next_part.md and with `--doc` the table between the page's next-part markers:

    .venv/bin/python experiments/learn_cell.py L1 --variants cone-tx200,cone-kr210,cone-irb6640
    .venv/bin/python experiments/learn_cell.py L2 --variants cone-tx200,cone-kr210,cone-irb6640 \\
        --plant-set sheet_law=2
    .venv/bin/python experiments/next_part.py OUT --law1 L1 --law2 L2 [--doc docs/learning.md]

(about 3 minutes on top of `learn_cell.py`'s runs).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from experiments_cli import cli, cli_json, lab_neutral
from learn_cell import OTHER_NAMES, cone_cells_parser, cone_study
from online_study import rms_mm, true_tip_miss_mm

#: How many parts follow the first.
NEXT_PARTS = 2


def _scores(run_dir: Path, ideal: Path) -> dict[str, float]:
    """`check`'s rms (the tracker) and the true tip's [mm]."""
    return {"tracker_mm": cli_json("check", str(run_dir), "--ideal", str(ideal))["residual_rms_mm"],
            "true_mm": rms_mm(true_tip_miss_mm(run_dir, ideal))}


def part_batch(out: Path, robot: str, folder: Path, prefix: str, plant_set: tuple[str, ...]) -> list[dict[str, float]]:
    """The part's first run (learn_cell's) and `NEXT_PARTS` more, each from the last one's forces."""
    ideal, model = folder / f"{prefix}path.csv", folder / "learned.json"
    last = folder / f"{prefix}learned_formed"
    scores = [_scores(last, ideal)]
    out.mkdir(parents=True, exist_ok=True)
    for k in range(1, NEXT_PARTS + 1):
        command = out / f"{prefix}next{k}.csv"
        for old in (command, command.with_suffix(".compensation.json")):
            old.unlink(missing_ok=True)
        cli("compensate", "--method", "twin", "--model", str(model), "--ideal", str(ideal), "--forces-from", str(last),
            "--out", str(command))
        last = lab_neutral(robot, command, out / f"{prefix}next{k}_formed", 3 + k, "compensated", plant_set)
        scores.append(_scores(last, ideal))
    return scores


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    heads = " | ".join(f"part {k + 2}, from part {k + 1}'s forces" for k in range(NEXT_PARTS))
    lines = ["Each part's rms miss, tracker (`check`) / true tip [mm]: the first compensated with the twin learned from "
             "the nominal cone (seed 3), each next one from the last one's measured forces (seeds 4, 5).", "",
             f"| cell | part | part 1, the learned twin | {heads} |", "|---|---|---|" + "---|" * NEXT_PARTS]
    for r in rows:
        cells = " | ".join(f"{s['tracker_mm']:.3f} / {s['true_mm']:.3f}" for s in r["parts"])
        lines.append(f"| {r['cell']} | {r['part']} | {cells} |")
    return "\n".join(lines) + "\n"


def cell_rows(work: Path, robot: str, folder: Path, plant_set: tuple[str, ...]) -> list[dict[str, Any]]:
    """One learn_cell variant's rows: each part it never formed, its batch formed into `work`."""
    return [{"part": part, "parts": part_batch(work, robot, folder, prefix, plant_set)}
            for prefix, part in OTHER_NAMES.items()]


def main() -> None:
    cone_study(cone_cells_parser(__doc__.splitlines()[0]).parse_args(), "next_part", "next-part", cell_rows, table)


if __name__ == "__main__":
    main()
