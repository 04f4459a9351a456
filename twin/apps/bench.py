"""Benchmarks of the twin (`tx200-twin bench`): wall times of the main workflows on one nominal lab run.

Everything runs in one process. Each timed step is repeated and the median reported (the first call of a
step also warms caches, so it is kept only as one of the repeats). The headline numbers:

* `replay_realtime_factor`: simulated machining time of the run divided by the wall time of
  `twin.analysis.replay.replay(run, twin=...)` with a ready `Twin` (`replay_warm_s`). `replay_s` is the same with a
  fresh `Twin` (model compilation and field fit included).
* `twin_over_mujoco_floor`: `replay_warm_s` over the wall time of the MuJoCo calls a replay that asks MuJoCo
  at every Newton iteration makes (`twin.apps.bench_speed.mujoco_call_floor`). The compiled loop
  (`twin.sim.compiled`) evaluates the chain from the model's own parameters instead, so the replay can fall
  below 1; `simulate_python_loop_s` is the Python loop that does call MuJoCo per iteration, for reference.
* `twin_over_analytic`: `replay_warm_s` over `analytic_replay_s`, the same run replayed with the linear model
  d = J K_q^-1 J^T f(p_cmd + d) (`analytic_replay`): the physical floor of any compliant-robot replay.
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from twin.apps.analytic_replay import AnalyticReplay, analytic_replay
from twin.apps.bench_cli import cli_ratios
from twin.apps.bench_place import place_cost
from twin.apps.bench_speed import cli_startup, isf_cone_benchmarks, mujoco_call_floor, path_growth
from twin.apps.machine import machine_info
from twin.apps.sweep import run_sweep
from twin.base.jobs import usable_cores
from twin.errors import InputError
from twin.process.toolpath.groove import ToolPath, label_passes
from twin.runs.format import Run
from twin.sim.quasi_static import PASS_DEADBAND_M, Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec

__all__ = ["AnalyticReplay", "analytic_replay", "format_table", "machine_info", "run_benchmarks", "time_call"]

def time_call(fn: Callable[[], Any], repeats: int) -> tuple[float, list[float]]:
    """Median wall time of `repeats` calls of `fn` [s], and every time [s]."""
    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), times


def run_benchmarks(
    repeats: int = 5, samples: int | None = None, *, seed: int = 0, sweep_draws: int | None = None
) -> dict[str, Any]:
    """Time the workflows on one nominal lab run.

    Args:
        repeats: Repeats of each timed step (median reported); the discrepancy search runs once.
        samples: Keep only the first `samples` commanded samples of the groove (a small smoke workload);
            None for the whole run.
        seed: Seed of the lab's noise.
        sweep_draws: Draws of the Monte Carlo sweep timed on every core; default 8 per core.

    Returns:
        The JSON payload: times [s], factors [-], `machine`, `workload`.
    """
    from twin.lab.virtual import nominal_commanded

    t_s, p_cmd = nominal_commanded()
    if samples is not None:
        if samples < 2:
            raise InputError(f"samples = {samples!r}: expected >= 2")
        t_s, p_cmd = t_s[:samples], p_cmd[:samples]
    duration_s = float(t_s[-1] - t_s[0])
    out: dict[str, Any] = {"workload": {"commanded_samples": len(t_s), "machining_s": duration_s, "repeats": repeats}}
    run = _bench_lab(out, t_s, p_cmd, seed, repeats)
    twin = TwinSpec().build()
    sim = _bench_replay(out, run, twin, t_s, p_cmd, repeats, duration_s)
    sweep = run_sweep(
        sweep_draws or 8 * usable_cores(), seed=seed,
        path=ToolPath(t_s=t_s, p_sheet_m=p_cmd, pass_index=sim.pass_index, direction=sim.direction),
    )
    out["sweep_replays_per_s_per_core"] = sweep.replays_per_s_per_core
    out["sweep"] = {"draws": len(sweep.rms_m), "workers": sweep.workers, "wall_s": sweep.wall_s}
    linear = analytic_replay(run, twin=twin)
    out["analytic_vs_twin_max_mm"] = 1e3 * float(np.max(np.linalg.norm(linear.p_sheet_m - sim.p_sheet_m, axis=1)))
    _bench_analysis(out, run, twin, t_s, p_cmd, repeats)
    _bench_force_models(out, t_s, p_cmd, repeats)
    _bench_dynamic(out, t_s, p_cmd, seed, repeats, (twin, sim))
    _bench_discrepancy(out, run, t_s, p_cmd, seed)
    _bench_gcode(out, repeats, smoke=samples is not None)
    out["cli_startup"] = cli_startup(max(3, repeats) if samples is None else repeats)
    out["cli_help_over_numpy"] = out["cli_startup"]["help_over_numpy"]
    # `compensate --method twin` and `place` over `replay` of a cone, each a fresh CLI process, after fixed costs
    cone_m = (0.16, 0.04) if samples is None else (0.02, 0.002)
    out.update(cli_ratios(*cone_m, min(repeats, 3), smoke=samples is not None))
    out.update(isf_cone_benchmarks(repeats, smoke=samples is not None))  # cones on the ISF model, Ø 40 to 160 mm
    # the placement search of a cone on the ISF model: Ø 80 mm, 20 mm deep (a Ø 20 mm, 2 mm deep one for a smoke run)
    width_m, depth_m = (80e-3, 20e-3) if samples is None else (20e-3, 2e-3)
    out["placement"] = place_cost(width_m, depth_m, min(repeats, 3), candidates=512 if samples is None else 64)
    out["place_over_simulation"] = out["placement"]["over_simulation"]
    out["place_best_over_default_rms"] = out["placement"]["best_over_default_rms"]
    from twin.apps.bench_online import online_benchmarks  # the online compensator's real-time figures

    out.update(online_benchmarks(smoke=samples is not None))
    out["machine"] = machine_info()
    return out


def _bench_lab(out: dict[str, Any], t_s: np.ndarray, p_cmd: np.ndarray, seed: int, repeats: int) -> Run:
    """`lab_run_s`: a quasi-static lab run written to disk; returns the run read back."""
    from twin.lab.virtual import run_lab
    from twin.runs.read import read_run
    from twin.runs.write import write_run

    with tempfile.TemporaryDirectory(prefix="tx200-bench-") as tmp:
        directory = Path(tmp) / "run"

        def lab() -> None:
            lab_run, truth = run_lab(t_s, p_cmd, scenario="nominal", seed=seed)
            write_run(directory, lab_run, truth=truth, overwrite=True)

        out["lab_run_s"], _ = time_call(lab, repeats)
        return read_run(directory)


def _bench_replay(
    out: dict[str, Any], run: Run, twin: Twin, t_s: np.ndarray, p_cmd: np.ndarray, repeats: int, duration_s: float
) -> SimResult:
    """Replay (fresh and ready twin), the compiled and Python loops, IK, the analytic and MuJoCo-call floors."""
    from twin.analysis.replay import replay

    out["replay_s"], _ = time_call(lambda: replay(run), repeats)
    out["replay_warm_s"], warm_all = time_call(lambda: replay(run, twin=twin), repeats)
    out["simulate_warm_s"], _ = time_call(lambda: twin.simulate(t_s, p_cmd), repeats)
    # the reference: the same loop in Python, MuJoCo called per Newton iteration (twin.sim.compiled)
    twin.use_compiled_loop = False
    try:
        out["simulate_python_loop_s"], _ = time_call(lambda: twin.simulate(t_s, p_cmd), max(1, repeats // 2))
    finally:
        twin.use_compiled_loop = True
    out["python_over_compiled_loop"] = out["simulate_python_loop_s"] / out["simulate_warm_s"]
    out["ik_path_s"], _ = time_call(lambda: twin.kinematics.ik_path(p_cmd + twin.p_base_sheet_origin), repeats)
    out["analytic_replay_s"], _ = time_call(lambda: analytic_replay(run, twin=twin), repeats)
    out["replay_realtime_factor"] = duration_s / out["replay_warm_s"]
    out["replay_realtime_factor_basis"] = "replay_warm_s (a ready Twin passed as twin=)"
    out["twin_over_analytic"] = out["replay_warm_s"] / out["analytic_replay_s"]
    out["replay_fresh_realtime_factor"] = duration_s / out["replay_s"]
    sim = replay(run, twin=twin).sim
    out["mujoco_floor_s"] = mujoco_call_floor(twin, sim, run.forces.t_s if run.forces is not None else None)
    out["twin_over_mujoco_floor"] = out["replay_warm_s"] / out["mujoco_floor_s"]
    out["newton_iterations_per_sample"] = float(np.mean(sim.iterations))
    out["path_growth"] = path_growth(twin, t_s, p_cmd)
    out["replay_warm_all_s"] = warm_all
    return sim


def _bench_analysis(
    out: dict[str, Any], run: Run, twin: Twin, t_s: np.ndarray, p_cmd: np.ndarray, repeats: int
) -> None:
    """Method 2 and the twin compensation on the run."""
    from twin.analysis.compensate import compensate_twin
    from twin.analysis.identify.method2 import method2

    out["identify_method2_s"], _ = time_call(lambda: method2(run), repeats)
    out["compensate_twin_s"], _ = time_call(lambda: compensate_twin(t_s, p_cmd, twin), repeats)


def _bench_force_models(out: dict[str, Any], t_s: np.ndarray, p_cmd: np.ndarray, repeats: int) -> None:
    """The table field and the ISF height-map field along the path, and a cone on the ISF model (any part)."""
    from twin.process.description import Process
    from twin.process.fe.load import default_force_history
    from twin.process.force.isf import IsfForceField
    from twin.process.force.table import SheetForceField
    from twin.process.toolpath.shapes import PartSpec, part_path

    pass_index, direction = label_passes(p_cmd[:, 0], deadband_m=PASS_DEADBAND_M)
    path = ToolPath(t_s=t_s, p_sheet_m=p_cmd, pass_index=pass_index, direction=direction)
    field = SheetForceField(default_force_history())
    out["force_field_eval_s"], _ = time_call(lambda: field.rigid_forces(path), repeats)
    isf_field = IsfForceField()
    out["isf_field_eval_s"], _ = time_call(lambda: isf_field.rigid_forces(path), repeats)
    out["isf_over_table_field"] = out["isf_field_eval_s"] / out["force_field_eval_s"]
    # a 45° cone, 4 mm deep, 40 mm across, on the ISF model, compiled and in Python
    cone = part_path(PartSpec(depth_m=4e-3, top_half_width_m=20e-3))
    cone_twin = TwinSpec(process=Process(force_model="isf")).build()
    cone_q = cone_twin.simulate(cone.t_s, cone.p_sheet_m).q_ik
    out["cone_simulate_s"], _ = time_call(lambda: cone_twin.simulate(cone.t_s, cone.p_sheet_m, q_ik=cone_q), repeats)
    cone_twin.use_compiled_loop = False
    try:
        out["cone_simulate_python_loop_s"], _ = time_call(
            lambda: cone_twin.simulate(cone.t_s, cone.p_sheet_m, q_ik=cone_q), max(1, repeats // 2)
        )
    finally:
        cone_twin.use_compiled_loop = True
    out["cone_realtime_factor"] = float(cone.t_s[-1] - cone.t_s[0]) / out["cone_simulate_s"]


def _bench_dynamic(out: dict[str, Any], t_s: np.ndarray, p_cmd: np.ndarray, seed: int, repeats: int,
                   replayed: tuple[Twin, SimResult]) -> None:
    """The dynamic lab plant (mj_step at 1 kHz with its sensor chain) on the same command; the dynamic twin's step of
    the replayed command under a servo (one `mj_step` per millisecond), over its quasi-static `Twin.simulate`."""
    from twin.lab.dynamic.knobs import Knobs as DynamicKnobs
    from twin.lab.dynamic.run import run_dynamic_lab
    from twin.sim.dynamic import DynamicTwin, ServoModel

    out["dynamic_lab_run_s"], _ = time_call(
        lambda: run_dynamic_lab(t_s, p_cmd, scenario="nominal", knobs=DynamicKnobs(), seed=seed), repeats
    )
    dynamic = DynamicTwin(*replayed)
    out["dynamic_twin_step_s"], _ = time_call(lambda: dynamic.simulate(ServoModel()), repeats)
    out["dynamic_twin_over_simulate"] = out["dynamic_twin_step_s"] / out["simulate_warm_s"]


def _bench_discrepancy(out: dict[str, Any], run: Run, t_s: np.ndarray, p_cmd: np.ndarray, seed: int) -> None:
    """The discrepancy workflow on a run with two hidden effects (the thesis story), a clean run, a run no
    family explains (every family fitted in every round) and a run edited by hand in a form the lab does not
    make (a drift along x only and an fz bias)."""
    from twin.analysis.discrepancy.families import FAMILIES
    from twin.analysis.discrepancy.search import find_discrepancy
    from twin.lab.virtual import run_lab
    from twin.runs.format import Stream
    from twin.sim.effects import Effects

    hidden = TwinSpec(effects=Effects({"force_scale": 2.0, "lost_motion": 0.3}))
    two_effects, _ = run_lab(t_s, p_cmd, scenario="nominal", seed=seed, spec=hidden)
    start = time.perf_counter()
    found = find_discrepancy(two_effects)
    out["discrepancy_s"] = time.perf_counter() - start
    out["discrepancy_effects_found"] = list(found.found)
    out["discrepancy_clean_s"], _ = time_call(lambda: find_discrepancy(run), 1)
    assert run.forces is not None
    wobble = run.tracker.values + np.outer(np.sin(2.0 * np.pi * 1.7 * run.tracker.t_s), [0.0, 0.0, 1e-4])
    edited = Run(None, dict(run.meta), run.commanded, Stream(run.tracker.t_s, wobble), run.forces, run.part_profile)
    out["discrepancy_unexplained_s"], _ = time_call(lambda: find_discrepancy(edited), 1)
    drift = run.tracker.values + np.outer(run.tracker.t_s, [1e-5, 0.0, 0.0])
    bias = run.forces.values + np.array([0.0, 0.0, 40.0])
    by_hand = Run(None, dict(run.meta), run.commanded, Stream(run.tracker.t_s, drift),
                  Stream(run.forces.t_s, bias), run.part_profile)
    out["discrepancy_by_hand_s"], _ = time_call(lambda: find_discrepancy(by_hand), 1)
    out["discrepancy_families"] = len(FAMILIES)


def _bench_gcode(out: dict[str, Any], repeats: int, smoke: bool = False) -> None:
    """G-code import: a 101,840-move spiral 45° cone, 120 mm across, 40 mm deep (Ø 20 mm, 2 mm deep for a smoke
    run), read back; the move count from the last timed read."""
    from twin.process.toolpath.gcode import read_gcode
    from twin.process.toolpath.gcode_write import write_gcode
    from twin.process.toolpath.shapes import PartSpec, part_path

    spec = PartSpec(step_down_m=0.3e-3, top_half_width_m=10e-3, depth_m=2e-3) if smoke else PartSpec(step_down_m=0.3e-3)
    with tempfile.TemporaryDirectory(prefix="tx200-bench-gcode-") as tmp:
        program = write_gcode(part_path(spec), Path(tmp) / "cone.nc")
        last: dict[str, Any] = {}
        out["gcode_load_s"], _ = time_call(lambda: last.update(read=read_gcode(program)), repeats)
        out["gcode_moves"] = len(last["read"]) - 1


TABLE_ROWS: tuple[tuple[str, str, str], ...] = (
    ("lab_run_s", "lab run (simulate, sensors, write)", "s"),
    ("replay_s", "replay, fresh Twin", "s"),
    ("replay_warm_s", "replay, ready Twin", "s"),
    ("simulate_warm_s", "  of which Twin.simulate", "s"),
    ("simulate_python_loop_s", "Twin.simulate, Python loop", "s"),
    ("python_over_compiled_loop", "  Python loop / compiled loop", "x"),
    ("ik_path_s", "  of which ik_path", "s"),
    ("analytic_replay_s", "analytic replay (J K^-1 J^T f)", "s"),
    ("replay_realtime_factor", "real-time factor (ready Twin)", "x"),
    ("replay_fresh_realtime_factor", "real-time factor (fresh Twin)", "x"),
    ("mujoco_floor_s", "MuJoCo-call floor (a call per iteration)", "s"),
    ("twin_over_mujoco_floor", "replay / MuJoCo-call floor", "x"),
    ("twin_over_analytic", "twin / analytic", "x"),
    ("sweep_replays_per_s_per_core", "sweep replays / s / core", "x"),
    ("identify_method2_s", "identify Method 2", "s"),
    ("compensate_twin_s", "compensate --method twin", "s"),
    ("discrepancy_s", "discrepancy search", "s"),
    ("discrepancy_unexplained_s", "  full library, nothing explains", "s"),
    ("discrepancy_by_hand_s", "  full library, two hand edits", "s"),
    ("force_field_eval_s", "field rigid_forces (full path)", "s"),
    ("isf_field_eval_s", "ISF height-map field (full path)", "s"),
    ("isf_over_table_field", "  ISF field / table field", "x"),
    ("cone_simulate_s", "Twin.simulate, 4 mm cone on the ISF model", "s"),
    ("cone_simulate_python_loop_s", "  the same, Python loop", "s"),
    ("cone_realtime_factor", "  real-time factor (27 s of machining)", "x"),
    ("gcode_load_s", "G-code import, ~100k moves", "s"),
    ("cli_help_over_numpy", "`tx200-twin --help` / import numpy", "x"),
    ("isf_160_realtime_factor", "Ø160 cone on the ISF model, real time", "x"),
    ("isf_growth_ratio", "  cost/added sample, 80-160 / 40-80", "x"),
    ("compensation_over_simulation", "Ø160 cone twin compensation / simulate", "x"),
    ("place_over_simulation", "cone placement search / one simulate", "x"),
    ("place_best_over_default_rms", "  best placement's rms / default's", "x"),
    ("cli_compensate_over_replay", "CLI compensate (twin) / replay, net", "x"),
    ("cli_place_over_replay", "CLI place / replay, net", "x"),
)


def format_table(result: dict[str, Any]) -> str:
    """A short human table of a `run_benchmarks` payload."""
    lines = []
    for key, label, unit in TABLE_ROWS:
        value = result.get(key)
        if value is None or (isinstance(value, float) and math.isnan(value)):
            text = "n/a"
        elif unit == "s":
            text = f"{value * 1e3:10.1f} ms"
        else:
            text = f"{value:10.1f} x"
        lines.append(f"{label:<38s}{text}")
    growth = result.get("path_growth")
    if growth:
        steps = ", ".join(f"{k} {v['samples']} samples {v['us_per_sample']:.0f} µs/sample ({v['over_1x']:.2f})"
                          for k, v in growth.items())
        lines.append(f"{'cost vs path length':<38s}{steps}")
    w = result["workload"]
    m = result["machine"]
    lines.append(
        f"({w['commanded_samples']} samples, {w['machining_s']:.1f} s machining, median of {w['repeats']}; "
        f"{m['cpu_count']} cores, python {m['python']}, mujoco {m['mujoco']})"
    )
    return "\n".join(lines)
