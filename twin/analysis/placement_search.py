"""Where to put the sheet (`tx200-twin place`): the placement of least predicted error of a part.

The part's error is the tool tip's miss against the ideal path (the ideal path commanded as it is, no
compensation): its rms and largest value over the path. The robot's compliance, and so the error, depends on
where the sheet sits in the cell.

Candidates are a seeded Latin hypercube (`scipy.stats.qmc.LatinHypercube`) over a box around the twin's own
placement (`SearchBox`): by default ±300 mm in x (toward and away from the robot), ±400 mm in y, ±100 mm in z and
the full turn of yaw. The box is what a fixture table near the cell's own could be moved by, wide enough that the
robot's pose, and so its compliance, changes across it; candidates outside the reach, too close to a joint limit
(`joint_margin_rad`) or to a singularity (the robot's |det J| threshold) are skipped and counted by reason.

Each candidate is screened by the linear compliance model of `twin.analysis.placement_screen` (what it neglects
is said there), and the best `confirm` are confirmed by `Twin.simulate`; the default placement's own error is
simulated too. The jobs run on `twin.base.jobs.Jobs`: every core, or a Dask cluster (`scheduler`).
"""

from __future__ import annotations

__all__ = ["PlacementSearch", "SearchBox", "candidate_rows", "describe", "search_placement"]

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from twin.analysis.placement_screen import (
    STATUSES,
    ConfirmSetup,
    ScreenSetup,
    confirm_one,
    placement_of,
    prepare_screen,
    screen_chunk,
    screen_rows,
    seeded_reach,
)
from twin.base.jobs import Jobs
from twin.errors import InputError
from twin.process.toolpath.groove import ToolPath
from twin.sim.spec import TwinSpec

#: Path samples the screen solves the IK at (evenly spread in time).
SCREEN_SAMPLES = 256
#: Smallest distance to a joint limit a feasible placement keeps [rad] (5°).
JOINT_MARGIN_RAD = math.radians(5.0)


@dataclass(frozen=True)
class SearchBox:
    """Half-widths of the candidate box around the twin's placement.

    Attributes:
        half_width_m: Half-widths of the origin's box along base x, y, z [m].
        half_yaw_rad: Half-range of the yaw [rad]; pi: the full turn.
    """

    half_width_m: tuple[float, float, float] = (0.3, 0.4, 0.1)
    half_yaw_rad: float = math.pi

    def __post_init__(self) -> None:
        w = np.asarray(self.half_width_m, dtype=float)
        if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise InputError(f"SearchBox.half_width_m = {self.half_width_m!r}: expected 3 finite lengths >= 0 [m]")
        if not (math.isfinite(self.half_yaw_rad) and 0.0 <= self.half_yaw_rad <= math.pi):
            raise InputError(f"SearchBox.half_yaw_rad = {self.half_yaw_rad!r}: expected an angle in [0, pi] [rad]")


def candidate_rows(center: np.ndarray, box: SearchBox, n: int, seed: int) -> np.ndarray:
    """`n` candidate rows [x, y, z, yaw] [m, m, m, rad]: a seeded Latin hypercube over `box` around `center`."""
    from scipy.stats import qmc

    if n < 1:
        raise InputError(f"candidates = {n!r}: expected an integer >= 1")
    unit = qmc.LatinHypercube(d=4, rng=np.random.default_rng(seed)).random(n)
    half = np.array([*box.half_width_m, box.half_yaw_rad])
    return np.asarray(center, dtype=float) + (2.0 * unit - 1.0) * half


class PlacementSearch(NamedTuple):
    """The search's result. Errors [m]; rows [x, y, z, yaw] [m, m, m, rad].

    Attributes:
        rows: The candidates (n, 4).
        screened: Each candidate's screen (n, 5): rms, max, status code (`STATUSES`), smallest joint margin [rad],
            smallest |det J| [m^3]; NaN errors where infeasible.
        default_row: The twin's own placement (4,).
        default_screened: Its screen (5,).
        default_simulated: Its simulation (5,).
        confirmed_index: Candidates confirmed by simulation, best screened first (k,).
        confirmed: Their simulations (k, 5).
        box: The candidate box.
        seed: Seed of the candidates.
        where: Where the jobs ran.
        timings_s: Wall times [s] of `default` (build and simulate), `screen`, `confirm` and `total`.
    """

    rows: np.ndarray
    screened: np.ndarray
    default_row: np.ndarray
    default_screened: np.ndarray
    default_simulated: np.ndarray
    confirmed_index: np.ndarray
    confirmed: np.ndarray
    box: SearchBox
    seed: int
    where: str
    timings_s: dict[str, float]

    @property
    def best(self) -> int | None:
        """Index (into `rows`) of the confirmed candidate of least simulated rms error; None if none is feasible."""
        ok = self.confirmed[:, 2] == 0
        if not np.any(ok):
            return None
        return int(self.confirmed_index[ok][np.argmin(self.confirmed[ok, 0])])

    def infeasible(self) -> dict[str, int]:
        """Skipped candidates by reason."""
        codes = self.screened[:, 2].astype(int)
        return {name: int(np.sum(codes == k)) for k, name in enumerate(STATUSES) if k > 0}

    def summary(self) -> dict[str, Any]:
        """JSON payload: millimetres and degrees."""

        def where(row: np.ndarray) -> dict[str, Any]:
            return {"origin_base_mm": [round(1e3 * float(v), 3) for v in row[:3]], "yaw_deg": math.degrees(row[3])}

        def errors(values: np.ndarray, kind: str) -> dict[str, Any]:
            ok = int(values[2]) == 0
            return {f"{kind}_rms_mm": 1e3 * float(values[0]) if ok else None,
                    f"{kind}_max_mm": 1e3 * float(values[1]) if ok else None,
                    f"{kind}_status": STATUSES[int(values[2])]}

        confirmed = [where(self.rows[i]) | errors(self.screened[i], "screened") | errors(sim, "simulated")
                     for i, sim in zip(self.confirmed_index, self.confirmed, strict=True)]
        best = self.best
        default_rms = float(self.default_simulated[0])
        return {
            "candidates": len(self.rows),
            "feasible": int(np.sum(self.screened[:, 2] == 0)),
            "infeasible": self.infeasible(),
            "seed": self.seed,
            "box": {"half_width_mm": [1e3 * v for v in self.box.half_width_m],
                    "half_yaw_deg": math.degrees(self.box.half_yaw_rad)},
            "default": where(self.default_row) | errors(self.default_screened, "screened")
            | errors(self.default_simulated, "simulated"),
            "confirmed": confirmed,
            "best": None if best is None else confirmed[list(self.confirmed_index).index(best)],
            "best_over_default_rms": None if best is None else
            float(self.confirmed[list(self.confirmed_index).index(best), 0]) / default_rms,
            "where": self.where,
            "timings_s": self.timings_s,
        }


def _subsample(n: int, m: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, m)).round().astype(int))


def search_placement(
    path: ToolPath,
    spec: TwinSpec | None = None,
    *,
    candidates: int = 512,
    confirm: int = 5,
    seed: int = 0,
    box: SearchBox | None = None,
    joint_margin_rad: float = JOINT_MARGIN_RAD,
    screen_samples: int = SCREEN_SAMPLES,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> PlacementSearch:
    """Search the sheet's placement for the least predicted error of `path` (module docstring).

    Args:
        path: The ideal path, sheet frame.
        spec: The twin; its placement is the default and the box's centre. None: the default cell.
        candidates: Candidates drawn.
        confirm: Best screened candidates confirmed by `Twin.simulate` (at most `candidates`).
        seed: Seed of the candidates.
        box: The candidate box; None: `SearchBox()`.
        joint_margin_rad: Smallest distance to a joint limit a feasible placement keeps [rad].
        screen_samples: Path samples the screen solves the IK at.
        workers: Local worker processes; None: every usable core.
        scheduler: Address of a Dask distributed scheduler to run the jobs on; None: local.
        progress: Called with (stage, done, total) as jobs complete; stage 'screen' or 'confirm'.

    Raises:
        InputError: `candidates` < 1, `confirm` < 0, a bad margin, or a bad `scheduler` address.
        UnreachableError, SingularityError: The path is not feasible at the default placement (its forces come
            from a simulation there).
    """
    if candidates < 1 or confirm < 0 or screen_samples < 2:
        raise InputError(f"candidates = {candidates!r}, confirm = {confirm!r}, screen_samples = {screen_samples!r}: "
                         "expected candidates >= 1, confirm >= 0 and screen_samples >= 2")
    if not (math.isfinite(joint_margin_rad) and joint_margin_rad >= 0):
        raise InputError(f"joint_margin_rad = {joint_margin_rad!r}: expected an angle >= 0 [rad]")
    spec, box = spec or TwinSpec(), box or SearchBox()
    start = time.perf_counter()
    with Jobs(workers, scheduler) as jobs:  # a bad scheduler address is refused before any work
        twin = spec.build()
        kin = twin.kinematics
        reach = seeded_reach(path, spec.placement, kin)
        sim = twin.simulate(path.t_s, path.p_sheet_m, q_ik=reach.q_rad)
        norm = np.linalg.norm(sim.p_sheet_m - path.p_sheet_m, axis=1)
        default_simulated = np.array([math.sqrt(float(np.mean(norm**2))), float(norm.max()), 0.0,
                                      float(reach.joint_margin_rad.min()), reach.min_abs_det_j])
        default_row = np.array([*spec.placement.origin_in(kin), spec.placement.yaw_rad])
        idx = _subsample(len(path.t_s), screen_samples)
        setup = ScreenSetup(spec.robot, twin.joint_stiffness, path.p_sheet_m[idx], sim.f_sheet_n[idx],
                            joint_margin_rad, spec.tool)
        default_screened = screen_rows(kin, setup, default_row[None])[0]
        rows = candidate_rows(default_row, box, candidates, seed)
        timings = {"default": time.perf_counter() - start}
        t0 = time.perf_counter()
        n_chunks = min(len(rows), max(4 * jobs.workers, math.ceil(len(rows) / 32)))
        report = None if progress is None else (lambda done, total: progress("screen", done, total))
        screened = np.vstack(jobs.map(screen_chunk, np.array_split(rows, n_chunks), setup, prepare=prepare_screen,
                                      progress=report))
        timings["screen"] = time.perf_counter() - t0
        feasible = np.flatnonzero(screened[:, 2] == 0)
        chosen = feasible[np.argsort(screened[feasible, 0], kind="stable")][:confirm]
        t0 = time.perf_counter()
        report = None if progress is None else (lambda done, total: progress("confirm", done, total))
        confirmed = jobs.map(confirm_one, list(rows[chosen]), ConfirmSetup(spec, path, joint_margin_rad),
                             progress=report)
        timings["confirm"] = time.perf_counter() - t0
        where = jobs.where
    timings["total"] = time.perf_counter() - start
    return PlacementSearch(
        rows=rows, screened=screened, default_row=default_row, default_screened=default_screened,
        default_simulated=default_simulated, confirmed_index=chosen,
        confirmed=np.array(confirmed).reshape(len(chosen), 5), box=box, seed=seed, where=where, timings_s=timings,
    )


def describe(row: np.ndarray) -> str:
    """A candidate row in words: origin [mm] and yaw [deg]."""
    placement = placement_of(row)
    assert placement.origin_base_m is not None
    x, y, z = (1e3 * v for v in placement.origin_base_m)
    return f"origin ({x:.0f}, {y:.0f}, {z:.0f}) mm, yaw {math.degrees(placement.yaw_rad):.0f}°"
