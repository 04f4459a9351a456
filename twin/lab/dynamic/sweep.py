"""Feed sweep: where does the quasi-static twin stop describing the dynamic plant?

The groove is run on the dynamic plant with neutral knobs (no hidden effect; sensor noise only) at several
feeds, and each run is replayed by a caller-supplied replay (the quasi-static twin: `twin.analysis.replay`;
this package may not import the twin, so the caller passes it in). The gap is compared with what noise
alone leaves: 2x the tracker's noise as a 3-D rms (2 sqrt(3) sigma) for position, 2 % of the peak force for
force. The first feed that exceeds either is where the quasi-static assumption breaks. The controller's stops at
the reversals keep the ramp length they have at 2 m/min (the acceleration grows with the feed squared), so every
feed is reached along the stroke.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Protocol, TextIO

import numpy as np

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.run import run_dynamic_lab
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.runs.format import Run

DEFAULT_FEEDS_M_PER_MIN = (0.5, 2.0, 5.0, 10.0, 20.0)
FORCE_GAP_FRACTION = 0.02  # force gap allowed, fraction of the peak force [-]
POSITION_GAP_NOISE_FACTOR = 2.0  # position gap allowed, in units of the tracker noise's 3-D rms [-]


REVERSAL_WINDOW_S = 0.15  # tracker samples this close to a commanded reversal count as "at a reversal" [s]


class ReplayLike(Protocol):
    """What the sweep needs from a replay (`twin.analysis.replay.ReplayResult` has it)."""

    @property
    def metrics(self) -> Mapping[str, float]:
        """Gap metrics: `position_rms_mm`, `position_max_mm`, `force_rms_n`, `force_peak_measured_n`."""
        ...

    @property
    def tracker_pred_m(self) -> np.ndarray:
        """Predicted tracker reading at the run's tracker times [m], shape (m, 3)."""
        ...


def reversal_mask(run: Run, window_s: float = REVERSAL_WINDOW_S) -> np.ndarray:
    """Tracker samples within `window_s` of a reversal of the commanded x, shape (m,) [bool]."""
    x = run.commanded.values[:, 0]
    t_rev = run.commanded.t_s[np.flatnonzero(np.diff(np.sign(np.diff(x))) != 0) + 1]
    if t_rev.size == 0:
        return np.zeros(run.tracker.t_s.shape, dtype=bool)
    return np.min(np.abs(run.tracker.t_s[:, None] - t_rev[None, :]), axis=1) < window_s


@dataclass(frozen=True)
class SweepRow:
    """One feed of the sweep.

    Attributes:
        feed_m_per_min: Feed [m/min].
        position_rms_mm: Replay gap, tracker vs twin, rms of the 3-D distance [mm].
        position_max_mm: Its maximum [mm].
        position_away_mm: The rms gap away from the reversals (farther than `REVERSAL_WINDOW_S`) [mm].
        force_rms_n: Replay gap of the force, rms of the 3-D difference [N].
        force_peak_n: Peak measured force [N].
        position_limit_mm: What noise alone allows, 2 sqrt(3) sigma_tracker [mm].
        wall_s: Wall time of the dynamic simulation [s].
    """

    feed_m_per_min: float
    position_rms_mm: float
    position_max_mm: float
    position_away_mm: float
    force_rms_n: float
    force_peak_n: float
    position_limit_mm: float
    wall_s: float

    @property
    def quasi_static(self) -> bool:
        """Whether the twin's gap stays within what noise explains."""
        return (
            self.position_rms_mm <= self.position_limit_mm
            and self.force_rms_n <= FORCE_GAP_FRACTION * self.force_peak_n
        )


def feed_sweep(
    replay: Callable[[Run], ReplayLike],
    *,
    feeds_m_per_min: Sequence[float] = DEFAULT_FEEDS_M_PER_MIN,
    spec: GrooveSpec | None = None,
    knobs: Knobs | None = None,
    seed: int = 0,
    progress: TextIO | None = None,
) -> list[SweepRow]:
    """Run the groove at each feed on the dynamic plant and replay it.

    Args:
        replay: Run -> its replay on the twin (`twin.analysis.replay.replay`).
        feeds_m_per_min: Feeds [m/min].
        spec: Groove geometry (its feed is replaced); default the thesis groove.
        knobs: Plant knobs; default the neutral ones.
        seed: Noise seed (the same for every feed).
        progress: Stream for one line per feed (None: quiet).

    Returns:
        One row per feed, in order.
    """
    spec = spec or GrooveSpec()
    knobs = knobs or Knobs(neutral=True)
    limit_mm = POSITION_GAP_NOISE_FACTOR * math.sqrt(3.0) * knobs["tracker_noise_mm"]
    rows = []
    ramp_m = (2.0 / 60.0) ** 2 / (2.0 * knobs["trajectory_accel_mps2"]) if knobs["trajectory_accel_mps2"] else 0.0
    for feed in feeds_m_per_min:
        path = groove_path(replace(spec, feed_m_per_s=feed / 60.0))
        feed_knobs = knobs
        if ramp_m > 0.0:  # the stop ramps keep their length at 2 m/min, so every feed is reached in the stroke
            accel = max(knobs["trajectory_accel_mps2"], (feed / 60.0) ** 2 / (2.0 * ramp_m))
            feed_knobs = Knobs({**knobs.as_dict(), "trajectory_accel_mps2": accel})
        run, _, log = run_dynamic_lab(path.t_s, path.p_sheet_m, scenario="nominal", knobs=feed_knobs, seed=seed)
        result = replay(run)
        metrics = result.metrics
        err_m = np.linalg.norm(run.tracker.values - result.tracker_pred_m, axis=1)
        away = ~reversal_mask(run)
        row = SweepRow(
            feed_m_per_min=float(feed),
            position_rms_mm=float(metrics["position_rms_mm"]),
            position_max_mm=float(metrics["position_max_mm"]),
            position_away_mm=1e3 * float(np.sqrt(np.mean(err_m[away] ** 2))),
            force_rms_n=float(metrics["force_rms_n"]),
            force_peak_n=float(metrics["force_peak_measured_n"]),
            position_limit_mm=limit_mm,
            wall_s=log.wall_s,
        )
        rows.append(row)
        if progress is not None:
            print(
                f"  feed {feed:5.1f} m/min: position gap {row.position_rms_mm:.3f} mm rms "
                f"({row.position_away_mm:.3f} away from reversals), "
                f"force gap {row.force_rms_n:.1f} N rms ({log.wall_s:.1f} s)",
                file=progress,
            )
    return rows


def breaking_feed(rows: Sequence[SweepRow]) -> float | None:
    """The lowest feed whose gap exceeds what noise explains [m/min] (None if none does)."""
    bad = [row.feed_m_per_min for row in rows if not row.quasi_static]
    return min(bad) if bad else None


def sweep_table(rows: Sequence[SweepRow]) -> str:
    """The sweep as a Markdown table."""
    lines = [
        "| feed [m/min] | position gap rms / max [mm] | rms away from reversals [mm] | limit [mm] | "
        "force gap rms [N] | 2 % of peak [N] | quasi-static |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.feed_m_per_min:g} | {r.position_rms_mm:.3f} / {r.position_max_mm:.3f} | "
            f"{r.position_away_mm:.3f} | {r.position_limit_mm:.3f} | {r.force_rms_n:.1f} | {FORCE_GAP_FRACTION * r.force_peak_n:.1f} | "
            f"{'yes' if r.quasi_static else 'no'} |"
        )
    return "\n".join(lines)


def write_sweep_figure(rows: Sequence[SweepRow], path: str | Path) -> Path:
    """Plot the position and force gaps against feed, with their noise limits, to a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    feeds = np.array([r.feed_m_per_min for r in rows])
    fig, (ax_p, ax_f) = plt.subplots(1, 2, figsize=(9.0, 3.6), constrained_layout=True)
    ax_p.plot(feeds, [r.position_rms_mm for r in rows], "o-", label="replay gap (rms)")
    ax_p.plot(feeds, [r.position_away_mm for r in rows], "s:", label="away from reversals")
    ax_p.plot(feeds, [r.position_limit_mm for r in rows], "k--", label="2x tracker noise (3-D rms)")
    ax_p.set(xscale="log", yscale="log", xlabel="feed [m/min]", ylabel="position gap [mm]")
    ax_f.plot(feeds, [r.force_rms_n for r in rows], "o-", color="C3", label="replay gap (rms)")
    ax_f.plot(feeds, [FORCE_GAP_FRACTION * r.force_peak_n for r in rows], "k--", label="2 % of peak force")
    ax_f.set(xscale="log", yscale="log", xlabel="feed [m/min]", ylabel="force gap [N]")
    for ax in (ax_p, ax_f):
        ax.axvline(2.0, color="0.7", lw=0.8)
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Quasi-static twin vs dynamic MuJoCo plant (neutral knobs, thesis groove)", fontsize=10)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(out)
    return out
