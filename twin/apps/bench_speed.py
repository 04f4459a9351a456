"""Speed measures of `tx200-twin bench`: the MuJoCo-call floor of a replay and the cost growth with path length.

* `mujoco_call_floor`: the wall time of exactly the MuJoCo calls one replay makes (`mj_kinematics`,
  `mj_comPos`, `mj_rne`, `mj_jacSite` per Newton iteration, the nominal pose and final tool tip per sample, the
  gravity gradient, and the sensor's `mj_inverse` pairs), issued in a bare loop at the replay's own poses. No
  replay that keeps MuJoCo as its source of kinematics and dynamics can be faster; the twin's replay over this
  floor is the overhead of everything else (field, Newton algebra, Python).
* `path_growth`: `Twin.simulate` of the groove resampled 1x, 4x, 16x as densely (the same geometry with k
  times the samples, since the force history has a fixed number of passes): the cost must grow linearly.
* `cli_startup`: `tx200-twin --help` over `python -c "import numpy"`, each a fresh interpreter, interleaved
  (a load on the machine weighs on both alike), median of the runs.
* `isf_cone_benchmarks`: `Twin.simulate` of 45° cones on the ISF model (Ø 40, 80, 160 mm), the cost per added
  sample from one to the next, and `compensation_cost`, the largest cone's twin compensation.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time
from typing import Any

import mujoco
import numpy as np

from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult


def mujoco_call_floor(twin: Twin, sim: SimResult, t_sensor_s: np.ndarray | None, repeats: int = 3) -> float:
    """Best-of-`repeats` wall time of the MuJoCo calls a replay of `sim` makes, alone [s].

    Args:
        twin: The twin `sim` came from.
        sim: A simulated run (its poses and per-sample Newton iteration counts set the calls).
        t_sensor_s: Sensor sample times of the replay (two `mj_inverse` and one `mj_kinematics` each), or None.
        repeats: Timed repeats; the best is reported (the floor).
    """
    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    m, d = twin.model, twin.data
    site = m.site(twin.robot.tool_site).id
    jacp, g = np.zeros((3, m.nv)), np.zeros(m.nv)
    q_nominal = np.zeros((len(sim.t_s), m.nq))
    arm = twin.robot.addresses(m).qpos
    q_nominal[:, arm] = sim.q_ik
    iterations = [int(k) for k in sim.iterations]
    q_sensor = interp_rows(t_sensor_s, sim.t_s, sim.qpos) if t_sensor_s is not None else np.zeros((0, m.nq))
    kinematics, com_pos, rne, jac_site, inverse = (
        mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_rne, mujoco.mj_jacSite, mujoco.mj_inverse
    )
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(2 * m.nv):  # the gravity gradient by central differences
            d.qpos[:] = sim.qpos[0]
            kinematics(m, d)
            com_pos(m, d)
            rne(m, d, 0, g)
        for i, k in enumerate(iterations):
            d.qpos[:] = q_nominal[i]
            kinematics(m, d)
            com_pos(m, d)
            rne(m, d, 0, g)
            d.qpos[:] = sim.qpos[i]
            for _ in range(k):
                kinematics(m, d)
                com_pos(m, d)
                rne(m, d, 0, g)
                jac_site(m, d, jacp, None, site)
            kinematics(m, d)
        d.qvel[:] = 0.0
        d.qacc[:] = 0.0
        for q in q_sensor:
            d.qpos[:] = q
            kinematics(m, d)
            inverse(m, d)
            inverse(m, d)
        best = min(best, time.perf_counter() - start)
    return best


def resample(t_s: np.ndarray, p_sheet_m: np.ndarray, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """The same path with `factor` times the samples (linear in time between the original samples).

    Args:
        t_s: Sample times [s], shape (n,).
        p_sheet_m: Positions [m], shape (n, 3).
        factor: Samples per original interval (1 returns the path itself).

    Returns:
        (t, p) with (n - 1)·factor + 1 samples.
    """
    if factor < 1:
        raise InputError(f"factor = {factor!r}: expected >= 1")
    n = len(t_s)
    u = np.linspace(0.0, n - 1, (n - 1) * factor + 1)
    t = np.interp(u, np.arange(n), t_s)
    return t, interp_rows(t, t_s, p_sheet_m)


def path_growth(
    twin: Twin, t_s: np.ndarray, p_sheet_m: np.ndarray, factors: tuple[int, ...] = (1, 4, 16), repeats: int = 2
) -> dict[str, dict[str, float]]:
    """Best-of-`repeats` wall time of `twin.simulate` (IK included) on the path resampled by each factor.

    Returns:
        Per factor ("1x", ...): samples, wall time [s], µs per sample, and time over the 1x time [-].
    """
    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    out: dict[str, dict[str, float]] = {}
    base = None
    for k in factors:
        t, p = resample(t_s, p_sheet_m, k)
        wall = float("inf")
        for _ in range(repeats):  # the best of a few: a shared machine only ever adds time
            start = time.perf_counter()
            twin.simulate(t, p)
            wall = min(wall, time.perf_counter() - start)
        base = wall if base is None else base
        out[f"{k}x"] = {"samples": len(t), "s": wall, "us_per_sample": 1e6 * wall / len(t), "over_1x": wall / base}
    return out


#: `tx200-twin --help` in a fresh interpreter, as the console script runs it (argparse exits after the help).
CLI_HELP = "import sys; from twin.cli import main; sys.argv[0] = 'tx200-twin'; main(['--help'])"


def cli_startup(repeats: int = 5) -> dict[str, float]:
    """Wall time of `tx200-twin --help` and of `python -c "import numpy"`, interleaved, medians [s] and ratio [-].

    Args:
        repeats: Runs of each (>= 1).
    """
    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    times: dict[str, list[float]] = {"help": [], "numpy": []}
    for _ in range(repeats):
        for key, code in (("numpy", "import numpy"), ("help", CLI_HELP)):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], check=True, stdout=subprocess.DEVNULL)
            times[key].append(time.perf_counter() - start)
    help_s, numpy_s = statistics.median(times["help"]), statistics.median(times["numpy"])
    return {"help_s": help_s, "numpy_s": numpy_s, "help_over_numpy": help_s / numpy_s}


#: The cones of `isf_cone_benchmarks` (top diameter, depth [m]), and the small ones of a smoke run.
ISF_CONES = ((40e-3, 5e-3), (80e-3, 20e-3), (160e-3, 40e-3))
ISF_SMOKE_CONES = ((20e-3, 2e-3), (30e-3, 3e-3), (40e-3, 5e-3))


def isf_cone_growth(
    twin: Twin, cones: tuple[tuple[float, float], ...] = ISF_CONES, repeats: int = 3
) -> dict[str, dict[str, float]]:
    """Best-of-`repeats` wall time of `twin.simulate` of 45° cones, their IK given, the cones interleaved.

    Args:
        twin: A twin on the ISF model.
        cones: (top diameter, depth) per cone [m].
        repeats: Timed rounds over every cone (>= 1).

    Returns:
        Per cone ("40mm", ...): samples, machining [s], wall time [s], µs per sample, real-time factor [-] and
        Newton iterations per sample.
    """
    from twin.process.toolpath.shapes import PartSpec, part_path

    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    paths = {f"{1e3 * width:.0f}mm": part_path(PartSpec(depth_m=depth, top_half_width_m=width / 2.0))
             for width, depth in cones}
    q_ik = {key: twin.simulate(path.t_s, path.p_sheet_m).q_ik for key, path in paths.items()}  # compiles too
    wall = dict.fromkeys(paths, float("inf"))
    for _ in range(repeats):  # interleaved: a load on the machine weighs on every cone alike
        for key, path in paths.items():
            start = time.perf_counter()
            twin.simulate(path.t_s, path.p_sheet_m, q_ik=q_ik[key])
            wall[key] = min(wall[key], time.perf_counter() - start)
    out = {}
    for key, path in paths.items():
        n, machining = len(path.t_s), float(path.t_s[-1] - path.t_s[0])
        iterations = twin.simulate(path.t_s, path.p_sheet_m, q_ik=q_ik[key]).iterations
        out[key] = {"samples": n, "machining_s": machining, "s": wall[key], "us_per_sample": 1e6 * wall[key] / n,
                    "realtime_factor": machining / wall[key], "iterations_per_sample": float(np.mean(iterations))}
    return out


def added_sample_ratio(growth: dict[str, dict[str, float]]) -> float:
    """The cost of each added sample from the second to the last cone over that from the first to the second
    (fixed costs cancel) [-]."""
    a, b, c = (growth[key] for key in list(growth)[:2] + list(growth)[-1:])
    return ((c["s"] - b["s"]) / (c["samples"] - b["samples"])) / ((b["s"] - a["s"]) / (b["samples"] - a["samples"]))


def isf_cone_benchmarks(repeats: int, smoke: bool = False) -> dict[str, Any]:
    """The ISF model at full part size: `isf_cone_growth` of `ISF_CONES` and `compensation_cost` of the largest.

    Args:
        repeats: Timed rounds of the replays (at least 3); the compensation takes at most 2 (each a
            simulation and a compensation of the largest cone).
        smoke: The small `ISF_SMOKE_CONES` instead (a quick check of the keys).

    Returns:
        `isf_cone_growth`, `isf_160_realtime_factor` (the largest cone's), `isf_growth_ratio`
        (`added_sample_ratio`; the issue's target: at most 1.5), `compensation` and `compensation_over_simulation`
        (the largest cone's; the target: at most 4).
    """
    from twin.process.description import Process
    from twin.sim.spec import TwinSpec

    cones = ISF_SMOKE_CONES if smoke else ISF_CONES
    twin = TwinSpec(process=Process(force_model="isf")).build()
    growth = isf_cone_growth(twin, cones, max(3, repeats))
    largest = growth[list(growth)[-1]]
    compensation = compensation_cost(*cones[-1], min(2, repeats), twin=twin)
    return {"isf_cone_growth": growth, "isf_160_realtime_factor": largest["realtime_factor"],
            "isf_growth_ratio": added_sample_ratio(growth), "compensation": compensation,
            "compensation_over_simulation": compensation["over_simulation"]}


def compensation_cost(
    top_width_m: float, depth_m: float, repeats: int = 3, twin: Twin | None = None
) -> dict[str, float | int | bool]:
    """`compensate_twin` of a 45° cone on the ISF model against one `Twin.simulate` of it, medians of `repeats`.

    Each repeat shifts the cone by a further nanometre, so no step reuses an IK solved before (a twin keeps the
    IK of the paths it last simulated); both run on warm twins.

    Args:
        top_width_m: The cone's top diameter [m].
        depth_m: Its depth [m].
        repeats: Timed runs of each (>= 1).
        twin: A twin on the ISF model; None builds one.

    Returns:
        samples, simulations (iterations), converged, the final rms and largest residual [mm], compensate_s and
        simulate_s [s] (one simulation of the path, its IK included), and their ratio `over_simulation` [-]
        (the issue's target: at most 4).
    """
    from twin.analysis.compensate import compensate_twin
    from twin.process.description import Process
    from twin.process.toolpath.shapes import PartSpec, part_path
    from twin.sim.spec import TwinSpec

    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    cone = part_path(PartSpec(depth_m=depth_m, top_half_width_m=top_width_m / 2.0))
    twin = twin or TwinSpec(process=Process(force_model="isf")).build()
    twin.simulate(cone.t_s[:50], cone.p_sheet_m[:50])  # compile and warm the loop outside the timings
    times: dict[str, list[float]] = {"simulate": [], "compensate": []}
    for k in range(1, repeats + 1):
        p = cone.p_sheet_m + 1e-9 * k
        start = time.perf_counter()
        twin.simulate(cone.t_s, p)
        times["simulate"].append(time.perf_counter() - start)
        p = p + 0.5e-9
        start = time.perf_counter()
        comp = compensate_twin(cone.t_s, p, twin)
        times["compensate"].append(time.perf_counter() - start)
    assert comp.predicted_residual_m is not None
    residual = np.linalg.norm(comp.predicted_residual_m, axis=1)
    compensate_s, simulate_s = statistics.median(times["compensate"]), statistics.median(times["simulate"])
    return {
        "samples": len(cone.t_s), "simulations": comp.iterations, "converged": comp.converged,
        "residual_rms_mm": 1e3 * float(np.sqrt(np.mean(residual**2))), "residual_max_mm": 1e3 * float(residual.max()),
        "compensate_s": compensate_s, "simulate_s": simulate_s, "over_simulation": compensate_s / simulate_s,
    }
