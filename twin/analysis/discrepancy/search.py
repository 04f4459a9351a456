"""Find where the twin and a measured run disagree, name the missing effect, add it, show the gap shrink.

1. Find: replay the run with the current twin; residuals of tool tip, force and part profile, normalised by
   the noise estimated from the data (`twin.analysis.discrepancy.residuals`). The gap is significant when the reduced chi-square
   of any stream exceeds 1 + CHI2_MARGIN (plus five standard errors).
2. Name: every candidate of the library (`twin.lab.effects.EFFECTS`, one parameter each) is fitted by Gauss-Newton
   over twin replays (finite-difference sensitivity). Candidates are scored by held-out error: the parameter
   is fitted on the odd passes and scored on the even ones and vice versa (linearised at the full fit), with a
   BIC penalty of log(N) per parameter. The best candidate is accepted when it removes at least
   EXPLAINED_FRACTION of the held-out excess over noise; otherwise the gap is `unexplained`. After an
   accepted effect the search repeats on what is left, so two effects are found one after the other.
   A candidate is rejected when, fitted (and refitted jointly with the effects already accepted), it makes
   any stream's residual significantly worse: an effect of the robot or its sensors must agree with every
   stream (e.g. a force offset fitted as force_scale predicts deflections the tracker does not see).
   When nothing is accepted the twin stays as given (`effects` = `start`). The excess over noise is
   counted per stream (`excess_over_noise`); stream_time_offset starts Gauss-Newton from a coarse scan.
3. Add: the accepted effects form a twin model file (`twin.lab.effects.write_model_file`).
4. Shrink: the run is replayed with the augmented twin; gaps before and after are reported.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from twin.analysis.discrepancy.residuals import ResidualModel
from twin.analysis.replay import replay_metrics
from twin.lab.effects import EFFECTS, Effects
from twin.lab.measure import predict_forces, predict_tracker
from twin.process.forces import ForceHistory
from twin.runs.format import Run

CHI2_MARGIN = 0.15  # noise estimates are good to a few per cent; below this the residual is noise
EXPLAINED_FRACTION = 0.6  # of the excess over noise, by all accepted effects together
COMPLETE_FRACTION = 0.9  # explained well enough to name effects although the rest is above noise
ROUND_FRACTION = 0.05  # of what is left, by the effect accepted in one round (then refitted jointly)
MAX_EFFECTS = 3
GN_ITERATIONS = 4

# Finite-difference step and bounds of each candidate's parameter, in the units of EFFECTS.
_STEP = {
    "direction_dependent_compliance": 0.1,
    "force_scale": 0.05,
    "stream_time_offset": 0.02,
    "tracker_drift": 0.005,
    "tcp_offset": 0.2,
    "sheet_springback": 0.02,
}
# Candidates whose residual is far from linear in the parameter and that need no new simulation: a coarse
# scan over the bounds (this many points) picks the Gauss-Newton start (a 0.3 s clock offset is out of
# reach of a few Gauss-Newton steps from zero; a scan point costs ~10 ms).
_SCAN_POINTS = {"stream_time_offset": 81}
_BOUNDS = {
    "direction_dependent_compliance": (-5.0, 5.0),
    "force_scale": (0.05, 5.0),
    "stream_time_offset": (-2.0, 2.0),
    "tracker_drift": (-1.0, 1.0),
    "tcp_offset": (-10.0, 10.0),
    "sheet_springback": (0.0, 0.9),
}


@dataclass(frozen=True)
class CandidateFit:
    """One candidate effect fitted on top of the current twin."""

    name: str
    value: float
    train_sse: float
    heldout_sse: float
    score: float
    explained: float

    def summary(self) -> dict[str, Any]:
        """JSON-ready."""
        unit = EFFECTS[self.name].unit
        return {
            "name": self.name,
            "score": self.score,
            "explained_fraction": self.explained,
            "parameters": Effects({self.name: self.value}).named_parameters().get(self.name, {}),
            "value": self.value,
            "unit": unit,
            "heldout_sse": self.heldout_sse,
        }


@dataclass(frozen=True)
class DiscrepancyResult:
    """Outcome of the workflow."""

    effects: Effects
    found: tuple[str, ...]
    verdict: str
    rounds: tuple[tuple[CandidateFit, ...], ...]
    chi2_before: dict[str, float]
    chi2_after: dict[str, float]
    gap_before: dict[str, float]
    gap_after: dict[str, float]
    noise: dict[str, float]
    location: dict[str, Any]
    confidence: float
    residual_before: dict[str, np.ndarray] = field(repr=False)
    residual_after: dict[str, np.ndarray] = field(repr=False)


def reduced_chi2(model: ResidualModel, streams: dict[str, np.ndarray]) -> dict[str, float]:
    """Reduced chi-square of each residual stream against the estimated noise."""
    sigma = {
        "position": model.noise.position_m,
        "force": model.noise.force_n,
        "profile": model.noise.profile_m,
    }
    return {name: float(np.mean((values / sigma[name]) ** 2)) for name, values in streams.items()}


def is_significant(chi2: dict[str, float], counts: dict[str, int]) -> bool:
    """Whether any stream's residual is above what its noise explains."""
    return any(chi2[name] > 1.0 + CHI2_MARGIN + 5.0 * np.sqrt(2.0 / max(counts[name], 1)) for name in chi2)


def is_contradicted(chi2_now: dict[str, float], chi2_new: dict[str, float], counts: dict[str, int]) -> bool:
    """Whether a new fit makes any stream's residual significantly worse than it is now.

    A stream is worse when its reduced chi-square rises by more than CHI2_MARGIN (relative, and not below
    the significance level of a noise-only stream) plus five standard errors.
    """
    return any(
        chi2_new[name]
        > (1.0 + CHI2_MARGIN) * max(chi2_now[name], 1.0 + CHI2_MARGIN)
        + 5.0 * np.sqrt(2.0 / max(counts[name], 1))
        for name in chi2_new
    )


def excess_over_noise(r: np.ndarray, sizes: list[int]) -> float:
    """Sum over streams of the normalised squared residual above its noise-only expectation, each >= 0.

    Per stream, so that a stream whose noise was estimated a little high (reduced chi-square below 1)
    cannot hide the excess of another.

    Args:
        r: Stacked normalised residual (`ResidualModel.vector`).
        sizes: Length of each stream's part of `r`, in order.
    """
    parts = np.split(r, np.cumsum(sizes)[:-1])
    return float(sum(max(float(part @ part) - part.size, 0.0) for part in parts))


def _fit_candidate(
    model: ResidualModel, base: Effects, name: str, r_base: np.ndarray, sizes: list[int]
) -> CandidateFit:
    lo, hi = _BOUNDS[name]
    step = _STEP[name]
    theta = base.get(name)
    r = r_base
    if name in _SCAN_POINTS:
        scan = [
            (float(v @ v), float(x), v)
            for x in np.linspace(lo, hi, _SCAN_POINTS[name])
            for v in (model.vector(base.with_value(name, float(x))),)
        ]
        sse, x_best, v_best = min(scan, key=lambda item: item[0])
        if sse < float(r @ r):
            theta, r = x_best, v_best
    jac = np.zeros_like(r)
    for _ in range(GN_ITERATIONS):
        jac = (model.vector(base.with_value(name, theta + step)) - r) / step
        denom = float(jac @ jac)
        if denom <= 0.0:
            break
        new = float(np.clip(theta - float(jac @ r) / denom, lo, hi))
        moved = abs(new - theta)
        theta = new
        r = model.vector(base.with_value(name, theta))
        if moved < 0.02 * step:
            break
    heldout = 0.0
    for train, test in (model.folds(), model.folds()[::-1]):
        denom = float(jac[train] @ jac[train])
        delta = -float(jac[train] @ r[train]) / denom if denom > 0 else 0.0
        heldout += float(np.sum((r[test] + jac[test] * delta) ** 2))
    penalty = np.log(r.size)
    excess = excess_over_noise(r_base, sizes)
    score = float(r_base @ r_base) - heldout - penalty
    explained = score / excess if excess > 0 else 0.0
    return CandidateFit(name, theta, float(r @ r), heldout, score, explained)


def _refit_jointly(model: ResidualModel, effects: Effects, names: list[str]) -> Effects:
    """Gauss-Newton over the parameters of all accepted effects together (removes sequential-fit bias)."""
    for _ in range(GN_ITERATIONS):
        r = model.vector(effects)
        jac = np.column_stack(
            [(model.vector(effects.with_value(n, effects.get(n) + _STEP[n])) - r) / _STEP[n] for n in names]
        )
        delta, *_ = np.linalg.lstsq(jac, -r, rcond=None)
        for name, d in zip(names, delta, strict=True):
            lo, hi = _BOUNDS[name]
            effects = effects.with_value(name, float(np.clip(effects.get(name) + d, lo, hi)))
        if all(abs(d) < 0.02 * _STEP[n] for n, d in zip(names, delta, strict=True)):
            break
    return effects


def _locate(model: ResidualModel, streams: dict[str, np.ndarray]) -> dict[str, Any]:
    """Where the position residual lives: per pass, per direction, near stroke ends, over time, in frequency."""
    run = model.run
    norm = np.linalg.norm(streams["position"], axis=1)
    t = run.tracker.t_s
    x_cmd = np.interp(t, run.commanded.t_s, run.commanded.values[:, 0])
    near_end = np.abs(x_cmd) > np.max(np.abs(run.commanded.values[:, 0])) - 0.005
    velocity = np.gradient(x_cmd, t)
    spectrum = np.abs(np.fft.rfft(streams["position"][:, 2] - np.mean(streams["position"][:, 2])))
    freqs = np.fft.rfftfreq(len(t), d=float(np.median(np.diff(t))))
    thirds = np.array_split(np.arange(len(t)), 3)

    def rms(mask: np.ndarray) -> float:
        return 1e3 * float(np.sqrt(np.mean(norm[mask] ** 2))) if np.any(mask) else float("nan")

    return {
        "position_rms_mm_per_pass": {
            str(k): rms(model.tracker_pass == k) for k in np.unique(model.tracker_pass)
        },
        "position_rms_mm_forward": rms(velocity > 0),
        "position_rms_mm_backward": rms(velocity < 0),
        "position_rms_mm_near_stroke_ends": rms(near_end),
        "position_rms_mm_mid_stroke": rms(~near_end),
        "position_rms_mm_by_time_third": [rms(np.isin(np.arange(len(t)), part)) for part in thirds],
        "position_mean_mm": (1e3 * np.mean(streams["position"], axis=0)).tolist(),
        "dominant_frequency_hz": float(freqs[1 + int(np.argmax(spectrum[1:]))]) if len(spectrum) > 1 else 0.0,
        "force_mean_n": np.mean(streams["force"], axis=0).tolist() if "force" in streams else None,
    }


def _gap(run: Run, model: ResidualModel, effects: Effects) -> dict[str, float]:
    twin, sim = model.simulate(effects)
    tracker = predict_tracker(sim, run.tracker.t_s, effects)
    forces = predict_forces(twin, sim, run.forces.t_s, effects) if run.forces is not None else None
    metrics = replay_metrics(run, tracker, forces)
    gap = {
        "position_rms_mm": metrics["position_rms_mm"],
        "force_rms_n": metrics.get("force_rms_n", float("nan")),
    }
    if run.part_profile is not None:
        gap["profile_rms_mm"] = 1e3 * float(np.sqrt(np.mean(model.streams(effects)["profile"] ** 2)))
    return gap


def _fit_reporting(
    model: ResidualModel,
    base: Effects,
    name: str,
    r_base: np.ndarray,
    sizes: list[int],
    progress: Callable[[str], None] | None,
) -> CandidateFit:
    if progress is not None:
        progress(name)
    return _fit_candidate(model, base, name, r_base, sizes)


def find_discrepancy(
    run: Run,
    *,
    start: Effects | None = None,
    history: ForceHistory | None = None,
    joint_stiffness: np.ndarray | None = None,
    candidates: tuple[str, ...] | None = None,
    progress: Callable[[str], None] | None = None,
) -> DiscrepancyResult:
    """Run the workflow on one run.

    Args:
        run: Measured run (truth.json is never read).
        start: Effects the twin already has (e.g. from an earlier model file).
        history: Force history of the twin's field (default: the shipped one).
        joint_stiffness: K_q of the twin [N·m/rad] (default: the model's).
        candidates: Names to try (default: all of EFFECTS; `sheet_springback` only with a part profile).
        progress: Called with each candidate's name as its fit starts (to show a long search moving).
    """
    model = ResidualModel(run, history, joint_stiffness)
    names = candidates or tuple(EFFECTS)
    if run.part_profile is None:
        names = tuple(n for n in names if n != "sheet_springback")
    if run.forces is None:
        names = tuple(n for n in names if n != "stream_time_offset")
    effects = start or Effects()
    streams_before = model.streams(effects)
    counts = {name: values.size for name, values in streams_before.items()}
    sizes = [counts[name] for name in ("position", "force", "profile") if name in counts]  # order of `vector`
    chi2_before = reduced_chi2(model, streams_before)
    rounds: list[tuple[CandidateFit, ...]] = []
    found: list[str] = []
    verdict = "none"
    confidence = 1.0
    chi2 = chi2_before
    while is_significant(chi2, counts) and len(found) < MAX_EFFECTS:
        r_base = model.vector(effects)
        fits = tuple(
            sorted(
                (_fit_reporting(model, effects, n, r_base, sizes, progress) for n in names if n not in found),
                key=lambda c: -c.score,
            )
        )
        rounds.append(fits)
        accepted: tuple[int, Effects, dict[str, float]] | None = None
        for index, fit in enumerate(fits):
            if fit.explained < ROUND_FRACTION or fit.score <= 0.0:
                break
            trial = effects.with_value(fit.name, fit.value)
            if found:
                trial = _refit_jointly(model, trial, [*found, fit.name])
            chi2_trial = reduced_chi2(model, model.streams(trial))
            if not is_contradicted(chi2, chi2_trial, counts):
                accepted = (index, trial, chi2_trial)
                break
        if accepted is None:
            break
        index, effects, chi2 = accepted
        best = fits[index]
        if not found:
            others = [max(fit.score, 0.0) for i, fit in enumerate(fits) if i != index]
            runner_up = max(others, default=0.0)
            confidence = float(best.score / (best.score + runner_up)) if best.score > 0 else 0.0
        found.append(best.name)
    r_start, r_end = model.vector(start or Effects()), model.vector(effects)
    excess = excess_over_noise(r_start, sizes)
    total_explained = 1.0 - excess_over_noise(r_end, sizes) / excess if excess > 0 else 1.0
    chi2_end = reduced_chi2(model, model.streams(effects))
    margin = {name: 5.0 * np.sqrt(2.0 / max(counts[name], 1)) for name in counts}
    # a named effect must not make any stream worse, and must bring the gap to noise (or nearly all the way)
    worsened = any(chi2_end[name] > chi2_before[name] + margin[name] for name in chi2_end)
    at_noise = not is_significant(chi2_end, counts) or total_explained >= COMPLETE_FRACTION
    if found and total_explained >= EXPLAINED_FRACTION and at_noise and not worsened:
        verdict = found[0]
    elif is_significant(chi2_before, counts):
        verdict = "unexplained"
    if verdict == "unexplained":
        effects = start or Effects()  # nothing named: the twin stays as given
    streams_after = model.streams(effects)
    return DiscrepancyResult(
        effects=effects,
        found=tuple(found) if verdict != "unexplained" else (),
        verdict=verdict,
        rounds=tuple(rounds),
        chi2_before=chi2_before,
        chi2_after=reduced_chi2(model, streams_after),
        gap_before=_gap(run, model, start or Effects()),
        gap_after=_gap(run, model, effects),
        noise=model.noise.summary(),
        location=_locate(model, streams_before),
        confidence=confidence,
        residual_before=streams_before,
        residual_after=streams_after,
    )


def result_summary(result: DiscrepancyResult) -> dict[str, Any]:
    """The JSON document of the `discrepancy` command."""
    return {
        "effect": result.verdict,
        "effects": list(result.found),
        "parameters": result.effects.named_parameters(),
        "confidence": result.confidence,
        "gap_before": result.gap_before,
        "gap_after": result.gap_after,
        "noise": result.noise,
        "reduced_chi2_before": result.chi2_before,
        "reduced_chi2_after": result.chi2_after,
        "location": result.location,
        "candidates": [c.summary() for c in result.rounds[0]] if result.rounds else [],
        "rounds": [[c.summary() for c in fits] for fits in result.rounds],
    }
