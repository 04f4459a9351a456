"""Where the online compensation of a pyramid and a groove stops, on the dynamic plant: the sensor, the arm's own
miss, the path of the correction.

For each robot a model is learned from one nominal cone (60 x 10 mm, seed 1) and the pyramid 40 x 6 mm and the groove
are formed online with it (seed 3), as `experiments/online_other_part.py`'s "online, learned" column; then, each
scored on the plant's true tip against the ideal path, timed as `check` times it (the plant's `truth_tip.csv` or its
log, read on the experiment's side only):

* **a perfect F/T sensor**: the same run with the sensor at 1 kHz and no noise, latency, quantum, bias, cross-talk
  or clock error (`lab --set`): how much of the miss is the sensor's;
* **in air**: the same program 30 mm above the sheet, nominal and online (the compensator's joint-friction term its
  only correction: there is no force) -- the arm's own miss at the controller's corner stops and the groove's
  reversals, which no force measures; and nominal again with the plant's joint friction off (`link_friction_scale=0`,
  a knob of the plant the twin never sees): what of that miss is the joints' friction, what their servo's;
* **the online run less its in-air miss**: the online run's miss less the in-air online run's, sample by sample (the
  same program and timing): an oracle, the most any feed-forward of the arm's own miss at the stops could take off;
* **the correction's step**: in air, a 0.5 mm step of the correction along x, y and z in turn every 4 s (on for
  2 s), the true tip's answer less the same run's without them: the median over the steps' edges of the time to
  90 % of the step [ms] and of the peak over the first 0.5 s [-] -- how late and how far a correction reaches the
  tip (on the pyramid's program; the robot's, shown on both of its rows).

Writes OUT/online_floor.json, OUT/online_floor.md and with `--doc` the table between the online-floor markers of that
page (docs/online.md; `tests/test_online_floor_doc.py` reads it):

    .venv/bin/python experiments/online_floor.py OUT [--robots tx200,kr210,irb6640] [--doc docs/online.md]

(a robot per process: `--robots`, then `--merge` the robots' JSON files).
"""

from __future__ import annotations

from itertools import count
from pathlib import Path
from typing import Any

import numpy as np
from online_other_part import (
    ONLINE_LIMIT_MM,
    ONLINE_RATE_MM_S,
    learn_cone,
    learned_online_miss,
    per_robot_main,
    target_ideal,
)
from online_study import rms_mm

from twin.analysis.check import ideal_times
from twin.analysis.resolve import resolve_robot, resolve_spec
from twin.base.signals import interp_rows
from twin.lab.dynamic.knobs import parse_set_args
from twin.lab.dynamic.run import run_dynamic_lab
from twin.runs.read import read_commanded_csv
from twin.sim.online import OnlineCompensator, OnlineSettings

#: The sensor as good as the plant's knobs make it.
PERFECT_SENSOR = ("ft_rate_hz=1000", "ft_noise_n=0", "ft_latency_s=0", "ft_quantum_n=0", "ft_bias_n=0",
                  "ft_crosstalk=0", "ft_clock_offset_s=0", "ft_clock_skew_ppm=0")
#: The parts, as `online_other_part.TARGETS` names them.
PARTS = ("pyramid", "groove")
#: The plant's joints without their friction (a diagnosis on the experiment's side).
NO_FRICTION = ("link_friction_scale=0",)
#: How far above the sheet the program runs in air [m], the correction's step [m], its period [s] and first start.
AIR_LIFT_M, STEP_M, STEP_PERIOD_S, STEP_START_S = 0.03, 5e-4, 4.0, 6.0
#: Over how long a step's answer is read [s].
STEP_WINDOW_S = 0.5


def _edge(k: int) -> tuple[float, int, float]:
    """The k-th edge of `StepCorrector`'s steps: (its time [s], the axis it steps, +1 on / -1 off)."""
    return STEP_START_S + k * STEP_PERIOD_S / 2.0, (k // 2) % 3, 1.0 if k % 2 == 0 else -1.0


class StepCorrector:
    """A correction of `STEP_M` along x, y, z in turn: on for half of each `STEP_PERIOD_S`, from `STEP_START_S`
    (the plant's `CycleCorrector`)."""

    cycle_s = 0.004

    def __init__(self) -> None:
        self.correction_m = np.zeros(3)

    def step(self, t_s: float, sample_t_s: float, f_sheet_n: np.ndarray, q_rad: np.ndarray,
             q_planned_rad: np.ndarray | None = None) -> int:
        self.correction_m[:] = 0.0
        k = int((t_s - STEP_START_S) // (STEP_PERIOD_S / 2.0))
        _, axis, sign = _edge(k)
        if t_s >= STEP_START_S and sign > 0.0:
            self.correction_m[axis] = STEP_M
        return 1


def _air_run(robot: str, ideal: Path, corrector: Any, knobs: tuple[str, ...] = ()) -> tuple[np.ndarray, np.ndarray,
                                                                                            np.ndarray]:
    """The program `AIR_LIFT_M` above the sheet (`knobs`: the plant's, NAME=VALUE): (the log's times [s], the true tip
    [m], its miss at the tracker's stamps against the lifted ideal, timed as `check` times it [mm])."""
    cmd = read_commanded_csv(ideal)
    p = cmd.values + np.array([0.0, 0.0, AIR_LIFT_M])
    run, _, log = run_dynamic_lab(cmd.t_s, p, scenario="nominal", knobs=parse_set_args(list(knobs)), seed=3,
                                  robot=resolve_robot(None, robot), corrector=corrector)
    tip = interp_rows(run.tracker.t_s, log.t_s, log.p_tip_sheet_m)
    ideal_tr = interp_rows(run.tracker.t_s, ideal_times(run.commanded.t_s, cmd.t_s), p)
    return log.t_s, log.p_tip_sheet_m, 1e3 * (tip - ideal_tr)


def step_answer(t_s: np.ndarray, tip_m: np.ndarray, plain_tip_m: np.ndarray) -> dict[str, float]:
    """The median time to 90 % [ms] and peak [-] of the true tip's answer to `StepCorrector`'s edges (an edge whose
    answer never reaches 90 % counts the whole window, `STEP_WINDOW_S`)."""
    delta = tip_m - plain_tip_m
    rise, peak = [], []
    for k in count():
        edge, axis, sign = _edge(k)
        if edge + STEP_WINDOW_S >= t_s[-1]:
            break
        inside = (t_s >= edge) & (t_s <= edge + STEP_WINDOW_S)
        base = float(np.interp(edge, t_s, delta[:, axis]))
        answer = sign * (delta[inside, axis] - base) / STEP_M
        reached = np.nonzero(answer >= 0.9)[0]
        rise.append(1e3 * float(t_s[inside][reached[0]] - edge) if reached.size else 1e3 * STEP_WINDOW_S)
        peak.append(float(np.max(answer)))
    return {"rise_90_ms": float(np.median(rise)), "peak": float(np.median(peak)), "edges": float(len(rise))}


def _part_floor(out: Path, robot: str, model: Path, part: str,
                plain: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, Any]:
    """One part's numbers (module docstring) but the step's; its nominal run in air (log times [s], true tip [m]) goes
    into `plain` by part, for the step's."""
    ideal = target_ideal(out, robot, part)
    row: dict[str, Any] = {"robot": robot, "part": part}
    misses = {}
    for name, plant_set in (("online", ()), ("perfect_sensor", PERFECT_SENSOR)):
        misses[name] = learned_online_miss(robot, model, ideal, ideal, out / f"{ideal.stem}_{name}", 3, "nominal",
                                           plant_set)
        row[name] = rms_mm(misses[name])
    spec = resolve_spec(model=model, robot=resolve_robot(None, robot), placement=None,
                        p_sheet_m=read_commanded_csv(ideal).values, cell=None)
    t_plain, tip_plain, air_nominal = _air_run(robot, ideal, None)
    plain[part] = (t_plain, tip_plain)
    row["air_nominal"] = rms_mm(air_nominal)
    settings = OnlineSettings(max_correction_mm=ONLINE_LIMIT_MM, max_rate_mm_s=ONLINE_RATE_MM_S)
    air_online = _air_run(robot, ideal, OnlineCompensator(spec, settings))[2]
    row["air_online"] = rms_mm(air_online)  # as lab_run's online runs
    if air_online.shape != misses["online"].shape:
        raise SystemExit(f"{robot} {part}: the runs on the sheet and in air have different tracker samples")
    row["online_less_air_online"] = rms_mm(misses["online"] - air_online)  # the oracle (module docstring)
    row["air_nominal_no_friction"] = rms_mm(_air_run(robot, ideal, None, NO_FRICTION)[2])
    return row


def robot_floor(out: Path, robot: str) -> list[dict[str, Any]]:
    """One robot's rows (module docstring), a part each."""
    model, _ = learn_cone(out, robot)
    plain: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    rows = [_part_floor(out, robot, model, part, plain) for part in PARTS]
    t_plain, tip_plain = plain["pyramid"]
    t_step, tip_step, _ = _air_run(robot, target_ideal(out, robot, "pyramid"), StepCorrector())
    if t_step.shape != t_plain.shape:
        raise SystemExit(f"{robot}: the runs with and without the steps have different logs")
    step = step_answer(t_step, tip_step, tip_plain)
    return [{**row, "step": step} for row in rows]


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table: true tip rms [mm]; the step's median time to 90 % [ms] and peak [-]."""
    lines = ["| robot | part | online, learned | the same, a perfect F/T sensor | in air, nominal | in air, online | "
             "in air, nominal, the joints' friction off | online less its in-air miss (oracle) | "
             "a correction's step: 90 % after / peak |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['robot']} | {r['part']} | {r['online']:.3f} mm | {r['perfect_sensor']:.3f} mm | "
                     f"{r['air_nominal']:.3f} mm | {r['air_online']:.3f} mm | {r['air_nominal_no_friction']:.3f} mm | "
                     f"{r['online_less_air_online']:.3f} mm | {r['step']['rise_90_ms']:.0f} ms / {r['step']['peak']:.2f} |")
    return "\n".join(lines) + "\n"


def robot_rows(out: Path, robot: str, plant_set: tuple[str, ...] = ()) -> list[dict[str, Any]]:
    """One robot's rows, said as they come; on the plant's default knobs only (its runs set knobs of their own)."""
    if plant_set:
        raise SystemExit(f"online_floor.py --plant-set {' '.join(plant_set)}: not taken here; expected none")
    rows = robot_floor(out, robot)
    print("\n".join(table(rows).splitlines()[2:]), flush=True)
    return rows


def main() -> None:
    per_robot_main(__doc__.splitlines()[0], "online_floor", robot_rows, table)


if __name__ == "__main__":
    main()
