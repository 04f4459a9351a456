"""The plant's corner and its robot, as issue #45 asks them shown: the sheet laws on a rigid path, then on the plant.

* Rigid paths (no robot): each sheet law driven along the KR210 pyramid (40 mm across, 6 mm deep), a cone of the
  same size and the TX200 groove, read every 0.1 mm: the largest in-plane force change against the steady force,
  and the mean axial force.
* The plant: the KR210 pyramid, nominal, default knobs, each law at the default timestep and at half of it: the
  fast tip motion (the true tip minus its 50 ms moving mean, rms over the whole run), contact lost where the
  command is 0.5 mm or more into the sheet, the largest |tip - command|, the in-plane force peak after each corner
  stop (`twin.lab.dynamic.metrics`).
* The plant's joint stiffness per joint against the twin's prior (the shipped model's actuator gains), per robot.

Run: `.venv/bin/python experiments/plant_corners.py [--doc docs/dynamic-plant.md]`; prints the tables (and writes
them between the page's plant-corners markers; `tests/test_plant_corners_doc.py` reruns it, slow).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROBOTS = ("tx200", "kr210", "irb6640")


def _paths() -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """name -> (robot, t [s], p [m]) of the paths measured."""
    from twin.process.toolpath.groove import groove_path
    from twin.process.toolpath.shapes import PartSpec, part_path

    pyramid = part_path(PartSpec(shape="pyramid", top_half_width_m=0.020, depth_m=0.006))
    cone = part_path(PartSpec(shape="cone", top_half_width_m=0.020, depth_m=0.006))
    groove = groove_path()
    return {"KR210 pyramid": ("kr210", pyramid.t_s, pyramid.p_sheet_m),
            "KR210 cone": ("kr210", cone.t_s, cone.p_sheet_m),
            "TX200 groove": ("tx200", groove.t_s, groove.p_sheet_m)}


def rigid_rows() -> list[dict[str, Any]]:
    """Each law along each path, rigid."""
    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.metrics import rigid_force_jumps
    from twin.lab.dynamic.sheet_laws import make_sheet
    from twin.process.description import Process

    rows = []
    for name, (_, _, p) in _paths().items():
        for law in (1, 2):
            jumps = rigid_force_jumps(make_sheet(Knobs({"sheet_law": law}), Process()), p)
            rows.append({"path": name, "law": law, "max_jump_n": jumps.max_jump_n, "steady_n": jumps.steady_n,
                         "jump_over_steady": jumps.jump_over_steady, "mean_fz_n": float(jumps.mean_f_n[2])})
    return rows


def plant_rows() -> list[dict[str, Any]]:
    """The KR210 pyramid on the plant, each law, two timesteps."""
    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.metrics import corner_metrics
    from twin.lab.dynamic.run import run_dynamic_lab

    robot, t_s, p = _paths()["KR210 pyramid"]
    rows = []
    for law in (1, 2):
        for dt in (1e-3, 5e-4):
            run, _, log = run_dynamic_lab(t_s, p, scenario="nominal", knobs=Knobs({"sheet_law": law, "timestep_s": dt}),
                                          seed=1, robot=robot)
            m = corner_metrics(log.t_s, log.p_tip_sheet_m, log.f_sheet_n, run.commanded.t_s, run.commanded.values)
            rows.append({"law": law, "timestep_s": dt, **m._asdict()})
    return rows


def stiffness_rows() -> list[dict[str, Any]]:
    """Per robot and joint: the twin's prior (the shipped model's actuator gain) and the plant's K_q."""
    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.plant import build_plant
    from twin.robot.description import load_robot
    from twin.robot.model import load_model

    rows = []
    for name in ROBOTS:
        robot = load_robot(name)
        model = load_model(scene=True, robot=robot)
        prior = model.actuator_gainprm[robot.addresses(model).actuator, 0]
        plant = build_plant(Knobs(), robot).k_q
        for j, (a, b) in enumerate(zip(prior, plant, strict=True), start=1):
            rows.append({"robot": name, "joint": j, "prior_nm_per_rad": float(a), "plant_nm_per_rad": float(b)})
    return rows


def tables(result: dict[str, list[dict[str, Any]]]) -> str:
    """The markdown the page carries."""
    lines = ["Rigid paths (no robot), read every 0.1 mm:", "",
             "| path | law | largest in-plane change [N] | steady force [N] | change / steady | mean Fz [N] |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {r['path']} | {r['law']} | {r['max_jump_n']:.1f} | {r['steady_n']:.0f} | "
              f"{r['jump_over_steady']:.3f} | {r['mean_fz_n']:.0f} |" for r in result["rigid"]]
    lines += ["", "KR210 pyramid (40 mm, 6 mm deep) on the plant, nominal, default knobs, seed 1:", "",
              "| law | timestep [s] | fast tip rms [mm] | contact lost | episodes | max error [mm] | "
              "corner in-plane peak, median / max [N] | corner ring, median [mm] |",
              "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['law']} | {r['timestep_s']:g} | {r['fast_rms_mm']:.3f} | {100 * r['contact_lost_frac']:.2f} % | "
              f"{r['contact_lost_episodes']} | {r['max_error_mm']:.2f} | {r['corner_peak_median_n']:.0f} / "
              f"{r['corner_peak_max_n']:.0f} | {r['corner_fast_median_mm']:.3f} |" for r in result["plant"]]
    lines += ["", "Joint stiffness K_q [MN·m/rad]: the twin's prior (the shipped model) and the plant's own:", "",
              "| robot | " + " | ".join(f"j{j}" for j in range(1, 7)) + " |", "|---|" + "---|" * 6]
    for name in ROBOTS:
        rows = [r for r in result["stiffness"] if r["robot"] == name]
        cells = [f"{1e-6 * r['prior_nm_per_rad']:.3g} -> {1e-6 * r['plant_nm_per_rad']:.3g} "
                 f"({r['plant_nm_per_rad'] / r['prior_nm_per_rad']:.2f}x)" for r in rows]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--doc", type=Path, help="write the tables between this page's plant-corners markers")
    parser.add_argument("--json", type=Path, help="write the numbers as JSON")
    args = parser.parse_args()
    result = {"rigid": rigid_rows(), "plant": plant_rows(), "stiffness": stiffness_rows()}
    text = tables(result)
    print(text)
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=1))
    if args.doc is not None:
        page = args.doc.read_text(encoding="utf-8")
        begin = page.index("\n", page.index("<!-- plant-corners:begin")) + 1
        end = page.index("<!-- plant-corners:end")
        args.doc.write_text(page[:begin] + text + page[end:], encoding="utf-8")


if __name__ == "__main__":
    main()
