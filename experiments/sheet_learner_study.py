"""The learned sheet on parts it never formed: its force gap against the published formula's, on plant cells.

For each cell (robot and the plant's sheet law): a nominal cone (60 mm wide, 10 mm deep, seed 1) is formed on
the dynamic plant and the sheet is learned from its F/T stream alone (`twin.analysis.learn.sheet.fit_sheet`:
fitted); then a wider, shallower cone (80 x 8 mm, seed 2) and a pyramid (40 x 6 mm, seed 3) are formed and each
model's force is compared with their measured force along their measured tips (predicted: never learned from).
Three models: the published formula (the declared ISF model, nothing fitted), the membrane learner this one
replaced (the published formula plus the membrane wrap terms of Silva et al. by least squares: the form the
plant's sheet law 1 is written in) and the learner (terms chosen by look-ahead validation, ridge towards the
published formula). The TX200 cells were looked at while the learner was built (development); the KR 210 and
IRB 6640 cells were not (held out). Nothing here reads the plant's truth, knobs or code on the twin's side.
A second table sets the force across and along the travel (Fx, Fy) of the published formula's constant ratios
against the learner's with its radial ratio held constant (μ_r alone, least squares with the learned Fz) and the
learner's own (μ_r, μ_ρ as it chose them: the push across the travel following the walls' rise).
Writes OUT/sheet_learner.json, OUT/sheet_learner.md and with `--doc` the tables between the sheet-learner and
sheet-learner-plane markers of that page (docs/learning.md; `tests/test_sheet_learner.py` guards their numbers);
`--reuse` keeps the plant runs an earlier call left in OUT (the plant is deterministic):

    .venv/bin/python experiments/sheet_learner_study.py OUT [--cells tx200:1,...] [--doc docs/learning.md] [--reuse]
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from experiments_cli import cli, write_between_markers

from twin.analysis.identify.forces import measured_tip_path
from twin.analysis.learn.cell import declared_process
from twin.analysis.learn.sheet import SheetRows, _lstsq, fit_sheet, in_plane_columns, sheet_rows
from twin.base.signals import interp_rows
from twin.process.description import Process
from twin.process.force.learned import RADIAL_RISE_KEY, WEIGHT_KEYS
from twin.process.force.registry import build_force_field
from twin.runs.read import read_run

#: robot:sheet law, development first.
CELLS = ("tx200:1", "tx200:2", "kr210:1", "kr210:2", "irb6640:1", "irb6640:2")
HELD_OUT = ("kr210", "irb6640")
#: name -> (shape, top width [mm], depth [mm], seed)
PARTS = {"cone": ("cone", 60, 10, 1), "cone 80 x 8": ("cone", 80, 8, 2), "pyramid": ("pyramid", 40, 6, 3)}


def membrane_fit(run_dir: Path, process: Process) -> Process:
    """The membrane learner this one replaced: the published formula and the three membrane wrap terms by least
    squares against Fz, the in-plane ratios against Fx, Fy with the fitted Fz."""
    run = read_run(run_dir)
    rows = sheet_rows(run, process)
    weights = np.zeros(len(WEIGHT_KEYS))
    weights[:4] = _lstsq(rows.terms[:, :4], rows.measured_n[:, 2])[0]
    mu_t, mu_r = _constant_ratios(rows, weights)
    fit = (*zip(WEIGHT_KEYS, map(float, weights), strict=True), ("mu_eff", mu_t), ("mu_radial", mu_r))
    return replace(process, force_model="learned", force_fit=fit)


def constant_ratio(run_dir: Path, learned: Process) -> Process:
    """The learned sheet with its radial ratio held constant: μ_t and μ_r by least squares against Fx, Fy with the
    learned Fz, μ_ρ = 0."""
    rows = sheet_rows(read_run(run_dir), learned)
    fit = dict(learned.force_fit)
    mu_t, mu_r = _constant_ratios(rows, np.array([fit[k] for k in WEIGHT_KEYS]))
    fit |= {"mu_eff": mu_t, "mu_radial": mu_r, RADIAL_RISE_KEY: 0.0}
    return replace(learned, force_fit=tuple(fit.items()))


def _constant_ratios(rows: SheetRows, weights: np.ndarray) -> tuple[float, float]:
    """(μ_t, μ_r), constant ratios, by least squares against the run's Fx, Fy with the Fz of `weights` [-]."""
    fz = np.maximum(rows.terms @ weights, 0.0)
    fxy = np.concatenate([rows.measured_n[:, 0], rows.measured_n[:, 1]])
    mu = np.clip(_lstsq(in_plane_columns(rows, fz)[:, :2], fxy)[0], 1e-6, None)
    return float(mu[0]), float(mu[1])


def force_gap(run_dir: Path, process: Process) -> dict[str, float]:
    """RMS of the measured minus the model's force along the run's measured tip [N]: Fz, and the whole vector."""
    run = read_run(run_dir)
    assert run.forces is not None
    path = measured_tip_path(run, 0.0)
    t = run.forces.t_s
    inside = (t >= path.t_s[0]) & (t <= path.t_s[-1])
    error = run.forces.values[inside] - interp_rows(t[inside], path.t_s, build_force_field(process).rigid_forces(path))
    return {"fz_n": float(np.sqrt(np.mean(error[:, 2] ** 2))),
            "vector_n": float(np.sqrt(np.mean(np.sum(error**2, axis=1)))),
            "plane_n": float(np.sqrt(np.mean(np.sum(error[:, :2] ** 2, axis=1))))}


def cell_study(out: Path, cell: str, reuse: bool = False) -> dict[str, Any]:
    """One cell's row (module docstring); `reuse`: plant runs already in `out` kept."""
    robot, law = cell.split(":")
    out.mkdir(parents=True, exist_ok=True)
    runs = {}
    for name, (shape, width, depth, seed) in PARTS.items():
        path, run = out / f"{name.replace(' ', '')}.csv", out / name.replace(" ", "")
        cli("path", "--shape", shape, "--top-width-mm", str(width), "--depth-mm", str(depth), "--robot", robot,
            "--out", str(path))
        if not (reuse and (run / "forces.csv").is_file()):
            cli("lab", "--plant", "dynamic", "--set", f"sheet_law={law}", "--scenario", "nominal", "--commanded",
                str(path), "--seed", str(seed), "--robot", robot, "--out", str(run))
        runs[name] = run
    declared = declared_process(read_run(runs["cone"]))
    fit = fit_sheet([read_run(runs["cone"])], declared)
    learned = replace(declared, force_model="learned", force_fit=fit.force_fit)
    models = {"published": declared, "membrane": membrane_fit(runs["cone"], declared), "learned": learned,
              "constant ratio": constant_ratio(runs["cone"], learned)}
    row: dict[str, Any] = {"cell": cell, "robot": robot, "sheet_law": int(law), "held_out": robot in HELD_OUT,
                           "terms": list(fit.terms), "validation_rms_n": fit.validation_rms_n,
                           "ratios": {k: v for k, v in fit.force_fit if k in ("mu_eff", "mu_radial", RADIAL_RISE_KEY)},
                           "published_validation_rms_n": fit.prior_validation_rms_n}
    for name, run in runs.items():
        row[name] = {model: force_gap(run, process) for model, process in models.items()}
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of the study: Fz rms [N], published / membrane / learned."""
    lines = ["| cell | terms chosen | cone (fitted) | cone 80 x 8 (predicted) | pyramid (predicted) |",
             "|---|---|---|---|---|"]
    for r in rows:
        cells = [" / ".join(f"{r[part][m]['fz_n']:.0f}" for m in ("published", "membrane", "learned")) + " N"
                 for part in PARTS]
        tag = "held out" if r["held_out"] else "development"
        terms = ", ".join(t for t in r["terms"] if t != "prior_weight")
        lines.append(f"| {r['robot']}, sheet law {r['sheet_law']} ({tag}) | {terms} | {' | '.join(cells)} |")
    return "\n".join(lines) + "\n"


def plane_table(rows: list[dict[str, Any]]) -> str:
    """The in-plane table: the learner's ratios, and Fx, Fy rms [N], published / constant ratio / learned."""
    lines = ["| cell | ratios learned | cone (fitted) | cone 80 x 8 (predicted) | pyramid (predicted) |",
             "|---|---|---|---|---|"]
    for r in rows:
        cells = [" / ".join(f"{r[part][m]['plane_n']:.0f}" for m in ("published", "constant ratio", "learned")) +
                 " N" for part in PARTS]
        q = r["ratios"]
        ratios = f"mu_t {q['mu_eff']:.2f}, mu_r {q['mu_radial']:.2f}, mu_rho {q[RADIAL_RISE_KEY]:.2f}"
        tag = "held out" if r["held_out"] else "development"
        lines.append(f"| {r['robot']}, sheet law {r['sheet_law']} ({tag}) | {ratios} | {' | '.join(cells)} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--cells", default=",".join(CELLS))
    parser.add_argument("--doc", type=Path, help="write the tables into this page between their markers")
    parser.add_argument("--reuse", action="store_true", help="keep the plant runs an earlier call left in OUT")
    args = parser.parse_args()
    rows = []
    for cell in args.cells.split(","):
        rows.append(cell_study(args.out / cell.replace(":", "-law"), cell, args.reuse))
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    (args.out / "sheet_learner.json").write_text(json.dumps(rows, indent=1))
    (args.out / "sheet_learner.md").write_text(table(rows) + "\n" + plane_table(rows))
    print(table(rows) + "\n" + plane_table(rows))
    if args.doc is not None:
        write_between_markers(args.doc, "sheet-learner", table(rows))
        write_between_markers(args.doc, "sheet-learner-plane", plane_table(rows))


if __name__ == "__main__":
    main()
