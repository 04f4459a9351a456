"""How far the sheet's force as a function of depth carries from a nominal cone to a pyramid it never formed.

On each cell of `experiments/sheet_learner_study.py`'s output (robot and the plant's sheet law, default knobs: the
nominal 60 x 10 mm cone, learned from, and the 40 x 6 mm pyramid, never learned from; the runs of docs/learning.md's
sheet-learner table), the pyramid's measured Fz is predicted from the cone's run three ways, each fitted on the cone
alone:

- the sheet learner's own choice (`twin.analysis.learn.sheet.select_terms`, best subset on the look-ahead);
- a function of depth alone, σ, σD and σD² (the contact, the depth below the original sheet and its square:
  terms the learner's library has);
- the cone's measured Fz as a table of the measured tip's depth (means over 0.25 mm bins, read at the pyramid's tip
  depth where the tool meets the sheet): the most a function of depth can carry, with no form at all.

With the cone's look-ahead error of the first two (what the learner chooses by) and the pyramid's measured Fz
over the cone's at the same tip depth, mean over the tip deeper than `DEEP_MM`. Every number is the regression
rows the learner itself reads (`sheet_rows`: the declared sheet driven along the measured tip); nothing reads a
plant's truth. Writes OUT/sheet_depth.json, OUT/sheet_depth.md and with `--doc` the table between the page's
sheet-depth markers:

    .venv/bin/python experiments/sheet_learner_study.py SLS
    .venv/bin/python experiments/sheet_depth_study.py OUT --from SLS [--doc docs/learning.md]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
from experiments_cli import write_between_markers
from sheet_learner_study import CELLS, HELD_OUT

from twin.analysis.learn import sheet as learner
from twin.analysis.learn.cell import declared_process
from twin.process.force.learned import WEIGHT_KEYS
from twin.runs.read import read_run

#: The pyramid's force over the cone's is compared where the tip is deeper than this [mm].
DEEP_MM = 3.0
#: Bin of the cone's Fz table [mm].
BIN_MM = 0.25
KEY = {k: i for i, k in enumerate(WEIGHT_KEYS)}
DEPTH_ONLY = [KEY["contact_n"], KEY["depth_n_per_mm"], KEY["depth_sq_n_per_mm2"]]


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e**2)))


def _tip_depth_mm(rows: learner.SheetRows) -> np.ndarray:
    """The measured tip's depth below the original sheet [mm], where the tool meets it (σD / σ)."""
    return rows.terms[:, KEY["depth_n_per_mm"]] / np.maximum(rows.terms[:, KEY["contact_n"]], 1e-9)


def cell_study(name: str, folder: Path) -> dict[str, Any]:
    """One cell's row (module docstring)."""
    cone, pyramid = read_run(folder / "cone"), read_run(folder / "pyramid")
    process = declared_process(cone)
    rc, rp = learner.sheet_rows(cone, process), learner.sheet_rows(pyramid, process)
    fc, fp = rc.measured_n[:, 2], rp.measured_n[:, 2]
    block = learner._blocks([rc], learner.BLOCKS)
    chosen, chosen_look_ahead, share = learner.select_terms(rc.terms, fc, block)  # the learner's choice, its score
    depth_only_look_ahead = learner._LookAhead(rc.terms, fc, block)(DEPTH_ONLY)
    row: dict[str, Any] = {"cell": name, "chosen": [WEIGHT_KEYS[c] for c in chosen], "rise_share": share}
    for key, cols, look_ahead in (("chosen", chosen, chosen_look_ahead),
                                  ("depth_only", DEPTH_ONLY, depth_only_look_ahead)):
        w = learner._ridge(rc.terms[:, cols], fc, cols)
        row[f"{key}_pyramid_rms_n"] = _rms(fp - rp.terms[:, cols] @ w)
        row[f"{key}_look_ahead_n"] = float(look_ahead)
    dc, dp = _tip_depth_mm(rc), _tip_depth_mm(rp)
    index = np.floor(dc / BIN_MM).astype(int)
    bins = [i for i in range(index.max() + 1) if np.count_nonzero(index == i) >= 4]
    centres = (np.array(bins) + 0.5) * BIN_MM
    table = np.array([fc[index == i].mean() for i in bins])
    contact = np.clip(rp.terms[:, KEY["contact_n"]], 0.0, 1.0)
    cone_at = np.interp(dp, centres, table)
    row["depth_table_pyramid_rms_n"] = _rms(fp - contact * cone_at)
    deep = (dp > DEEP_MM) & (dp <= dc.max())
    row["pyramid_over_cone_deep_n"] = float(np.mean(fp[deep] - cone_at[deep]))
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table (module docstring)."""
    lines = ["Pyramid (never formed) Fz rms gap [N], predicted from the nominal cone by: the learner's chosen terms; "
             "σ, σD, σD²; the cone's Fz as a table of the tip's depth. Look-ahead on the cone [N] (what the learner "
             f"chooses by). Pyramid over cone at the same tip depth, mean deeper than {DEEP_MM:g} mm [N]. The share "
             "of the tip terms' look-ahead error on the cone the walls' rise around the tool would take off (taken "
             f"over {100 * learner.SHAPE_GAIN:.0f} %).", "",
             "| cell | terms chosen | chosen: pyramid / cone look-ahead | σ, σD, σD²: pyramid / cone look-ahead | "
             "cone's Fz(depth) table: pyramid | pyramid over cone | walls' rise: share off |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['cell']} | {', '.join(k for k in r['chosen'] if k != 'prior_weight')} | "
                     f"{r['chosen_pyramid_rms_n']:.0f} / {r['chosen_look_ahead_n']:.0f} | "
                     f"{r['depth_only_pyramid_rms_n']:.0f} / {r['depth_only_look_ahead_n']:.0f} | "
                     f"{r['depth_table_pyramid_rms_n']:.0f} | {r['pyramid_over_cone_deep_n']:+.0f} | "
                     f"{100 * r['rise_share']:.0f} % |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--from", dest="source", type=Path, required=True,
                        help="the output folder of experiments/sheet_learner_study.py")
    parser.add_argument("--doc", type=Path, help="write the table into this page between its markers")
    args = parser.parse_args()
    rows = []
    for cell in CELLS:
        robot, law = cell.split(":")
        name = f"{robot}, sheet law {law} ({'held out' if robot in HELD_OUT else 'development'})"
        rows.append(cell_study(name, args.source / cell.replace(":", "-law")))
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "sheet_depth.json").write_text(json.dumps(rows, indent=1))
    (args.out / "sheet_depth.md").write_text(table(rows))
    print(table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, "sheet-depth", table(rows))


if __name__ == "__main__":
    main()
