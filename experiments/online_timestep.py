"""Do the online results on parts a cone did not teach hold at a finer plant step? The plant's own convergence.

The dynamic plant integrates at 1 ms (`timestep_s`, twin/lab/dynamic/knobs.py: its servo runs once per step). A
result that moves when that step is halved is the integrator's, not the cell's. For each robot a model is learned
from one nominal cone (60 x 10 mm, seed 1, at the default step) and each part of `experiments/online_other_part.py`
(a cone 80 x 8 mm, a pyramid 40 x 6 mm, the thesis's groove) is formed online with it (seed 3, as that table's
"online, learned" column) at the default step and at half of it (`lab --set timestep_s=5e-4`: a knob of the plant,
which the twin never sees), and so is its "both, learned" (the learned offline command, `compensate --method twin
--model`, with the learned online correction on top). Each is scored on the plant's true tip (its `truth_tip.csv`, read on the experiment's
side only); the share of the run's mean square miss from samples that miss by more than 0.5 mm says whether a few
events carry it. Writes OUT/online_timestep.json, OUT/online_timestep.md and with `--doc` the table between the
online-timestep markers of that page (docs/online.md; `tests/test_online_timestep_doc.py` reads it):

    .venv/bin/python experiments/online_timestep.py OUT [--robots tx200,kr210,irb6640] [--doc docs/online.md]

About 20 minutes on one core (a robot per process: `--robots`, then `--merge` the robots' JSON files).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from online_other_part import learned_online_miss, learned_parts, per_robot_main
from online_study import rms_mm

#: The finer step [s] (the plant's default is 1 ms), and the miss above which a sample counts as an event [mm].
FINE_STEP_S, EVENT_MM = 5e-4, 0.5
#: The plant knob that halves its step (`lab --set`).
FINE_STEP = (f"timestep_s={FINE_STEP_S:g}",)


def _score(miss: np.ndarray) -> dict[str, float]:
    """A run's true-tip rms [mm] and the share of its mean square from samples that miss by more than `EVENT_MM`."""
    square = np.sum(miss**2, axis=1)
    return {"true_tip_rms_mm": rms_mm(miss),
            "event_share": float(np.sum(square[np.sqrt(square) > EVENT_MM]) / np.sum(square))}


def robot_rows(out: Path, robot: str, plant_set: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """One robot's rows (module docstring); `plant_set`: plant knobs NAME=VALUE added to every run."""
    rows = []
    for p in learned_parts(out, robot, plant_set):
        row: dict[str, Any] = {"robot": robot, "part": p.part}
        for name, step in (("default", ()), ("fine", FINE_STEP)):
            for key, run, formed, scenario in ((name, f"online_{name}", p.ideal, "nominal"),
                                               (f"both_{name}", f"both_{name}", p.command, "compensated")):
                row[key] = _score(learned_online_miss(robot, p.model, formed, p.ideal, out / f"{p.ideal.stem}_{run}", 3,
                                                      scenario, (*plant_set, *step)))
        rows.append(row)
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table: true tip rms [mm] and the share of its mean square from misses over `EVENT_MM`."""
    lines = ["| robot | part (never formed) | online, learned: 1 ms step | the same, 0.5 ms step | share from misses over "
             "0.5 mm: 1 ms / 0.5 ms | both, learned: 1 ms step | the same, 0.5 ms step |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['robot']} | {r['part']} | {r['default']['true_tip_rms_mm']:.3f} mm | "
                     f"{r['fine']['true_tip_rms_mm']:.3f} mm | {r['default']['event_share']:.2f} / "
                     f"{r['fine']['event_share']:.2f} | {r['both_default']['true_tip_rms_mm']:.3f} mm | "
                     f"{r['both_fine']['true_tip_rms_mm']:.3f} mm |")
    return "\n".join(lines) + "\n"


def main() -> None:
    per_robot_main(__doc__.splitlines()[0], "online_timestep", robot_rows, table)


if __name__ == "__main__":
    main()
