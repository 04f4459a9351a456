"""Are the online results on parts a cone did not teach the cell's, or the seed's? The same runs on six seeds.

The other-part table (`experiments/online_other_part.py`) forms each part once, with seed 3 (the lab's noise: the
sensors' and the tracker's, the plant's small draws). A row that moves by tenths of a millimetre from one seed to the
next is a draw, not a number. For each robot a model is learned from one nominal cone (60 x 10 mm, seed 1, as that
table's) and each part (a cone 80 x 8 mm, a pyramid 40 x 6 mm, the thesis's groove) is formed online with it and
with the learned offline command under it ("both"), on seeds `SEEDS` (3 first: the other-part table's runs again),
and online again with the plant's step halved,
each scored on the plant's true tip (its `truth_tip.csv`, read on the experiment's side only). Every online run may
correct up to `online_other_part.ONLINE_LIMIT_MM`. Writes OUT/online_seeds.json, OUT/online_seeds.md and with
`--doc` the table between the online-seeds markers of that page (docs/online.md; `tests/test_online_seeds_doc.py`
reads it):

    .venv/bin/python experiments/online_seeds.py OUT [--robots tx200,kr210,irb6640] [--doc docs/online.md]

About 25 minutes on one core (a robot per process: `--robots`, then `--merge` the robots' JSON files).
"""

from __future__ import annotations

import statistics
from pathlib import Path
from typing import Any

from online_other_part import learned_online_miss, learned_parts, per_robot_main
from online_study import rms_mm
from online_timestep import FINE_STEP

#: The lab's seeds each part is formed with (3: the other-part table's).
SEEDS = (3, 4, 5, 6, 7, 8)
#: The columns: online with the learned model, and the learned offline command with it on top; then online again
#: with the plant's step halved (`online_timestep.FINE_STEP`): a row that spans as much at either step is the
#: draw's, not the integrator's.
MODES = ("online", "both")


def robot_rows(out: Path, robot: str, plant_set: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """One robot's rows (module docstring): each mode's true-tip rms [mm] per seed; `plant_set`: plant knobs
    NAME=VALUE added to every run."""
    rows = []
    for p in learned_parts(out, robot, plant_set):
        row: dict[str, Any] = {"robot": robot, "part": p.part}
        for mode, formed, scenario, step in (("online", p.ideal, "nominal", ()),
                                             ("both", p.command, "compensated", ()),
                                             ("online_fine", p.ideal, "nominal", FINE_STEP)):
            knobs = (*plant_set, *step)
            row[mode] = [rms_mm(learned_online_miss(robot, p.model, formed, p.ideal, out / f"{p.ideal.stem}_{mode}_{seed}",
                                                    seed, scenario, knobs)) for seed in SEEDS]
        rows.append(row)
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    return rows


def _cells(values: list[float]) -> list[str]:
    return [f"{values[0]:.3f}", f"{min(values):.3f} / {statistics.median(values):.3f} / {max(values):.3f}"]


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table: per mode, seed 3's true-tip rms and the least / median / largest over `SEEDS` [mm]."""
    span = f"seeds {SEEDS[0]}-{SEEDS[-1]}: least / median / largest"
    lines = [f"| robot | part (never formed) | online, learned: seed {SEEDS[0]} | the same, {span} | both, learned: seed "
             f"{SEEDS[0]} | the same, {span} | online, learned, 0.5 ms step: {span} |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        cells = [c for mode in MODES for c in _cells(r[mode])] + _cells(r["online_fine"])[1:]
        lines.append(f"| {r['robot']} | {r['part']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    per_robot_main(__doc__.splitlines()[0], "online_seeds", robot_rows, table)


if __name__ == "__main__":
    main()
