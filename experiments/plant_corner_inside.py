"""The plant's law 1 at a pyramid's corners (a diagnostic on the experiment's side; the plant is not changed).

Law 1 (`twin.lab.dynamic.sheet.PlantSheet`) holds the side of the tool towards a part's inside flat (the hanging
bottom) where its near read across the travel is less formed than the other side's. A tool radius or so before and
after a pyramid's corner that read lands on the adjacent side's track, the test lets the side go, and its chord to
the sheet's unformed height stands in for a wall (`tests/test_plant_corner.py`'s strict xfail). This measures two
readings of the inside against the shipped one, each a subclass of the plant's sheet run in its Python loop:

* `inside_flat`: the side towards the part's centre (the sheet origin) held flat, a diagnostic that knows the part;
* `bottom_state`: the bottom carried as a state along the track, as the law carries its heading and slip: it takes
  a side's bottom read at once and lets it go over `HOLD_RADII` tool radii of travel, swapped where the travel
  reverses (a general rule a fix could take; not tuned here beyond this one value).

For each: the rigid force a radius from the corners over the side's middle (the xfail's ratio) on the KR 210 parts
of issue #45, the rigid cone's mean axial force, and the online pyramid of docs/online.md (the learned model
`online_floor.py` wrote for each robot, seed 3, true tip, scored as that study scores it):

    .venv/bin/python experiments/plant_corner_inside.py FLOOR_TX_KR FLOOR_IRB   # online_floor.py's OUT folders

Prints a table; writes nothing. Each variant's online run takes ~25 s (the sheet's Python loop).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import twin.lab.dynamic.simulate as plant_simulate
from twin.lab.dynamic import sheet as law1

#: `bottom_state`: a side's bottom is let go over this many tool radii of travel [-].
HOLD_RADII = 4.0


class InsideFlat(law1.PlantSheet):
    """Law 1 with the side towards the sheet origin (a centred part's inside) flat."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.compiled = False

    def _side_angles(self, x: float, y: float, z: float, sx: float, sy: float, cx: float, cy: float
                     ) -> tuple[float, float]:
        if sx * -x + sy * -y > 0.0:
            return 0.0, 0.0
        return super()._side_angles(x, y, z, sx, sy, cx, cy)


class BottomState(law1.PlantSheet):
    """Law 1 with each side's bottom carried along the track (module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.compiled = False
        self.state, self.read, self.before = np.zeros(2), np.zeros(2), np.zeros(2)

    def force_reference(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """`PlantSheet.force_reference` with the bottom max(read, state)."""
        x, y, z = (float(v) for v in p_sheet_m)
        r = self.radius
        tx, ty = float(self.travel[0]), float(self.travel[1])
        sides = ((-ty, tx), (ty, -tx))
        met = self.height(x + r * tx, y + r * ty) - z
        cx, cy, cz = (x, y, z) if self._last is None else (float(v) for v in self._last)
        near = [self.formed_fraction(cx + law1.FORMED_READ * r * sx, cy + law1.FORMED_READ * r * sy) for sx, sy in sides]
        far = [self.formed_fraction(cx + 2.0 * r * sx, cy + 2.0 * r * sy) for sx, sy in sides]
        alpha = [0.0, 0.0]
        for s, o in ((0, 1), (1, 0)):
            chord, slope = self._side_angles(x, y, z, *sides[s], cx, cy)
            hanging = min(1.0, max(0.0, law1.FORMED_GAIN * (near[o] - far[s] - law1.FORMED_TRACK)))
            self.read[s] = min(1.0, max(0.0, law1.FORMED_GAIN * (near[o] - near[s] - law1.FORMED_TRACK)))
            bottom = max(float(self.read[s]), float(self.state[s]))
            alpha[s] = (1.0 - bottom) * min(max(chord, (1.0 - hanging) * slope), law1.MAX_ANGLE_RAD)
        steep = max(alpha)
        n, w = self.membrane_n_per_m(steep), r * math.sin(steep)
        up = w * n * (math.sin(alpha[0]) + math.sin(alpha[1]))
        left = w * n * (math.cos(alpha[0]) - math.cos(alpha[1]))
        recovery = max(self.springback_m(-z, steep), law1.MIN_RECOVERY_M)
        rate = (cz - z) / self.timestep_s
        contact = min(1.0, max(0.0, (met + recovery) / recovery * (1.0 + 1.5 * law1.HUNT_CROSSLEY_ALPHA_S_PER_M * rate)))
        if contact <= 0.0:
            return np.zeros(3)
        friction = -self.mu * up * self.slip
        return contact * np.array([friction[0] - left * ty, friction[1] + left * tx, up])

    def advance_reference(self, p_sheet_m: np.ndarray) -> None:
        """`PlantSheet.advance_reference`, then the state: up at once, down over `HOLD_RADII` radii of travel."""
        p = np.asarray(p_sheet_m, dtype=float)
        step = 0.0 if self._last is None else float(np.hypot(*(p[:2] - self._last[:2])))
        super().advance_reference(p_sheet_m)
        if float(np.asarray(self.travel) @ self.before) < 0.0:
            self.state = self.state[::-1].copy()  # the travel reversed: left is right
        self.before = np.array(self.travel, dtype=float)
        gain = min(1.0, step / (HOLD_RADII * self.radius))
        self.state = np.where(self.read > self.state, self.read, self.state + gain * (self.read - self.state))


VARIANTS: dict[str, type[law1.PlantSheet] | None] = {"shipped": None, "inside_flat": InsideFlat,
                                                     "bottom_state": BottomState}


def rigid_row(variant: type[law1.PlantSheet] | None) -> dict[str, float]:
    """The xfail's ratios on the rigid KR 210 pyramid, and the rigid cone's mean axial force [N]."""
    import test_plant_corner as corner

    law = variant or law1.PlantSheet
    path = corner._resampled(corner.part_path(corner._part("pyramid")).p_sheet_m)
    f, _ = corner._rigid(path, corner.Process(), law=law)
    ratios = corner.corner_ratios(path, f)
    fc, _ = corner._rigid(corner._resampled(corner.part_path(corner._part("cone")).p_sheet_m), corner.Process(), law=law)
    return {"ratio_min": min(ratios), "ratio_max": max(ratios), "cone_fz_n": float(fc[:, 2].mean())}


def online_miss_mm(robot: str, folder: Path, variant: type[law1.PlantSheet] | None) -> float:
    """The learned online pyramid of `online_floor.py`'s folder on the plant with `variant`'s sheet [mm rms]."""
    from online_other_part import ONLINE_LIMIT_MM

    from twin.analysis.check import ideal_times
    from twin.analysis.resolve import resolve_robot, resolve_spec
    from twin.base.signals import interp_rows
    from twin.lab.dynamic.knobs import parse_set_args
    from twin.lab.dynamic.run import run_dynamic_lab
    from twin.runs.read import read_commanded_csv
    from twin.sim.online import OnlineCompensator, OnlineSettings

    cmd = read_commanded_csv(folder / "pyramid.csv")
    spec = resolve_spec(model=folder / "learned.json", robot=resolve_robot(None, robot), placement=None,
                        p_sheet_m=cmd.values, cell=None)
    shipped = plant_simulate.make_sheet
    if variant is not None:
        plant_simulate.make_sheet = lambda knobs, process: variant(  # type: ignore[assignment]
            process, 1e-3 * knobs["friction_reversal_mm"], knobs["timestep_s"])
    try:
        run, _, log = run_dynamic_lab(cmd.t_s, cmd.values, scenario="nominal", knobs=parse_set_args([]), seed=3,
                                      robot=resolve_robot(None, robot),
                                      corrector=OnlineCompensator(spec, OnlineSettings(max_correction_mm=ONLINE_LIMIT_MM)))
    finally:
        plant_simulate.make_sheet = shipped
    ideal = interp_rows(log.t_s, ideal_times(run.commanded.t_s, cmd.t_s), cmd.values)
    return float(1e3 * np.sqrt(np.mean(np.sum((log.p_tip_sheet_m - ideal) ** 2, axis=1))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("floors", type=Path, nargs="+", help="online_floor.py OUT folders (a robot's folder inside)")
    args = parser.parse_args()
    robots = {d.name: d for floor in args.floors for d in sorted(floor.iterdir()) if (d / "learned.json").is_file()}
    print("| sheet | rigid: force a radius from a corner / side's middle | rigid cone Fz [N] | online pyramid "
          + " / ".join(robots) + " [mm] |")
    print("|---|---|---|---|")
    for name, variant in VARIANTS.items():
        rigid = rigid_row(variant)
        online = [online_miss_mm(robot, folder, variant) for robot, folder in robots.items()]
        print(f"| {name} | {rigid['ratio_min']:.2f}-{rigid['ratio_max']:.2f} | {rigid['cone_fz_n']:.1f} | "
              + " / ".join(f"{v:.3f}" for v in online) + " |", flush=True)


if __name__ == "__main__":
    main()
