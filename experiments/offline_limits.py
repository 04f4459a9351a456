"""What the offline targets ask of the learned twin: on each part it never formed, how much of the compensated run's
miss its robot leaves with the run's own forces, and how much of the force its sheet's form can take at all.

On `experiments/learn_cell.py`'s cone variants (the twin learned from the nominal 60 x 10 mm cone, seed 1; the
80 x 8 mm cone and the 40 x 6 mm pyramid compensated with it and formed with seed 3, neutral knobs), for each of
those two parts:

- **the compensated run's true tip** (the plant's `truth_tip.csv`, read here on the experiment's side only): the
  miss issue #48's targets are set on;
- **the robot with the run's own forces**: the learned twin's robot (its joint springs, friction and servo
  transient; quasi-static, `twin.analysis.learn.split.measured_force_tip`) driven by the forces the run measured,
  against the same true tip. What is left there is what a compensation by that robot leaves even with a sheet model
  that knew the force exactly (a perfect sheet); its part above `FAST_HZ` is the arm moving faster than a
  quasi-static robot does, and its share of the mean square within `NEAR_STOP_S` of a stop of the controller
  (`twin.analysis.learn.split.controller_stops`: a pyramid's corners);
- **the sheet's force**: the learned sheet's force along the run's measured tip against the measured force, axial
  and in the sheet's plane (`sheet_learner_study.force_gap`: the model file's sheet itself; predicted, the sheet
  never saw the part), and the most the learner's form can take: the published formula and every candidate term
  fitted by least squares to that run's Fz, and the in-plane ratios μ_t, μ_r, μ_ρ fitted to its Fx, Fy with its
  measured Fz (`in_plane_columns`; in-sample: the floor of the form, not a prediction).

Writes OUT/offline_limits.json, OUT/offline_limits.md and with `--doc` the table between the page's
offline-limits markers:

    .venv/bin/python experiments/learn_cell.py L1 --variants cone-tx200,cone-kr210,cone-irb6640
    .venv/bin/python experiments/learn_cell.py L2 --variants cone-tx200,cone-kr210,cone-irb6640 \\
        --plant-set sheet_law=2
    .venv/bin/python experiments/offline_limits.py OUT --law1 L1 --law2 L2 [--doc docs/learning.md]
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from learn_cell import cone_cells_parser, cone_study
from online_study import rms_mm, true_tip_miss_mm
from sheet_learner_study import force_gap

from twin.analysis.learn import sheet as learner
from twin.analysis.learn.cell import declared_process
from twin.analysis.learn.split import FAST_HZ, NEAR_STOP_S, fast_part_mm, measured_force_tip, near_stop_shares
from twin.analysis.replay import spec_for_run
from twin.base.signals import interp_rows
from twin.process.force.learned import WEIGHT_KEYS
from twin.runs.read import read_commanded_csv, read_run
from twin.sim.model_file import read_model_file

#: The parts (file prefix in a learn_cell variant, name).
PARTS = (("cone80_", "cone 80 x 8"), ("pyramid_", "pyramid"))


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e**2)))


def _rms_xy(stacked: np.ndarray, m: int) -> float:
    """The rms length [N] of an in-plane force stacked as (Fx..., Fy...), m samples each."""
    return float(np.sqrt(np.mean(stacked[:m] ** 2 + stacked[m:] ** 2)))


def part_limits(folder: Path, prefix: str) -> dict[str, float]:
    """One part's numbers (module docstring) from a learn_cell variant folder."""
    run_dir, ideal = folder / f"{prefix}learned_formed", folder / f"{prefix}path.csv"
    run, spec = read_run(run_dir), read_model_file(folder / "learned.json")
    miss = true_tip_miss_mm(run_dir, ideal)
    truth = read_commanded_csv(run_dir / "truth_tip.csv")
    true_tip = interp_rows(run.tracker.t_s, truth.t_s, truth.values)
    robot_miss_m = true_tip - measured_force_tip(run, spec_for_run(run, spec).build())
    rows = learner.sheet_rows(run, declared_process(run))
    fz, fxy, m = rows.measured_n[:, 2], np.concatenate([rows.measured_n[:, 0], rows.measured_n[:, 1]]), len(rows.t_s)
    cols = [0, *(WEIGHT_KEYS.index(k) for k in learner.LIBRARY)]
    library, *_ = np.linalg.lstsq(rows.terms[:, cols], fz, rcond=None)
    plane = learner.in_plane_columns(rows, fz)
    ratios, *_ = np.linalg.lstsq(plane, fxy, rcond=None)
    learned = force_gap(run_dir, spec.process)  # the learned model itself, along the run's measured tip
    near = near_stop_shares(run, run.tracker.t_s, robot_miss_m)
    return {"true_tip_mm": rms_mm(miss), "robot_mm": rms_mm(1e3 * robot_miss_m),
            "robot_fast_mm": fast_part_mm(run.tracker.t_s, robot_miss_m),
            "robot_near_stop": near[0], "samples_near_stop": near[1],
            "learned_fz_n": learned["fz_n"], "library_fz_n": _rms(fz - rows.terms[:, cols] @ library),
            "learned_fxy_n": learned["plane_n"], "library_fxy_n": _rms_xy(fxy - plane @ ratios, m)}


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = ["Each part compensated with the twin learned from the nominal cone and formed (neutral knobs, seed 3); "
             "the robot driven by the run's own measured forces against the plant's true tip; the sheet's Fz along "
             "the run's measured tip.", "",
             f"| cell | part | true tip [mm] | robot with the run's own forces: all / above {FAST_HZ:g} Hz [mm]; its mean square's share within {NEAR_STOP_S:g} s of a stop, of the samples' | "
             "Fz rms: learned sheet (predicted) / the library fitted to the run itself [N] | "
             "Fxy rms: learned sheet (predicted) / its ratios fitted to the run itself with the measured Fz [N] |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['cell']} | {r['part']} | {r['true_tip_mm']:.3f} | {r['robot_mm']:.3f} / "
                     f"{r['robot_fast_mm']:.3f}; {r['robot_near_stop']:.2f} of {r['samples_near_stop']:.2f} | "
                     f"{r['learned_fz_n']:.0f} / {r['library_fz_n']:.0f} | "
                     f"{r['learned_fxy_n']:.0f} / {r['library_fxy_n']:.0f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    cone_study(cone_cells_parser(__doc__.splitlines()[0]).parse_args(), "offline_limits", "offline-limits",
               lambda _, __, folder, ___: [{"part": part, **part_limits(folder, prefix)} for prefix, part in PARTS],
               table)


if __name__ == "__main__":
    main()
