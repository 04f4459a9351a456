"""A 45° cone with the ISF height-map force model: nominal run, twin compensation, surface check.

Run: `.venv/bin/python experiments/cone_twin.py [OUT_DIR] [--depth-mm 20] [--top-width-mm 80] [--step-mm 0.5]`
(default OUT_DIR docs/figures). The plant is the twin itself with the ISF field (the virtual-lab plants still
build the per-pass table field, which knows only the groove): the script shows that the twin forms a cone,
that twin compensation brings the tool tip onto the target path, and compares the formed surface (height map
after elastic recovery) with the target's (the same height map driven rigidly along the ideal path).
Prints a Markdown table; writes `cone_deviation.png` (formed minus target surface on the wall, nominal and
compensated).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from twin.analysis.compensate import compensate_twin
from twin.process.description import Process
from twin.process.force.isf import IsfForceField
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.spec import TwinSpec


def surface(field: IsfForceField) -> np.ndarray:
    """The formed surface after the tool has left (elastic recovery) [m], (ny, nx)."""
    return field.map.unloaded_z_m(field.k_unload)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="docs/figures", type=Path)
    parser.add_argument("--depth-mm", type=float, default=20.0)
    parser.add_argument("--top-width-mm", type=float, default=80.0)
    parser.add_argument("--step-mm", type=float, default=0.5)
    args = parser.parse_args()
    spec = PartSpec(shape="cone", top_half_width_m=args.top_width_mm / 2e3, depth_m=args.depth_mm / 1e3,
                    step_down_m=args.step_mm / 1e3, wall_angle_deg=45.0)
    path = part_path(spec)
    twin = TwinSpec(process=Process(force_model="isf")).build()
    field = twin.sheet_field
    assert isinstance(field, IsfForceField)
    start = time.perf_counter()
    nominal = twin.simulate(path.t_s, path.p_sheet_m)
    formed_nominal = surface(field)
    t_nominal = time.perf_counter() - start
    start = time.perf_counter()
    comp = compensate_twin(path.t_s, path.p_sheet_m, twin, tol_m=0.1e-3, max_iter=30)
    t_comp = time.perf_counter() - start
    compensated = twin.simulate(path.t_s, comp.p_cmd_sheet_m)
    formed_comp = surface(field)
    target = IsfForceField(field.params)
    target.rigid_forces(path)
    formed_target = surface(target)

    def rms(a: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum(a**2, axis=1))))

    # the wall of the target part: formed by > 0.1 mm, above its last 2 mm (the height map keeps the cone's
    # bottom at the sheet's height, so the rim of the bottom compares envelope edges, not the part)
    mask = (formed_target < -1e-4) & (formed_target > -(spec.depth_m - 2e-3))
    rows = [
        ("nominal", rms(nominal.p_sheet_m - path.p_sheet_m), formed_nominal - formed_target),
        ("twin-compensated", rms(compensated.p_sheet_m - path.p_sheet_m), formed_comp - formed_target),
    ]
    print(f"45° spiral cone, top Ø {args.top_width_mm:g} mm, {args.depth_mm:g} mm deep, step {args.step_mm:g} mm, "
          f"{len(path)} samples; simulate {t_nominal:.1f} s, compensation {t_comp:.1f} s ({comp.iterations} iter.)")
    print("| run | path RMS [mm] | surface RMS [mm] | surface max [mm] | peak Fz [N] |")
    print("|---|---|---|---|---|")
    for (name, path_rms, dev), sim in zip(rows, (nominal, compensated), strict=True):
        print(f"| {name} | {path_rms * 1e3:.3f} | {np.sqrt(np.mean(dev[mask] ** 2)) * 1e3:.3f} | "
              f"{np.max(np.abs(dev[mask])) * 1e3:.3f} | {sim.f_sheet_n[:, 2].max():.0f} |")
    args.out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    hm = field.map
    extent = (hm.x_m[0] * 1e3, hm.x_m[-1] * 1e3, hm.y_m[0] * 1e3, hm.y_m[-1] * 1e3)
    lim = max(np.max(np.abs(d[mask])) for _, _, d in rows) * 1e3
    for ax, (name, _, dev) in zip(axes, rows, strict=True):
        shown = np.where(mask, dev * 1e3, np.nan)
        image = ax.imshow(shown, origin="lower", extent=extent, cmap="RdBu_r", vmin=-lim, vmax=lim)
        ax.set_title(f"{name}: formed - target surface")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        half = args.top_width_mm / 2 + 10
        ax.set_xlim(-half, half)
        ax.set_ylim(-half, half)
    fig.colorbar(image, ax=axes, label="deviation [mm] (+: shallower than the target)")
    out = args.out / "cone_deviation.png"
    fig.savefig(out, dpi=110)
    print(f"figure: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
