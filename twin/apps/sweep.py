"""Monte Carlo sweep (`tx200-twin sweep`): how far the compensated groove lands when the model is uncertain.

The groove is compensated once with the nominal twin (`compensate_twin`), the model's best belief. Each draw
is then one plausible real cell: joint springs K_q, joint friction, the sheet's sensitivities k_unload/k_load
and a force scale drawn independently from normal distributions, clipped to physical values (springs and
sheet stiffnesses >= 10 % of their mean, friction >= 0, force scale >= 0.1). Each draw replays the
compensated command on a twin with those values; the residual is the simulated tool tip minus the ideal path.

Means and σ: `twin.apps.uncertainty` (a calibration file, or the model's values with default relative σ).

The draws are made in the parent from one seed, so the result does not depend on the number of workers or
where they run; they run on all cores, or with `scheduler` on a Dask distributed cluster (`twin.base.jobs.Jobs`),
one ready twin per worker.
"""

from __future__ import annotations

__all__ = ["MAX_DRAWS", "PARAMETERS", "SweepResult", "Uncertainty", "check_draws", "draw_bytes", "model_uncertainty",
           "replay_draw", "run_sweep", "usable_cores"]

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from twin.apps.uncertainty import PARAMETERS, Draw, Uncertainty, load_uncertainty, model_uncertainty
from twin.base.jobs import Jobs, usable_cores
from twin.errors import InputError
from twin.process.force.pass_tables import PassTable, scaled_tables
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

MAX_DRAWS = 1_000_000
"""Most draws a sweep takes: at ~25 ms a replay, a million draws are already ~7 core-hours."""
MEMORY_SHARE = 0.5
"""Share of the machine's memory the draws may hold [-]."""


def draw_bytes() -> int:
    """Memory one draw holds until the sweep ends [B]: its parameters and residuals (8 B floats), and the record's
    Python floats and their JSON text (~32 B each), one per parameter and residual."""
    return (8 + 32 + 32) * (len(PARAMETERS) + 3)


def _machine_bytes() -> int | None:
    """The machine's physical memory [B], or None where the system does not say."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return None


def check_draws(draws: int) -> None:
    """Refuse a number of draws before anything is allocated: at most `MAX_DRAWS`, and no more than fit in
    `MEMORY_SHARE` of the machine's memory at `draw_bytes` each.

    Raises:
        InputError: Above the limit, naming `--draws`, the value, the limit and the memory it would take.
    """
    memory = _machine_bytes()
    limit = MAX_DRAWS if memory is None else min(MAX_DRAWS, int(MEMORY_SHARE * memory) // draw_bytes())
    if draws > limit:
        fits = "" if memory is None else (f" and what fits in {MEMORY_SHARE:.0%} of this machine's "
                                          f"{memory / 2**30:.0f} GiB")
        raise InputError(f"--draws {draws}: expected at most {limit} (the sweep's cap of {MAX_DRAWS} draws{fits}; "
                         f"at ~{draw_bytes()} B a draw, {draws} draws would need ~{draws * draw_bytes() / 2**30:.3g} "
                         "GiB of memory)")


@dataclass(frozen=True)
class SweepResult:
    """Distribution of the compensated residual over the draws.

    Attributes:
        parameters: Drawn parameter sets, shape (n, len(PARAMETERS)), `PARAMETERS` order and units.
        rms_m: RMS over the path of |tool tip - ideal| per draw [m], shape (n,).
        max_m: Largest |tool tip - ideal| per draw [m], shape (n,).
        mean_z_m: Mean z residual per draw (positive: too shallow) [m], shape (n,).
        nominal_rms_m: The same RMS with the nominal model (the compensation's own prediction) [m].
        wall_s: Wall time of the draws (compensation excluded) [s].
        workers: Workers used (local processes, or the Dask cluster's worker threads).
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


# ------------------------------------------------------------------ worker side
def _prepare_worker(setup: tuple[TwinSpec, np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> dict[str, Any]:
    """A worker's ready twin and the shared arrays (once per worker)."""
    spec, t_s, p_cmd, q_ik, p_ideal = setup
    twin = spec.build()
    sheet = twin.sheet_field
    assert isinstance(sheet, SheetForceField)  # `model_uncertainty` refused another force model
    return {"twin": twin, "t_s": t_s, "p_cmd": p_cmd, "q_ik": q_ik, "p_ideal": p_ideal, "tables": sheet.pass_tables}


def replay_draw(twin: Twin, values: np.ndarray, t_s: np.ndarray, p_cmd: np.ndarray,
                q_ik: np.ndarray | None = None, tables: list[PassTable] | None = None) -> np.ndarray:
    """Simulate `p_cmd` on `twin` set to one parameter set (`PARAMETERS` order); the twin keeps the values.

    `tables` are the pass tables of the twin's history itself (unscaled), to rescale per draw instead of
    refitting the field (26 ms a draw); None refits.

    Returns:
        The simulated tool tip [m], shape (n, 3).
    """
    draw = Draw.of(values)
    twin.set_joint_stiffness(draw.k_q_nm_per_rad)
    twin.joint_friction = draw.friction_nm
    scale, history = draw.force_scale, twin.history
    scaled = history if scale == 1.0 else replace(history, f_sheet_n=scale * history.f_sheet_n)
    drawn = None if tables is None else (tables if scale == 1.0 else scaled_tables(tables, scale))
    field = SheetForceField(
        scaled, k_unload_n_per_m=draw.k_unload_n_per_m, k_load_n_per_m=draw.k_load_n_per_m, tables=drawn
    )
    twin.set_sheet_field(field)
    return twin.simulate(t_s, p_cmd, q_ik=q_ik).p_sheet_m


def _residual_stats(p_sim: np.ndarray, p_ideal: np.ndarray) -> tuple[float, float, float]:
    residual = p_sim - p_ideal
    norm = np.linalg.norm(residual, axis=1)
    return float(np.sqrt(np.mean(norm**2))), float(norm.max()), float(residual[:, 2].mean())


def _run_chunk(w: dict[str, Any], values: np.ndarray) -> np.ndarray:
    """A job: replay a chunk of draws; (rms, max, mean z) of each residual [m], shape (k, 3)."""
    out = np.empty((len(values), 3))
    for i, row in enumerate(values):
        p = replay_draw(w["twin"], row, w["t_s"], w["p_cmd"], w["q_ik"], w["tables"])
        out[i] = _residual_stats(p, w["p_ideal"])
    return out


def run_sweep(
    draws: int,
    *,
    spec: TwinSpec | None = None,
    seed: int = 0,
    workers: int | None = None,
    uncertainty: Uncertainty | None = None,
    calibration: str | Path | None = None,
    path: ToolPath | None = None,
    compensate: bool = True,
    chunk: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    scheduler: str | None = None,
) -> SweepResult:
    """Monte Carlo of the compensated (or plain) groove over the model's uncertainty.

    Args:
        draws: Number of parameter sets.
        spec: The nominal twin (its force model must be the table field); default the thesis's cell.
        seed: Seed of the draws.
        workers: Worker processes; default every core this process may use (ignored with `scheduler`).
        uncertainty: Means and σ; default `load_uncertainty(calibration, nominal twin)`.
        calibration: Calibration JSON file (`parameters`, `sigma`), used when `uncertainty` is None.
        path: Ideal path; default the thesis groove.
        compensate: True: replay the twin-compensated command; False: the ideal path itself.
        chunk: Draws per task sent to a worker; default about a quarter of each worker's share, at most 8.
        progress: Called with (draws done, draws) as chunks complete.
        scheduler: Address of a Dask distributed scheduler to replay the draws on; None: local.

    Returns:
        The distribution (the same for the same seed wherever it ran).

    Raises:
        InputError: Bad `workers` or `chunk`, more draws than `check_draws` allows, or no Dask scheduler answers
            at `scheduler`.
    """
    from twin.analysis.compensate import compensate_twin  # analysis runs before apps: an allowed import

    check_draws(draws)
    spec = spec or TwinSpec()
    path = path if path is not None else groove_path()
    if (workers is not None and workers < 1) or (chunk is not None and chunk < 1):
        raise InputError(f"workers = {workers!r}, chunk = {chunk!r}: expected >= 1")
    with Jobs(workers, scheduler) as jobs:  # a bad scheduler address is refused before any work
        nominal = spec.build()
        uncertainty = uncertainty or load_uncertainty(calibration, nominal)
        values = uncertainty.draw(draws, seed)
        t_s, p_ideal = path.t_s, path.p_sheet_m
        start = time.perf_counter()
        p_cmd = compensate_twin(t_s, p_ideal, nominal).p_cmd_sheet_m if compensate else p_ideal
        sim = nominal.simulate(t_s, p_cmd)
        compensate_s = time.perf_counter() - start
        nominal_rms = _residual_stats(sim.p_sheet_m, p_ideal)[0]
        workers = jobs.workers
        if chunk is None:
            chunk = max(1, min(8, draws // (4 * workers)))
        start = time.perf_counter()
        chunks = [values[i : i + chunk] for i in range(0, draws, chunk)]
        report = None if progress is None else (lambda done, _n: progress(min(draws, done * chunk), draws))
        stats = np.concatenate(jobs.map(_run_chunk, chunks, (spec, t_s, p_cmd, sim.q_ik, p_ideal),
                                        prepare=_prepare_worker, progress=report))
        wall = time.perf_counter() - start
    return SweepResult(values, stats[:, 0], stats[:, 1], stats[:, 2], nominal_rms, wall, workers, compensate_s,
                       uncertainty)
