"""A catalogue of hidden effects the discrepancy search has never seen in this form, and its confusion matrix.

Every case starts from a clean virtual-lab run (its own seed and noise level) and edits the DATA here, in the
test, never through `twin.sim.effects` or the search's families:

- robot-side truths are made by replaying the run's command on test-built twins (a per-axis force scale of
  the FE history, an extra deflection c x (the clean deflection) executed in one travel direction only, a joint's lost motion pushed into the command
  with a 3 mm take-up, a longer tool, a force rise near the clamps with its own decay length) and adding
  the difference to the clean run's streams, so the lab's noise stays as it was;
- sensor truths are edits of the streams (bias, cross-talk, clock offset with rate skew from the twin's
  force replayed at shifted times, a drift and a finite registration rotation in random directions, a
  springback that varies along the part);
- made-up effects no family has (tracker or force oscillations at 0.7-3 Hz) must come out `unexplained`;
- runs of the dynamic MuJoCo plant (neutral, and with backlash on joint 2 or joint 1) are reported apart.

Magnitudes are drawn log-uniformly between 3 and 30 times the per-axis noise of the stream the effect shows
most in; two and three effects are combined; noise levels are 0.5, 1 and 2 x the lab's.

Make the confusion matrix: `.venv/bin/python -m tests.discrepancy_catalogue --out confusion.json`.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from twin.analysis.discrepancy.search import find_discrepancy
from twin.lab.virtual import LabSettings, nominal_commanded, run_lab
from twin.process.description import Process
from twin.process.fe.load import ForceHistory, default_force_history
from twin.process.toolpath.groove import label_passes
from twin.runs.format import Run, Stream
from twin.sim.quasi_static import PASS_DEADBAND_M, Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec

SINGLE = (
    "force_scale", "direction_dependent_compliance", "lost_motion", "tool_length_offset", "clamp_proximity",
    "force_sensor_bias", "force_sensor_crosstalk", "stream_time_offset", "tracker_drift",
    "tracker_registration", "sheet_springback",
)
MADE_UP = ("tracker_oscillation", "force_oscillation")
NOISE_LEVELS = (0.5, 1.0, 2.0)
MULTIPLE_RANGE = (3.0, 30.0)
TAKEUP_M = 0.003  # the test's lost motion takes up over 3 mm (the library assumes 2 mm)


@dataclass
class Truth:
    """What a case hides: families (largest first), their multiples of the noise, the made-up kind."""

    families: list[str]
    multiples: list[float]
    kind: str  # "single", "combo", "made_up", "clean"
    noise_level: float
    made_up: dict[str, Any] = field(default_factory=dict)

    @property
    def expected(self) -> str:
        """The verdict the case should get (`none`, `unexplained`, or the largest hidden family)."""
        if self.kind == "clean":
            return "none"
        if self.kind == "made_up":
            return "unexplained"
        if self.kind == "dynamic":
            return "dynamic plant" + (" + " + ", ".join(self.made_up["knobs"]) if self.made_up["knobs"] else "")
        return self.families[0]


class _Base:
    """The clean lab run of one case and the test's own twin replays of its command."""

    def __init__(self, seed: int, noise_level: float) -> None:
        t, p = nominal_commanded()
        settings = LabSettings(tracker_noise_m=2e-5 * noise_level, ft_noise_n=5.0 * noise_level,
                               profile_noise_m=2e-5 * noise_level)
        self.run, _ = run_lab(t, p, scenario="nominal", seed=seed, settings=settings)
        self.sigma = {"position": 2e-5 * noise_level, "force": 5.0 * noise_level, "profile": 2e-5 * noise_level}
        self.twin = Twin(TwinSpec())
        self.sim = self.twin.simulate(self.run.commanded.t_s, self.run.commanded.values)
        self.clean = self.streams(self.twin, self.sim)

    def streams(self, twin: Twin, sim: SimResult, force_times: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Noise-free tracker, force and profile of a replay at the run's sample times."""
        assert self.run.forces is not None and self.run.part_profile is not None
        t_f = self.run.forces.t_s if force_times is None else force_times
        tip = np.column_stack([np.interp(self.run.tracker.t_s, sim.t_s, sim.p_sheet_m[:, i]) for i in range(3)])
        profile = np.interp(self.run.part_profile[0], sim.formed_x_m, sim.formed_z_m)
        return {"position": tip, "force": twin.sensor_forces(sim, np.clip(t_f, sim.t_s[0], sim.t_s[-1])),
                "profile": profile}

    def replay(self, twin: Twin, p_cmd: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Change of the streams when the command (as the robot really executes it) runs on `twin`."""
        cmd = self.run.commanded.values if p_cmd is None else p_cmd
        sim = twin.simulate(self.run.commanded.t_s, cmd)
        return {k: v - self.clean[k] for k, v in self.streams(twin, sim).items()}

    def level(self) -> np.ndarray:
        """+/-1 with the travel direction, ramped over TAKEUP_M after each reversal (commanded samples)."""
        x = self.run.commanded.values[:, 0]
        _, direction = label_passes(x, deadband_m=PASS_DEADBAND_M)
        level = direction.astype(float).copy()
        changes = np.flatnonzero(np.diff(direction) != 0)
        first = int(changes[0]) + 1 if changes.size else len(x)
        travelled = 0.0
        for i in range(1, len(x)):
            travelled = 0.0 if direction[i] != direction[i - 1] else travelled + abs(x[i] - x[i - 1])
            if i >= first and travelled < TAKEUP_M:
                level[i] = direction[i] * (2.0 * travelled / TAKEUP_M - 1.0)
        return level


def _twin_of(history: ForceHistory) -> Twin:
    """The default twin with its field fitted to the test's own FE history."""
    return TwinSpec(process=Process(history=history)).build()


def _telling_multiple(delta: dict[str, np.ndarray], sigma: dict[str, float]) -> float:
    """Largest per-axis rms of a change over the noise sigma of its stream."""
    out = 0.0
    for k, v in delta.items():
        v2 = v.reshape(len(v), -1)
        out = max(out, float(np.max(np.sqrt(np.mean(v2**2, axis=0)))) / sigma[k])
    return out


def _edit(
    base: _Base, name: str, rng: np.random.Generator, size: float, info: dict[str, Any] | None = None
) -> dict[str, np.ndarray]:
    """The change one hidden effect makes, at a magnitude proportional to `size` (1: a typical one).

    `info` receives the stream, axis and frequency of a made-up oscillation.
    """
    info = {} if info is None else info
    run, zero = base.run, {k: np.zeros_like(v) for k, v in base.clean.items()}
    assert run.forces is not None and run.part_profile is not None
    history = default_force_history()
    if name == "force_scale":  # per axis, x and z differ
        k = 1.0 + size * 0.1 * rng.uniform(0.5, 1.5, 3) * rng.choice([-1.0, 1.0])
        return base.replay(_twin_of(replace(history, f_sheet_n=history.f_sheet_n * k)))
    if name == "direction_dependent_compliance":  # softer when backing (or forward), by its own ratio
        c = size * 0.15 * rng.uniform(0.5, 1.5)
        soft = (base.sim.direction < 0) == (rng.random() < 0.7)
        # the extra deflection c C f of the soft passes, executed by the robot (the sheet answers it)
        extra = c * base.sim.deflection_sheet_m * soft[:, None]
        return base.replay(Twin(TwinSpec()), run.commanded.values + extra)
    if name == "lost_motion":  # one joint of 1-3, pushed into the executed command
        joint = int(rng.integers(0, 3))
        b = size * 2e-4 * rng.uniform(0.5, 1.5) * rng.choice([-1.0, 1.0])
        jac = base.twin.kinematics.jacobians(base.sim.q_ik)[:, :3, joint]
        return base.replay(Twin(TwinSpec()), run.commanded.values + jac * (b * base.level())[:, None])
    if name == "tool_length_offset":
        length = size * 2e-4 * rng.uniform(0.5, 1.5) * rng.choice([-1.0, 1.0])
        return base.replay(Twin(TwinSpec()), run.commanded.values + np.array([0.0, 0.0, -length]))
    if name == "clamp_proximity":  # force rise near the clamped ends, decay 3-8 mm
        decay = rng.uniform(0.003, 0.008)
        a = size * 0.3 * rng.uniform(0.5, 1.5)
        x = history.p_sheet_m[:, 0]
        w = 1.0 + a * np.exp(-(np.max(np.abs(x)) - np.abs(x)) / decay)
        return base.replay(_twin_of(replace(history, f_sheet_n=history.f_sheet_n * w[:, None])))
    if name == "force_sensor_bias":
        return {**zero, "force": np.broadcast_to(size * 15.0 * rng.normal(0.0, 1.0, 3), run.forces.values.shape)}
    if name == "force_sensor_crosstalk":
        m = np.zeros((3, 3))
        m[0, 2], m[2, 0] = size * 0.02 * rng.normal(0.0, 1.0, 2)
        return {**zero, "force": base.clean["force"] @ m.T}
    if name == "stream_time_offset":
        tau, skew = size * 0.02 * rng.uniform(-1.5, 1.5), size * 1e-3 * rng.uniform(-1.0, 1.0)
        shifted = run.forces.t_s - tau - skew * run.forces.t_s
        return {**zero, "force": base.streams(base.twin, base.sim, shifted)["force"] - base.clean["force"]}
    if name == "tracker_drift":  # any direction
        v = rng.normal(0.0, 1.0, 3)
        v *= size * 6e-6 / np.linalg.norm(v)
        return {**zero, "position": np.outer(run.tracker.t_s, v)}
    if name == "tracker_registration":  # a finite rotation about a point off the part, and a shift
        rot = Rotation.from_rotvec(rng.normal(0.0, 1.0, 3) * size * 1e-3)
        pivot = rng.normal(0.0, 0.05, 3)
        p = run.tracker.values
        return {**zero, "position": rot.apply(p - pivot) + pivot - p + rng.normal(0.0, size * 2e-5, 3)}
    if name == "sheet_springback":  # recovers more at one end than the other
        x = run.part_profile[0]
        s = size * 0.03 * rng.uniform(0.5, 1.5) * (1.0 + 0.3 * x / np.max(np.abs(x)))
        return {**zero, "profile": -s * base.clean["profile"]}
    if name == "tracker_oscillation":
        axis, freq = int(rng.integers(0, 3)), float(rng.uniform(0.7, 3.0))
        info.update(stream="position", axis="xyz"[axis], frequency_hz=freq)
        pos = np.zeros_like(run.tracker.values)
        pos[:, axis] = size * 3e-5 * np.sin(2 * np.pi * freq * run.tracker.t_s + rng.uniform(0, 6.28))
        return {**zero, "position": pos}
    if name == "force_oscillation":
        axis, freq = int(rng.choice([0, 2])), float(rng.uniform(0.7, 3.0))
        info.update(stream="force", axis="xyz"[axis], frequency_hz=freq)
        force = np.zeros_like(run.forces.values)
        force[:, axis] = size * 8.0 * np.sin(2 * np.pi * freq * run.forces.t_s + rng.uniform(0, 6.28))
        return {**zero, "force": force}
    raise KeyError(name)


def _scaled(
    base: _Base, name: str, seed: int, multiple: float, info: dict[str, Any]
) -> dict[str, np.ndarray]:
    """The effect at `multiple` x the noise in its most telling stream (one rescaled second draw)."""
    first = _edit(base, name, np.random.default_rng(seed), 1.0)
    size = multiple / max(_telling_multiple(first, base.sigma), 1e-9)
    return _edit(base, name, np.random.default_rng(seed), size, info)


def _apply(run: Run, delta: dict[str, np.ndarray]) -> Run:
    assert run.forces is not None and run.part_profile is not None
    return Run(None, dict(run.meta), run.commanded, Stream(run.tracker.t_s, run.tracker.values + delta["position"]),
               Stream(run.forces.t_s, run.forces.values + delta["force"]),
               (run.part_profile[0], run.part_profile[1] + delta["profile"]))


def make_case(seed: int) -> tuple[Run, Truth]:
    """Case `seed`: 0..43 single families (4 each), 44..55 combinations of 2-3, 56..63 made-up effects,
    64 and above clean runs. Every draw comes from `seed`."""
    rng = np.random.default_rng(10_000 + seed)
    noise_level = float(rng.choice(NOISE_LEVELS))
    base = _Base(seed=500 + seed, noise_level=noise_level)
    if seed >= 64:
        return base.run, Truth([], [], "clean", noise_level)
    if seed < 44:
        kind, names = "single", [SINGLE[seed % len(SINGLE)]]
    elif seed < 56:
        kind = "combo"
        names = list(rng.choice(SINGLE, size=2 + int(seed % 3 == 0), replace=False))
    else:
        kind, names = "made_up", [MADE_UP[seed % 2]]
    multiples = sorted(np.exp(rng.uniform(*np.log(MULTIPLE_RANGE), len(names))), reverse=True)
    total = {k: np.zeros_like(v) for k, v in base.clean.items()}
    info: dict[str, Any] = {}
    for name, multiple in zip(names, multiples, strict=True):
        for k, v in _scaled(base, name, seed * 31 + len(name), float(multiple), info).items():
            total[k] = total[k] + v
    return _apply(base.run, total), Truth(names, [float(m) for m in multiples], kind, noise_level, info)


# Dynamic-plant runs (`twin.lab.dynamic`, all knobs neutral but the ones set): the plant's servo dynamics
# are outside the twin, so the right answer is `unexplained` with a signature; backlash is their hidden effect.
# joint 3, not joint 2: gravity keeps joint 2's gear loaded on one side all along the groove (tests/test_dynamic_lab.py)
DYNAMIC_CASES: tuple[tuple[str, ...], ...] = ((), ("backlash_j3_mrad=0.4",), ("backlash_j1_mrad=0.4",))


def make_dynamic_case(index: int) -> tuple[Run, Truth]:
    """Dynamic-plant case `index` of DYNAMIC_CASES (seed 900 + index)."""
    from twin.lab.dynamic.knobs import parse_set_args
    from twin.lab.dynamic.run import run_dynamic_lab

    t, p = nominal_commanded()
    sets = DYNAMIC_CASES[index]
    run, _, _ = run_dynamic_lab(t, p, scenario="nominal", knobs=parse_set_args(list(sets), neutral=True),
                                seed=900 + index)
    # the neutral run hides nothing but the plant's dynamics: its signature must place them at the reversals
    info = {"knobs": list(sets), "transient_at_reversals": not sets}
    return run, Truth(["lost_motion"] if sets else [], [], "dynamic", 1.0, info)


def evaluate(seeds: list[int], dynamic: int = 0) -> dict[str, Any]:
    """Run the search on each case (and the first `dynamic` dynamic-plant cases, reported apart from the
    rates); rows, the confusion matrix (expected -> verdict) and the rates."""
    rows = []
    cases = [(seed, lambda s=seed: make_case(s)) for seed in seeds]
    cases += [(1000 + i, lambda i=i: make_dynamic_case(i)) for i in range(dynamic)]
    for seed, make in cases:
        run, truth = make()
        began = time.perf_counter()
        result = find_discrepancy(run)
        seconds = time.perf_counter() - began
        before, after = result.gap_before, result.gap_after
        shrink = {k: after[k] / before[k] for k in before if before[k] > 0 and np.isfinite(before[k])}
        rows.append({
            "seed": seed, "kind": truth.kind, "truth": truth.families, "multiples": truth.multiples,
            "noise_level": truth.noise_level, "expected": truth.expected, "verdict": result.verdict,
            "found": list(result.found), "explained_fraction": result.explained_fraction,
            "gap_ratio": shrink, "remainder": result.remainder["words"], "seconds": seconds,
            "made_up": truth.made_up, "signature_describes": describes(result.remainder, truth.made_up),
        })
        print(json.dumps(rows[-1]), flush=True)
    return {"rows": rows, **confusion(rows)}


def describes(remainder: dict[str, Any], made_up: dict[str, Any]) -> bool | None:
    """Whether the signature names a made-up oscillation (its stream and axis, its frequency within 10 %), or for
    a neutral dynamic-plant run, a transient at the reversals on the position axes it shows in."""
    if made_up.get("transient_at_reversals"):
        position = [a for a in remainder["axes"] if a["stream"] == "position"]
        return bool(position) and all("transient at the" in a["words"] for a in position)
    if "stream" not in made_up:
        return None
    return any(
        a["stream"] == made_up["stream"] and a["axis"] == made_up["axis"] and a.get("peak_share", 0.0) >= 0.5
        and abs(a["peak_hz"] - made_up["frequency_hz"]) <= 0.1 * made_up["frequency_hz"]
        and "oscillation" in a["words"]
        for a in remainder["axes"]
    )


def right_first(row: dict[str, Any]) -> bool:
    """Whether the first thing said is right: the hidden family (any of a combination's), none, unexplained."""
    if row["kind"] in ("single", "combo"):
        return row["verdict"] in row["truth"]
    if row["kind"] == "dynamic":
        return row["verdict"] in row["truth"] or row["verdict"] == "unexplained"
    return bool(row["verdict"] == row["expected"])


def confusion(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Confusion matrix (rows: expected, a combination under the hidden family named if any) and rates."""
    matrix: dict[str, dict[str, int]] = {}
    for row in rows:
        expected = row["verdict"] if row["kind"] == "combo" and row["verdict"] in row["truth"] else row["expected"]
        matrix.setdefault(expected, {}).setdefault(row["verdict"], 0)
        matrix[expected][row["verdict"]] += 1
    effect_rows = [r for r in rows if r["kind"] in ("single", "combo")]
    named = [r for r in effect_rows if right_first(r)]
    return {
        "confusion": matrix,
        "named_first_rate": len(named) / max(len(effect_rows), 1),
        "clean_none": sum(r["verdict"] == "none" for r in rows if r["kind"] == "clean"),
        "clean_runs": sum(r["kind"] == "clean" for r in rows),
        "made_up_unexplained": sum(r["verdict"] == "unexplained" for r in rows if r["kind"] == "made_up"),
        "made_up_runs": sum(r["kind"] == "made_up" for r in rows),
        "median_seconds": float(np.median([r["seconds"] for r in rows])) if rows else 0.0,
        "max_seconds": float(max((r["seconds"] for r in rows), default=0.0)),
        "min_named_explained_fraction": float(min((r["explained_fraction"] for r in named), default=0.0)),
        "named_explained_at_least_70": sum(r["explained_fraction"] >= 0.7 for r in named),
        "named_runs": len(named),
        "made_up_described": sum(bool(r["signature_describes"]) for r in rows if r["kind"] == "made_up"),
    }


def main(argv: list[str] | None = None) -> int:
    """`python -m tests.discrepancy_catalogue --out confusion.json [--cases 64 --clean 20]`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--cases", type=int, default=64)
    parser.add_argument("--clean", type=int, default=20)
    parser.add_argument("--dynamic", type=int, default=len(DYNAMIC_CASES), help="dynamic-plant cases (0-3)")
    args = parser.parse_args(argv)
    doc = evaluate(list(range(args.cases)) + list(range(64, 64 + args.clean)), args.dynamic)
    with open(args.out, "w") as handle:
        json.dump(doc, handle, indent=1, default=float)
    print(json.dumps({k: v for k, v in doc.items() if k != "rows"}, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
