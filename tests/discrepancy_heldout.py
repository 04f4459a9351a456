"""A held-out set of hidden effects for the discrepancy search: a development set and a test set, written apart.

Written independently of the search: this module imports neither `twin.sim.effects` nor the search's families
(nor the older catalogue, `tests/discrepancy_catalogue.py`, on which the search was first tuned). Every case
starts from a clean virtual-lab run and edits its DATA here:

- `inside` truths are effects of the library's families, in the test's own writing: a scalar force scale of
  the FE history, extra compliance of its own size in each travel direction, a true play operator (dead band)
  on joint 2 or 3, a longer tool, a force rise near the clamps (4-7 mm decay), a bias on two channels, a full
  off-diagonal cross-talk matrix, a pure force-clock delay, a tracker drift, a registration by a Rodrigues
  rotation about the sheet origin with a shift, and a uniform springback. The expected verdict is the family.
- `outside` truths are forms no family has; the expected verdict is `unexplained`. DEVELOPMENT kinds: a wrist
  joint (5) stiffness that differs with the sign of its torque, a tool-length error growing with the square of
  the stroke position, F/T saturation, an F/T temperature drift, tracker line-of-sight dropouts (held values),
  a tracker jump (re-registration) mid-run, F/T quantisation. TEST kinds (never looked at while choosing
  thresholds): a cyclic gear error against a joint's angle, one F/T channel frozen for seconds, a tracker
  scale error, stale (repeated) tracker samples, bursts of 8-15 Hz chatter, a compliance that grows with the
  force (deflection ~ |F| F), a first-order tracker lag.
- `clean` runs: the expected verdict is `none`.

Development and test sets differ in seeds (lab runs and draws) and in the outside kinds. The search's frozen
consistency thresholds (`twin.analysis.discrepancy.consistency`) were chosen on the development set only.

Make both confusion matrices: `.venv/bin/python -m tests.discrepancy_heldout --out heldout.json
--markdown docs/discrepancy.md`.
"""

from __future__ import annotations

import argparse
import json
import re
import time
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.discrepancy.search import find_discrepancy
from twin.lab.virtual import LabSettings, nominal_commanded, run_lab
from twin.process.description import Process
from twin.process.fe.load import default_force_history
from twin.runs.format import Run, Stream
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

INSIDE = (
    "force_scale", "direction_dependent_compliance", "lost_motion", "tool_length_offset", "clamp_proximity",
    "force_sensor_bias", "force_sensor_crosstalk", "stream_time_offset", "tracker_drift",
    "tracker_registration", "sheet_springback",
)
OUTSIDE = {
    "development": ("wrist_one_sided_stiffness", "tool_length_vs_stroke", "force_saturation",
                    "force_temperature_drift", "tracker_dropouts", "tracker_jump", "force_quantisation"),
    "test": ("gear_eccentricity", "force_channel_held", "tracker_scale", "tracker_stale_samples",
             "position_bursts", "force_squared_compliance", "tracker_lag"),
}
SEEDS = {"development": 20_000, "test": 30_000}  # case draws; the lab runs use their own (BASE_SEEDS)
BASE_SEEDS = {"development": 600, "test": 700}
BASES = 8  # clean lab runs per set, reused by its cases
PER_KIND = 2  # cases per inside family and per outside kind
CLEAN = 5
MULTIPLE_RANGE = (3.0, 30.0)  # magnitude: x the noise of the stream the effect shows most in
NOISE_LEVELS = (0.5, 1.0, 2.0)
NOISE = {"position": 2e-5, "force": 5.0, "profile": 2e-5}  # the lab's, at noise level 1 [m, N, m]


class Base:
    """One clean lab run, its noise-free twin replay, and the test's own replays of a changed command."""

    def __init__(self, seed: int) -> None:
        rng = np.random.default_rng(seed)
        self.noise_level = float(rng.choice(NOISE_LEVELS))
        self.sigma = {k: v * self.noise_level for k, v in NOISE.items()}
        t, p = nominal_commanded()
        settings = LabSettings(tracker_noise_m=self.sigma["position"], ft_noise_n=self.sigma["force"],
                               profile_noise_m=self.sigma["profile"])
        self.run, _ = run_lab(t, p, scenario="nominal", seed=seed, settings=settings)
        self.twin = Twin(TwinSpec())
        self.sim = self.twin.simulate(self.run.commanded.t_s, self.run.commanded.values)
        self.clean = self.observe(self.twin, self.sim)
        assert self.run.forces is not None and self.run.part_profile is not None
        self.measured = {"position": self.run.tracker.values, "force": self.run.forces.values,
                         "profile": np.asarray(self.run.part_profile[1], dtype=float)}

    def observe(self, twin: Twin, sim: Any, force_t: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Noise-free tracker, F/T and profile of a simulation at the run's sample times."""
        assert self.run.forces is not None and self.run.part_profile is not None
        t_f = np.clip(self.run.forces.t_s if force_t is None else force_t, sim.t_s[0], sim.t_s[-1])
        tip = np.column_stack([np.interp(self.run.tracker.t_s, sim.t_s, sim.p_sheet_m[:, i]) for i in range(3)])
        return {"position": tip, "force": twin.sensor_forces(sim, t_f),
                "profile": np.interp(self.run.part_profile[0], sim.formed_x_m, sim.formed_z_m)}

    def executed(self, dp_sheet_m: np.ndarray, twin: Twin | None = None) -> dict[str, np.ndarray]:
        """Change of every stream when the robot executes the command plus `dp_sheet_m` (the sheet answers)."""
        twin = twin or self.twin
        sim = twin.simulate(self.run.commanded.t_s, self.run.commanded.values + dp_sheet_m)
        return {k: v - self.clean[k] for k, v in self.observe(twin, sim).items()}

    def joint_to_tip(self, joint: int) -> np.ndarray:
        """Tip motion per radian of one joint at each commanded sample, sheet frame (n, 3) [m/rad]."""
        jac = self.twin.kinematics.jacobians(self.sim.q_ik)[:, :3, joint]
        return np.asarray(jac @ self.twin.R_base_sheet, dtype=float)

    def t(self, stream: str) -> np.ndarray:
        assert self.run.forces is not None
        return self.run.tracker.t_s if stream == "position" else self.run.forces.t_s


@lru_cache(maxsize=32)
def base(seed: int) -> Base:
    return Base(seed)


def _zero(b: Base) -> dict[str, np.ndarray]:
    return {k: np.zeros_like(v) for k, v in b.measured.items()}


def _rotation(rotvec: np.ndarray) -> np.ndarray:
    """Rodrigues' formula."""
    angle = float(np.linalg.norm(rotvec))
    k = rotvec / angle if angle > 0 else np.zeros(3)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def _play(q: np.ndarray, band: float) -> np.ndarray:
    """Play operator: the output follows q only once q has crossed a dead band of width `band` [rad]."""
    out = np.empty_like(q)
    out[0] = q[0]
    for i in range(1, q.size):
        out[i] = min(max(out[i - 1], q[i] - band / 2), q[i] + band / 2)
    return out - q


def _with_history(b: Base, factor: np.ndarray) -> dict[str, np.ndarray]:
    """Streams' change when the real forces are the FE history's times `factor` (per history sample and axis)."""
    history = default_force_history()
    twin = TwinSpec(process=Process(history=replace(history, f_sheet_n=history.f_sheet_n * factor))).build()
    return b.executed(np.zeros_like(b.run.commanded.values), twin)


def _segments(rng: np.random.Generator, t: np.ndarray, count: int, length_s: tuple[float, float]) -> np.ndarray:
    mask = np.zeros(t.size, bool)
    for start in rng.uniform(t[0] + 1.0, t[-1] - 1.0, count):
        mask |= (t >= start) & (t < start + rng.uniform(*length_s))
    return mask


def _hold(values: np.ndarray, mask: np.ndarray, columns: list[int]) -> np.ndarray:
    """Each masked sample repeats the last unmasked one, in `columns`."""
    out = values.copy()
    for i in np.flatnonzero(mask):
        if i > 0:
            out[i, columns] = out[i - 1, columns]
    return out - values


def change(b: Base, kind: str, rng: np.random.Generator, size: float) -> dict[str, np.ndarray]:
    """The change one hidden effect makes to the measured streams, at a magnitude ~ `size` (1: typical)."""
    out, n = _zero(b), len(b.run.commanded.values)
    sign = float(rng.choice([-1.0, 1.0]))
    if kind == "force_scale":  # one scalar factor
        return _with_history(b, np.full(3, 1.0 + sign * 0.05 * size))
    if kind == "direction_dependent_compliance":  # extra compliance, its own size in each direction
        c = size * 0.1 * rng.uniform(0.2, 1.0, 2) * rng.permutation([1.0, 0.0])
        extra = np.where(b.sim.direction[:, None] > 0, c[0], c[1]) * b.sim.deflection_sheet_m
        return b.executed(extra)
    if kind == "lost_motion":  # a true dead band on joint 2 or 3
        joint = int(rng.integers(1, 3))
        dq = _play(b.sim.q_ik[:, joint], size * 4e-4 * rng.uniform(0.5, 1.5))
        return b.executed(b.joint_to_tip(joint) * dq[:, None])
    if kind == "tool_length_offset":
        return b.executed(np.tile([0.0, 0.0, -sign * size * 1e-4], (n, 1)))
    if kind == "clamp_proximity":
        x = default_force_history().p_sheet_m[:, 0]
        rise = 1.0 + size * 0.2 * np.exp(-(np.max(np.abs(x)) - np.abs(x)) / rng.uniform(0.004, 0.007))
        return _with_history(b, rise[:, None])
    if kind == "force_sensor_bias":
        axes = rng.choice(3, 2, replace=False)
        out["force"][:, axes] += size * 10.0 * rng.uniform(0.5, 1.0, 2) * rng.choice([-1.0, 1.0], 2)
        return out
    if kind == "force_sensor_crosstalk":
        m = size * 0.01 * rng.uniform(-1.0, 1.0, (3, 3))
        np.fill_diagonal(m, 0.0)
        out["force"] = b.clean["force"] @ m.T
        return out
    if kind == "stream_time_offset":  # the F/T clock late by a pure delay
        late = b.observe(b.twin, b.sim, b.t("force") - sign * size * 0.01)
        out["force"] = late["force"] - b.clean["force"]
        return out
    if kind == "tracker_drift":
        v = rng.normal(size=3)
        out["position"] = np.outer(b.t("position"), size * 4e-6 * v / np.linalg.norm(v))
        return out
    if kind == "tracker_registration":
        rot = _rotation(rng.normal(size=3) * size * 5e-4)
        p = b.measured["position"]
        out["position"] = p @ rot.T - p + rng.normal(size=3) * size * 1e-5
        return out
    if kind == "sheet_springback":
        out["profile"] = -sign * size * 0.02 * b.clean["profile"]
        return out
    return _outside(b, kind, rng, size, out, sign)


def _outside(
    b: Base, kind: str, rng: np.random.Generator, size: float, out: dict[str, np.ndarray], sign: float
) -> dict[str, np.ndarray]:
    """The forms no family has."""
    force, pos = b.measured["force"], b.measured["position"]
    if kind == "wrist_one_sided_stiffness":  # joint 5 softer under a torque of one sign
        jac = b.joint_to_tip(4)
        f_base = b.sim.f_sheet_n @ b.twin.R_base_sheet.T
        tau = np.einsum("ni,ni->n", b.twin.kinematics.jacobians(b.sim.q_ik)[:, :3, 4], f_base)
        dq = size * 2e-6 * tau * np.where(sign * tau > 0, 1.0, 0.1)
        return b.executed(jac * dq[:, None])
    if kind == "tool_length_vs_stroke":
        x = b.run.commanded.values[:, 0]
        u = (x - x.mean()) / np.max(np.abs(x - x.mean()))
        return b.executed(np.column_stack([0 * u, 0 * u, sign * size * 1e-4 * u**2]))
    if kind == "force_saturation":  # every channel through a soft limit at 1-2.5 x its peak
        limit = np.max(np.abs(force), axis=0) * rng.uniform(1.0, 2.5)
        out["force"] = limit * np.tanh(force / limit) - force
        return out
    if kind == "force_temperature_drift":  # warm-up drift, time constant 3-10 s, random direction
        v = rng.normal(size=3)
        tau = rng.uniform(3.0, 10.0)
        out["force"] = np.outer(1.0 - np.exp(-b.t("force") / tau), size * 15.0 * v / np.linalg.norm(v))
        return out
    if kind == "tracker_dropouts":  # the tracker holds its last reading while the line of sight is lost
        out["position"] = _hold(pos, _segments(rng, b.t("position"), int(rng.integers(2, 5)), (0.2, 0.6)), [0, 1, 2])
        return out
    if kind == "tracker_jump":  # re-registered mid-run: a step
        v = rng.normal(size=3)
        step = b.t("position") > rng.uniform(0.3, 0.7) * b.t("position")[-1]
        out["position"] = np.outer(step, size * 2e-5 * v / np.linalg.norm(v))
        return out
    if kind == "force_quantisation":
        q = rng.uniform(3.0, 5.0) * b.sigma["force"]
        out["force"] = q * np.round(force / q) - force
        return out
    if kind == "gear_eccentricity":  # a cyclic error against the joint's angle, 2-4 cycles over its range
        joint = int(rng.integers(0, 3))
        q = b.sim.q_ik[:, joint]
        period = (np.ptp(q) + 1e-9) / rng.uniform(2.0, 4.0)
        dq = size * 5e-5 * np.sin(2 * np.pi * (q - q.min()) / period + rng.uniform(0, 2 * np.pi))
        return b.executed(b.joint_to_tip(joint) * dq[:, None])
    if kind == "force_channel_held":  # one F/T channel frozen for 2-5 s
        mask = _segments(rng, b.t("force"), 1, (2.0, 5.0))
        out["force"] = _hold(force, mask, [int(rng.choice([0, 2]))])
        return out
    if kind == "tracker_scale":  # the tracker's length scale off, about a point off the part
        centre = rng.normal(0.0, 0.05, 3)
        out["position"] = sign * size * 5e-4 * (pos - centre)
        return out
    if kind == "tracker_stale_samples":  # 10-25 % of the samples repeat the previous one
        mask = rng.random(len(pos)) < rng.uniform(0.1, 0.25)
        out["position"] = _hold(pos, mask & ~np.roll(mask, 1), [0, 1, 2])
        return out
    if kind == "position_bursts":  # chatter: 3-5 bursts of 0.3 s at 8-15 Hz on one axis
        t, axis = b.t("position"), int(rng.integers(0, 3))
        for start in rng.uniform(1.0, t[-1] - 1.0, int(rng.integers(3, 6))):
            inside = (t >= start) & (t < start + 0.3)
            envelope = np.sin(np.pi * (t[inside] - start) / 0.3) ** 2
            out["position"][inside, axis] += size * 1e-4 * envelope * np.sin(2 * np.pi * rng.uniform(8, 15) * t[inside])
        return out
    if kind == "force_squared_compliance":  # extra deflection ~ |F| F
        magnitude = np.linalg.norm(b.sim.f_sheet_n, axis=1)
        return b.executed(size * 0.1 * (magnitude / magnitude.mean())[:, None] * b.sim.deflection_sheet_m)
    if kind == "tracker_lag":  # a first-order filter of 30-120 ms on the tracker
        tau, p, dt = rng.uniform(0.03, 0.12), b.clean["position"], float(np.median(np.diff(b.t("position"))))
        lagged = p.copy()
        for i in range(1, len(p)):
            lagged[i] = lagged[i - 1] + dt / (tau + dt) * (p[i] - lagged[i - 1])
        out["position"] = lagged - p
        return out
    raise KeyError(kind)


SCALED = set(INSIDE) | {"wrist_one_sided_stiffness", "tool_length_vs_stroke", "force_temperature_drift",
                        "tracker_jump", "gear_eccentricity", "tracker_scale", "position_bursts",
                        "force_squared_compliance"}


def _telling(delta: dict[str, np.ndarray], sigma: dict[str, float]) -> float:
    """Largest per-axis rms of a change over its stream's noise."""
    return max(float(np.max(np.sqrt(np.mean(v.reshape(len(v), -1) ** 2, axis=0)))) / sigma[k]
               for k, v in delta.items())


@dataclass(frozen=True)
class Case:
    """One held-out case: what it hides and the verdict it should get."""

    split: str
    index: int
    kind: str  # an inside family, an outside kind, or "clean"
    group: str  # "inside", "outside", "clean"
    base_seed: int

    @property
    def expected(self) -> str:
        return {"inside": self.kind, "outside": "unexplained", "clean": "none"}[self.group]


def cases(split: str) -> list[Case]:
    """The cases of one set (`development` or `test`), in order."""
    kinds = [("inside", k) for k in INSIDE] + [("outside", k) for k in OUTSIDE[split]]
    plan = [g_k for g_k in kinds for _ in range(PER_KIND)] + [("clean", "clean")] * CLEAN
    return [Case(split, i, kind, group, BASE_SEEDS[split] + i % BASES) for i, (group, kind) in enumerate(plan)]


def make(case: Case) -> tuple[Run, dict[str, Any]]:
    """The case's run and what was hidden (magnitude as a multiple of the noise)."""
    b = base(case.base_seed)
    rng_seed = SEEDS[case.split] + case.index
    if case.group == "clean":
        return b.run, {"multiple": 0.0}
    multiple = float(np.exp(np.random.default_rng(rng_seed + 7).uniform(*np.log(MULTIPLE_RANGE))))
    delta = change(b, case.kind, np.random.default_rng(rng_seed), 1.0)
    if case.kind in SCALED:
        delta = change(b, case.kind, np.random.default_rng(rng_seed), multiple / max(_telling(delta, b.sigma), 1e-12))
    new = {k: b.measured[k] + delta[k] for k in b.measured}
    run = b.run
    assert run.forces is not None and run.part_profile is not None
    edited = Run(None, dict(run.meta), run.commanded, Stream(run.tracker.t_s, new["position"]),
                 Stream(run.forces.t_s, new["force"]), (run.part_profile[0], new["profile"]))
    return edited, {"multiple": _telling(delta, b.sigma)}


def evaluate(split: str, indices: list[int] | None = None) -> dict[str, Any]:
    """Run the search on the cases of one set (all, or those at `indices`): rows, confusion matrix, rates."""
    rows = []
    for case in cases(split):
        if indices is not None and case.index not in indices:
            continue
        run, hidden = make(case)
        began = time.perf_counter()
        result = find_discrepancy(run)
        rows.append({
            "index": case.index, "group": case.group, "kind": case.kind, "expected": case.expected,
            "verdict": result.verdict, "multiple": hidden["multiple"],
            "noise_level": base(case.base_seed).noise_level, "seconds": time.perf_counter() - began,
            "explained_fraction": result.explained_fraction, "consistency": result.consistency,
            "remainder": result.remainder["words"],
        })
    return {"split": split, "rows": rows, **rates(rows)}


def rates(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Confusion matrix (expected -> verdict, counts) and the three rates of issue #28."""
    matrix: dict[str, dict[str, int]] = {}
    for row in rows:
        cell = matrix.setdefault(row["expected"], {})
        cell[row["verdict"]] = cell.get(row["verdict"], 0) + 1

    def share(group: str) -> tuple[int, int]:
        mine = [r for r in rows if r["group"] == group]
        return sum(r["verdict"] == r["expected"] for r in mine), len(mine)

    def unchecked(row: dict[str, Any]) -> str:  # the verdict the search gave before the consistency check
        return str(row["consistency"]["family"]) if row["consistency"] else str(row["verdict"])

    outside = [r for r in rows if r["group"] == "outside"]
    return {"confusion": matrix, "inside_named_first": share("inside"), "outside_unexplained": share("outside"),
            "clean_none": share("clean"),
            "outside_unexplained_unchecked": (sum(unchecked(r) == "unexplained" for r in outside), len(outside)),
            "inside_named_first_unchecked": (
                sum(unchecked(r) == r["expected"] for r in rows if r["group"] == "inside"),
                sum(r["group"] == "inside" for r in rows)),
            "median_seconds": float(np.median([r["seconds"] for r in rows])) if rows else 0.0}


def chosen_threshold(development: dict[str, Any]) -> float:
    """STRUCTURE_SHARE as chosen on the development set: the geometric mean of the largest slow-structure share an
    inside form leaves and the smallest above it that an outside form leaves (among those a family was named for
    and whose evidence stream shows a gap), rounded to one significant digit."""
    def left(row: dict[str, Any]) -> float:
        return max((row["consistency"]["streams"][s]["structure_left"] for s in row["consistency"]["judged"]),
                   default=0.0)
    inside = max(left(r) for r in development["rows"] if r["group"] == "inside")
    outside = min(left(r) for r in development["rows"] if r["group"] == "outside" and r["consistency"]
                  and not r["consistency"]["no_gap"] and left(r) > inside)
    return float(f"{np.sqrt(inside * outside):.1g}")


def meets_goals(doc: dict[str, Any]) -> bool:
    """The goals on the test set: outside -> `unexplained` >= 90 %, inside named first >= 95 %, clean all `none`."""
    (o, no), (i, ni), (c, nc) = doc["outside_unexplained"], doc["inside_named_first"], doc["clean_none"]
    return o >= 0.9 * no and i >= 0.95 * ni and c == nc


def markdown(doc: dict[str, Any]) -> str:
    """One set's confusion matrix and rates as markdown (rows: expected; columns: the verdict)."""
    columns = sorted({v for row in doc["confusion"].values() for v in row}, key=lambda v: (v in ("unexplained", "none"), v))
    lines = [f"| {doc['split']}: expected \\ verdict | " + " | ".join(f"`{c}`" for c in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for expected, row in doc["confusion"].items():
        lines.append(f"| `{expected}` | " + " | ".join(str(row.get(c, "")) for c in columns) + " |")
    (o, no), (i, ni), (c, nc) = doc["outside_unexplained"], doc["inside_named_first"], doc["clean_none"]
    (ou, _), (iu, _) = doc["outside_unexplained_unchecked"], doc["inside_named_first_unchecked"]
    lines += ["", f"{doc['split']}: inside forms named first {i} / {ni}; outside forms `unexplained` {o} / {no}; "
                  f"clean runs `none` {c} / {nc}. Without the consistency check (the family the selection named): "
                  f"inside {iu} / {ni}, outside {ou} / {no}."]
    return "\n".join(lines)


BEGIN, END = "<!-- heldout:begin", "<!-- heldout:end -->"


def write_markdown(path: Path, docs: list[dict[str, Any]]) -> None:
    """Replace the generated block of `path` (between the heldout markers) with both sets' tables."""
    text = path.read_text()
    block = (f"{BEGIN} (generated by `.venv/bin/python -m tests.discrepancy_heldout --out heldout.json "
             f"--markdown {path.as_posix()}`; do not edit) -->\n" + "\n\n".join(markdown(d) for d in docs) + f"\n{END}")
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
    path.write_text(pattern.sub(lambda _: block, text) if pattern.search(text) else text.rstrip() + "\n\n" + block + "\n")


def main(argv: list[str] | None = None) -> int:
    """`python -m tests.discrepancy_heldout --out heldout.json [--markdown docs/discrepancy.md] [--split test]`."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--markdown", default=None, help="a markdown file whose generated block is replaced")
    parser.add_argument("--split", choices=("development", "test", "both"), default="both")
    args = parser.parse_args(argv)
    splits = ("development", "test") if args.split == "both" else (args.split,)
    docs = [evaluate(s) for s in splits]
    for doc in docs:
        print(f"{doc['split']}: median search {doc['median_seconds']:.2f} s")
    Path(args.out).write_text(json.dumps(docs, indent=1, default=float))
    for doc in docs:
        print(markdown(doc) + "\n")
    if args.markdown:
        write_markdown(Path(args.markdown), docs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
