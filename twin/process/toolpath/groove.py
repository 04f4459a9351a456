"""The ideal tool path U_ID of the groove, in the sheet frame (thesis §1.2.3, §2.2, Table 2.3).

Sheet frame: origin at the centre of the sheet's top surface, x along the groove, z up. Positions are
those of the tool tip (the bottom of the 7.5 mm tool sphere).

Construction (the thesis fixes L, B, H, N, RpP and the zig-zag but not where each pass starts; we chose
this symmetric layout):

* pass k (1-based) has stroke S_k = L - (k-1)·RpP, with RpP = (L - B)/(N - 1);
* it runs from x = -d_k·S_k/2 to x = +d_k·S_k/2, d_k = +1 for odd k and -1 for even k (zig-zag);
* its depth goes linearly ("constant increment", §1.2.3) from -(k-1)·H/N to -k·H/N along the pass;
* between passes a short horizontal turn at constant depth moves RpP/2 towards the centre, so each end wall
  drops H/N for every RpP/2 of run: tan α = 2H/(N·RpP) (Eq. 2.8), 63.43° for the thesis's groove;
* pass 1 starts at (-L/2, 0, 0) on the sheet surface; constant feed, t from 0.

Samples: every segment (pass or turn) is cut into equal pieces no longer than `spacing_m`, and every corner is
a sample, so the 20 corners (start, reversals, turn ends, end) are exact. Turn samples belong to the pass they
lead into (they already move in its direction); the reversal point itself ends its pass. The FE history
stand-in (`twin.process.fe.generator`) instead uses 1311 equal arc-length samples of the same geometry
(`resample_by_arc_length`), the count of the thesis's ABAQUS export (§2.2.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twin.base.signals import interp_rows
from twin.errors import InputError


@dataclass(frozen=True)
class GrooveSpec:
    """Geometry and feed of the groove (defaults: thesis Table 2.3, §1.2.3).

    Attributes:
        top_length_m: Groove length L at the sheet surface [m] (70 mm).
        bottom_length_m: Groove length B at full depth, the last pass's stroke [m] (61 mm).
        depth_m: Final depth H [m] (10 mm).
        passes: Number of passes N (10).
        feed_m_per_s: Constant tool feed [m/s] (2 m/min, §1.2.3).
        spacing_m: Largest distance between consecutive path samples [m] (0.5 mm, the FE seed size in the
            groove strip, §2.2.1).
    """

    top_length_m: float = 0.070
    bottom_length_m: float = 0.061
    depth_m: float = 0.010
    passes: int = 10
    feed_m_per_s: float = 2.0 / 60.0
    spacing_m: float = 0.5e-3

    def __post_init__(self) -> None:
        for name in ("top_length_m", "bottom_length_m", "depth_m", "feed_m_per_s", "spacing_m"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InputError(f"GrooveSpec.{name} = {value!r}: expected a finite number > 0")
        if not isinstance(self.passes, int) or isinstance(self.passes, bool) or self.passes < 2:
            raise InputError(f"GrooveSpec.passes = {self.passes!r}: expected an integer >= 2")
        if self.bottom_length_m >= self.top_length_m:
            raise InputError(
                f"GrooveSpec.bottom_length_m = {self.bottom_length_m!r} must be shorter than "
                f"top_length_m = {self.top_length_m!r} (the strokes shrink by RpP each pass)"
            )
        if self.spacing_m > self.bottom_length_m:
            raise InputError(
                f"GrooveSpec.spacing_m = {self.spacing_m!r} exceeds the last stroke {self.bottom_length_m!r}"
            )

    @property
    def rpp_m(self) -> float:
        """Stroke reduction per pass RpP = (L - B)/(N - 1) [m]."""
        return (self.top_length_m - self.bottom_length_m) / (self.passes - 1)

    @property
    def step_down_m(self) -> float:
        """Depth increment per pass H/N [m]."""
        return self.depth_m / self.passes

    @property
    def wall_angle_rad(self) -> float:
        """End-wall angle α, tan α = 2H/(N·RpP) (Eq. 2.8) [rad]."""
        return math.atan2(2.0 * self.depth_m, self.passes * self.rpp_m)

    def stroke_m(self, k: int) -> float:
        """Stroke S_k of pass k (1-based) [m]."""
        return self.top_length_m - (k - 1) * self.rpp_m

    def direction(self, k: int) -> int:
        """Travel direction along x of pass k: +1 for odd k, -1 for even k."""
        return 1 if k % 2 == 1 else -1


@dataclass(frozen=True)
class ToolPath:
    """A sampled tool-tip path in the sheet frame.

    Attributes:
        t_s: Time of each sample [s], shape (n,).
        p_sheet_m: Tool-tip position [m], shape (n, 3).
        pass_index: Pass number 1..N of each sample, shape (n,).
        direction: Travel direction along x, +1 or -1, shape (n,).
    """

    t_s: np.ndarray
    p_sheet_m: np.ndarray
    pass_index: np.ndarray
    direction: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.t_s)
        shapes = {
            "t_s": (np.shape(self.t_s), (n,)),
            "p_sheet_m": (np.shape(self.p_sheet_m), (n, 3)),
            "pass_index": (np.shape(self.pass_index), (n,)),
            "direction": (np.shape(self.direction), (n,)),
        }
        for name, (got, want) in shapes.items():
            if got != want:
                raise InputError(f"ToolPath.{name} has shape {got}, expected {want}")

    @property
    def s_m(self) -> np.ndarray:
        """Arc length along the path from the first sample [m], shape (n,)."""
        steps = np.linalg.norm(np.diff(self.p_sheet_m, axis=0), axis=1)
        return np.concatenate(([0.0], np.cumsum(steps)))

    def __len__(self) -> int:
        return len(self.t_s)


def _corners(spec: GrooveSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Corner points (m, 3) and, for each segment ending at corner i>0, its pass and direction."""
    h = spec.step_down_m
    points = [(-spec.top_length_m / 2.0, 0.0, 0.0)]
    seg_pass: list[int] = []
    seg_dir: list[int] = []
    for k in range(1, spec.passes + 1):
        d = spec.direction(k)
        half = spec.stroke_m(k) / 2.0
        if k > 1:  # turn: constant depth, RpP/2 towards the centre, already in pass k's direction
            points.append((-d * half, 0.0, -(k - 1) * h))
            seg_pass.append(k)
            seg_dir.append(d)
        points.append((d * half, 0.0, -k * h))
        seg_pass.append(k)
        seg_dir.append(d)
    return np.asarray(points), np.asarray(seg_pass), np.asarray(seg_dir)


#: The most samples a path generator or reader makes (5 million: about 240 MB of path arrays, a path of 2.5 km at
#: the 0.5 mm default spacing); a spacing that would make more is refused before anything is allocated.
MAX_SAMPLES = 5_000_000


class SampleLimitError(InputError):
    """A spacing that would make more than `MAX_SAMPLES` samples (`samples`: the count, at least; `spacing_m`)."""

    def __init__(self, samples: float, spacing_m: float) -> None:
        self.samples, self.spacing_m = samples, spacing_m
        super().__init__(f"spacing_m = {spacing_m:g} would make {samples:.3g} samples or more; expected at most "
                         f"{MAX_SAMPLES:,} samples (a spacing of at least {min_spacing_m(samples, spacing_m):.3g} m)")


def min_spacing_m(samples: float, spacing_m: float) -> float:
    """The spacing [m] that brings `samples` (made at `spacing_m`) down to `MAX_SAMPLES`: a lower bound."""
    return spacing_m * (samples / MAX_SAMPLES) if math.isfinite(samples) else math.inf


def check_samples(samples: float, spacing_m: float) -> None:
    """Refuse a sample count (a float: length / spacing may overflow) above `MAX_SAMPLES`, before allocating.

    Raises:
        SampleLimitError: More than `MAX_SAMPLES` samples (or a count that is not a number).
    """
    if not samples <= MAX_SAMPLES:
        raise SampleLimitError(samples, spacing_m)


def groove_path(spec: GrooveSpec | None = None) -> ToolPath:
    """Sample the ideal groove path U_ID (construction in the module docstring).

    Args:
        spec: Groove geometry and feed; None for the thesis groove.

    Returns:
        The path, corners included, samples at most `spec.spacing_m` apart.

    Raises:
        SampleLimitError: A spacing that would make more than `MAX_SAMPLES` samples.
    """
    spec = spec or GrooveSpec()
    corners, seg_pass, seg_dir = _corners(spec)
    check_samples(len(corners) + float(np.linalg.norm(np.diff(corners, axis=0), axis=1).sum()) / spec.spacing_m,
                  spec.spacing_m)
    chunks = [corners[:1]]
    passes = [np.array([1])]
    dirs = [np.array([seg_dir[0]])]
    for i in range(1, len(corners)):
        a, b = corners[i - 1], corners[i]
        pieces = max(1, math.ceil(float(np.linalg.norm(b - a)) / spec.spacing_m - 1e-9))
        f = np.arange(1, pieces + 1) / pieces
        chunks.append(a + f[:, None] * (b - a))
        passes.append(np.full(pieces, seg_pass[i - 1]))
        dirs.append(np.full(pieces, seg_dir[i - 1]))
    p = np.concatenate(chunks)
    p[:, 1] = 0.0
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate(([0.0], np.cumsum(steps)))
    return ToolPath(
        t_s=s / spec.feed_m_per_s,
        p_sheet_m=p,
        pass_index=np.concatenate(passes).astype(int),
        direction=np.concatenate(dirs).astype(int),
    )


def resample_by_arc_length(path: ToolPath, n: int) -> ToolPath:
    """Resample a path at `n` equally spaced arc lengths (first and last samples kept).

    A new sample between old samples i-1 and i takes the labels of sample i (the step that reaches it).

    Args:
        path: Path to resample (piecewise linear between its samples).
        n: Number of samples, >= 2.
    """
    if n < 2:
        raise InputError(f"n = {n}: expected at least 2 samples")
    s = path.s_m
    s_new = np.linspace(0.0, s[-1], n)
    p = interp_rows(s_new, s, path.p_sheet_m)
    idx = np.searchsorted(s, s_new, side="left").clip(0, len(s) - 1)
    return ToolPath(
        t_s=np.interp(s_new, s, path.t_s),
        p_sheet_m=p,
        pass_index=path.pass_index[idx].copy(),
        direction=path.direction[idx].copy(),
    )


def label_passes(x_m: np.ndarray, *, deadband_m: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Infer pass number and travel direction from a commanded x sequence alone.

    Counts reversals with hysteresis: a reversal is declared at the running extreme once x has come back by
    more than `deadband_m`. The reversal sample ends its pass; the samples after it (the turn segment, which
    already moves in the new direction) start the next one, as in `groove_path`.

    Args:
        x_m: Tool x positions along the path [m], shape (n,).
        deadband_m: Back-travel needed to declare a reversal [m].

    Returns:
        (pass_index, direction): int arrays of shape (n,), passes from 1, direction +1/-1 (all +1 if x never
        moves by more than the dead band).
    """
    x = np.asarray(x_m, dtype=float)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise InputError(f"x_m must be a finite 1-D array, got shape {x.shape}")
    n = len(x)
    xs = x.tolist()  # Python floats: the scan below reads one at a time
    boundaries: list[int] = []
    d = 0
    first = 1
    ext_i = 0
    ext_x = xs[0]
    for i in range(1, n):
        xi = xs[i]
        if d == 0:
            if abs(xi - xs[0]) > deadband_m:
                d = first = 1 if xi > xs[0] else -1
                ext_i, ext_x = i, xi
            continue
        if d * (xi - ext_x) > 0.0:
            ext_i, ext_x = i, xi
        elif d * (ext_x - xi) > deadband_m:
            boundaries.append(ext_i)
            d = -d
            ext_i = ext_i + 1 + int(np.argmax(d * x[ext_i + 1 : i + 1]))
            ext_x = xs[ext_i]
    starts = np.zeros(n, dtype=int)
    starts[np.asarray(boundaries, dtype=int) + 1] = 1  # boundaries are distinct and below n - 1
    pass_index = 1 + np.cumsum(starts)
    direction = np.where(pass_index % 2 == 1, first, -first).astype(int)
    return pass_index, direction
