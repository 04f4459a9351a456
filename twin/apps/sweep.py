"""Monte Carlo sweep (`tx200-twin sweep`): how far the compensated groove lands when the model is uncertain.

The groove is compensated once with the nominal twin (`compensate_twin`), the model's best belief. Each draw
is then one plausible real cell: joint springs K_q, joint friction, the sheet's sensitivities k_unload/k_load
and a force scale drawn independently from normal distributions, clipped to physical values (springs and
sheet stiffnesses >= 10 % of their mean, friction >= 0, force scale >= 0.1). Each draw replays the
compensated command on a twin with those values; the residual is the simulated tool tip minus the ideal path.

Means and σ come from a calibration file (`tx200-twin calibrate` writes `parameters` and `sigma`, e.g.
docs/calibration.json; only the σ of each parameter is stored, so the draws are independent), else from the
model with the relative σ of `DEFAULT_RELATIVE_SIGMA`. Parameters a file does not name keep those defaults.

The draws are made in the parent from one seed, so the result does not depend on the number of workers; they
run on all cores (`concurrent.futures.ProcessPoolExecutor`), one ready twin per worker process.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.csvio import read_json
from twin.errors import InputError
from twin.process.field import SheetForceField
from twin.process.forces import ForceHistory, default_force_history
from twin.process.pass_tables import PassTable, scaled_tables
from twin.process.path import ToolPath, groove_path
from twin.robot.stiffness import set_joint_stiffness
from twin.sim.quasi_static import Twin

#: Relative σ of each parameter group when no calibration file gives one [-].
DEFAULT_RELATIVE_SIGMA: dict[str, float] = {
    "k_q": 0.10,  # K_q from a load test: the thesis's Method 1 spread is ~10 % per joint
    "friction": 0.30,
    "k_unload_n_per_m": 0.20,  # calibration: 1.43 ± 0.29 kN/mm
    "k_load_n_per_m": 0.40,  # calibration: 0.160 ± 0.065 kN/mm
    "force_scale": 0.05,
}
MIN_FRACTION = 0.1  # stiffnesses and the force scale are clipped to >= this fraction of their mean
PARAMETERS: tuple[str, ...] = (
    *(f"k_q{i}_nm_per_rad" for i in range(1, 7)),
    *(f"friction{i}_nm" for i in range(1, 7)),
    "k_unload_n_per_m",
    "k_load_n_per_m",
    "force_scale",
)


@dataclass(frozen=True)
class Uncertainty:
    """Independent normal uncertainty of the sweep's parameters (`PARAMETERS` order).

    Attributes:
        mean: Mean of each parameter [its unit], shape (15,).
        sigma: Standard deviation [its unit], shape (15,).
        source: Where the values come from (a file, or "model defaults").
    """

    mean: np.ndarray
    sigma: np.ndarray
    source: str

    def draw(self, n: int, seed: int) -> np.ndarray:
        """`n` parameter sets [units of `PARAMETERS`], shape (n, 15), clipped to physical values."""
        if n < 1:
            raise InputError(f"draws = {n!r}: expected >= 1")
        rng = np.random.default_rng(seed)
        values = self.mean + self.sigma * rng.standard_normal((n, len(PARAMETERS)))
        floor = np.array([0.0 if name.startswith("friction") else MIN_FRACTION for name in PARAMETERS])
        return np.maximum(values, floor * self.mean)


def model_uncertainty(twin: Twin, calibration: Mapping[str, Any] | None = None, source: str = "") -> Uncertainty:
    """Means and σ of the sweep: the model's values with `DEFAULT_RELATIVE_SIGMA`, overridden by a calibration.

    Args:
        twin: The nominal twin (K_q, friction and the field's k_unload/k_load are read from it).
        calibration: A `tx200-twin calibrate` payload with `parameters` and `sigma` (same keys), or None.
        source: Name of the calibration (a path) for the record.

    Raises:
        InputError: A calibration without `parameters`/`sigma`, or with a non-finite, negative or zero-mean value.
    """
    k_q, friction = twin.joint_stiffness, twin.joint_friction
    mean = np.array([*k_q, *friction, twin.sheet_field.k_unload, twin.sheet_field.k_load, 1.0])
    rel = [DEFAULT_RELATIVE_SIGMA["k_q"]] * 6 + [DEFAULT_RELATIVE_SIGMA["friction"]] * 6
    rel += [DEFAULT_RELATIVE_SIGMA[name] for name in PARAMETERS[12:]]
    sigma = np.array(rel) * mean
    if calibration is None:
        return Uncertainty(mean, sigma, "model defaults")
    params, sig = calibration.get("parameters"), calibration.get("sigma")
    if not isinstance(params, Mapping) or not isinstance(sig, Mapping):
        raise InputError(f"{source}: expected a calibration with 'parameters' and 'sigma' objects")
    for j, name in enumerate(PARAMETERS):
        if name not in params and name not in sig:
            continue
        if name not in params or name not in sig:
            raise InputError(f"{source}: '{name}' needs both a value in 'parameters' and one in 'sigma'")
        value, spread = params[name], sig[name]
        if not (isinstance(value, int | float) and isinstance(spread, int | float)):
            raise InputError(f"{source}: '{name}' = {value!r} ± {spread!r}: expected numbers")
        if not (math.isfinite(value) and math.isfinite(spread) and value >= 0 and spread >= 0):
            raise InputError(f"{source}: '{name}' = {value!r} ± {spread!r}: expected finite values >= 0")
        if value == 0 and not name.startswith("friction"):
            raise InputError(f"{source}: '{name}' = 0: a stiffness or scale must be > 0")
        mean[j], sigma[j] = float(value), float(spread)
    return Uncertainty(mean, sigma, str(source))


def load_uncertainty(path: str | Path | None, twin: Twin) -> Uncertainty:
    """`model_uncertainty` from a calibration JSON file, or the model defaults when `path` is None."""
    if path is None:
        return model_uncertainty(twin)
    return model_uncertainty(twin, read_json(path), str(path))


@dataclass(frozen=True)
class SweepResult:
    """Distribution of the compensated residual over the draws.

    Attributes:
        parameters: Drawn parameter sets, shape (n, 15), `PARAMETERS` order and units.
        rms_m: RMS over the path of |tool tip - ideal| per draw [m], shape (n,).
        max_m: Largest |tool tip - ideal| per draw [m], shape (n,).
        mean_z_m: Mean z residual per draw (positive: too shallow) [m], shape (n,).
        nominal_rms_m: The same RMS with the nominal model (the compensation's own prediction) [m].
        wall_s: Wall time of the draws (compensation excluded) [s].
        workers: Worker processes used.
        compensate_s: Wall time of the compensation [s].
        uncertainty: Means and σ used.
    """

    parameters: np.ndarray
    rms_m: np.ndarray
    max_m: np.ndarray
    mean_z_m: np.ndarray
    nominal_rms_m: float
    wall_s: float
    workers: int
    compensate_s: float
    uncertainty: Uncertainty = field(repr=False)

    @property
    def replays_per_s_per_core(self) -> float:
        """Draws (one replay each) per second of wall time per worker [1/s]."""
        return len(self.rms_m) / self.wall_s / self.workers

    def summary(self) -> dict[str, Any]:
        """JSON payload: percentiles in mm, timing, the uncertainty and every draw."""

        def pct(values: np.ndarray) -> dict[str, float]:
            return {f"p{q}": float(np.percentile(values, q) * 1e3) for q in (5, 50, 95)} | {
                "max": float(values.max() * 1e3)
            }

        return {
            "draws": len(self.rms_m),
            "workers": self.workers,
            "wall_s": self.wall_s,
            "compensate_s": self.compensate_s,
            "replays_per_s_per_core": self.replays_per_s_per_core,
            "nominal_rms_mm": self.nominal_rms_m * 1e3,
            "rms_mm": pct(self.rms_m),
            "max_mm": pct(self.max_m),
            "mean_z_mm": pct(self.mean_z_m),
            "uncertainty": {
                "source": self.uncertainty.source,
                "mean": dict(zip(PARAMETERS, self.uncertainty.mean.tolist(), strict=True)),
                "sigma": dict(zip(PARAMETERS, self.uncertainty.sigma.tolist(), strict=True)),
            },
            "per_draw": {
                "rms_mm": (self.rms_m * 1e3).tolist(),
                "max_mm": (self.max_m * 1e3).tolist(),
                "mean_z_mm": (self.mean_z_m * 1e3).tolist(),
                "parameters": {name: self.parameters[:, j].tolist() for j, name in enumerate(PARAMETERS)},
            },
        }


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


# ------------------------------------------------------------------ worker side
_WORKER: dict[str, Any] = {}


def _init_worker(history: ForceHistory, t_s: np.ndarray, p_cmd: np.ndarray, q_ik: np.ndarray,
                 p_ideal: np.ndarray) -> None:
    twin = Twin(history=history)
    _WORKER.update(twin=twin, history=history, t_s=t_s, p_cmd=p_cmd, q_ik=q_ik, p_ideal=p_ideal,
                   tables=twin.sheet_field.pass_tables)


def replay_draw(twin: Twin, history: ForceHistory, values: np.ndarray, t_s: np.ndarray, p_cmd: np.ndarray,
                q_ik: np.ndarray | None = None, tables: list[PassTable] | None = None) -> np.ndarray:
    """Simulate `p_cmd` on `twin` set to one parameter set (`PARAMETERS` order); the twin keeps the values.

    `tables` are the pass tables of `history` itself (unscaled), to rescale per draw instead of refitting the
    field (26 ms a draw); None refits.

    Returns:
        The simulated tool tip [m], shape (n, 3).
    """
    set_joint_stiffness(twin.model, values[0:6])
    twin.joint_friction = values[6:12]
    scale = float(values[14])
    scaled = history if scale == 1.0 else replace(history, f_sheet_n=scale * history.f_sheet_n)
    drawn = None if tables is None else (tables if scale == 1.0 else scaled_tables(tables, scale))
    field = SheetForceField(
        scaled, k_unload_n_per_m=float(values[12]), k_load_n_per_m=float(values[13]), tables=drawn
    )
    twin.set_sheet_field(field)
    return twin.simulate(t_s, p_cmd, q_ik=q_ik).p_sheet_m


def _residual_stats(p_sim: np.ndarray, p_ideal: np.ndarray) -> tuple[float, float, float]:
    residual = p_sim - p_ideal
    norm = np.linalg.norm(residual, axis=1)
    return float(np.sqrt(np.mean(norm**2))), float(norm.max()), float(residual[:, 2].mean())


def _run_chunk(start: int, values: np.ndarray) -> tuple[int, np.ndarray]:
    w = _WORKER
    out = np.empty((len(values), 3))
    for i, row in enumerate(values):
        p = replay_draw(w["twin"], w["history"], row, w["t_s"], w["p_cmd"], w["q_ik"], w["tables"])
        out[i] = _residual_stats(p, w["p_ideal"])
    return start, out


def run_sweep(
    draws: int,
    *,
    seed: int = 0,
    workers: int | None = None,
    uncertainty: Uncertainty | None = None,
    calibration: str | Path | None = None,
    history: ForceHistory | None = None,
    path: ToolPath | None = None,
    compensate: bool = True,
    chunk: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> SweepResult:
    """Monte Carlo of the compensated (or plain) groove over the model's uncertainty.

    Args:
        draws: Number of parameter sets.
        seed: Seed of the draws.
        workers: Worker processes; default every core this process may use.
        uncertainty: Means and σ; default `load_uncertainty(calibration, nominal twin)`.
        calibration: Calibration JSON file (`parameters`, `sigma`), used when `uncertainty` is None.
        history: FE force history; default the shipped one.
        path: Ideal path; default the thesis groove.
        compensate: True: replay the twin-compensated command; False: the ideal path itself.
        chunk: Draws per task sent to a worker; default about a quarter of each worker's share, at most 8.
        progress: Called with (draws done, draws) as chunks complete.

    Returns:
        The distribution.
    """
    from twin.analysis.compensate import compensate_twin  # analysis runs before apps: an allowed import

    history = history if history is not None else default_force_history()
    path = path if path is not None else groove_path()
    if workers is None:
        workers = usable_cores()
    if chunk is None:
        chunk = max(1, min(8, draws // (4 * workers)))
    if workers < 1 or chunk < 1:
        raise InputError(f"workers = {workers!r}, chunk = {chunk!r}: expected >= 1")
    nominal = Twin(history=history)
    uncertainty = uncertainty or load_uncertainty(calibration, nominal)
    values = uncertainty.draw(draws, seed)
    t_s, p_ideal = path.t_s, path.p_sheet_m
    start = time.perf_counter()
    p_cmd = compensate_twin(t_s, p_ideal, nominal).p_cmd_sheet_m if compensate else p_ideal
    sim = nominal.simulate(t_s, p_cmd)
    compensate_s = time.perf_counter() - start
    nominal_rms = _residual_stats(sim.p_sheet_m, p_ideal)[0]
    stats = np.empty((draws, 3))
    init = (history, t_s, p_cmd, sim.q_ik, p_ideal)
    start = time.perf_counter()
    done = 0
    if workers == 1:
        _init_worker(*init)
        for i in range(0, draws, chunk):
            stats[i : i + chunk] = _run_chunk(i, values[i : i + chunk])[1]
            done = min(draws, i + chunk)
            if progress is not None:
                progress(done, draws)
    else:
        with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker, initargs=init) as pool:
            futures = [pool.submit(_run_chunk, i, values[i : i + chunk]) for i in range(0, draws, chunk)]
            for future in as_completed(futures):
                i, out = future.result()
                stats[i : i + len(out)] = out
                done += len(out)
                if progress is not None:
                    progress(done, draws)
    wall = time.perf_counter() - start
    return SweepResult(values, stats[:, 0], stats[:, 1], stats[:, 2], nominal_rms, wall, workers, compensate_s,
                       uncertainty)
