"""Residuals between a measured run and the twin, normalised by the sensors' noise estimated from the data.

Noise is estimated from each stream alone: the signals are smooth at their sample rates, so the second
difference of a stream is dominated by white noise with variance 6 sigma^2; a median absolute deviation keeps
reversals and force transients from inflating it. Residuals are stacked into one vector, each stream divided
by its noise, so a pure-noise residual has reduced chi-square 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.process.toolpath.groove import label_passes
from twin.runs.format import Run, run_placement
from twin.sim.effects import Effects
from twin.sim.measure import predict_forces, predict_part_profile, predict_tracker
from twin.sim.quasi_static import PASS_DEADBAND_M, Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec

MAD_TO_SIGMA = 1.4826


def second_difference_noise(values: np.ndarray) -> float:
    """Robust white-noise sigma of a smooth sampled signal, from its second differences [signal unit]."""
    dd = np.diff(np.asarray(values, dtype=float), n=2, axis=0).ravel()
    if dd.size < 3:
        return float("nan")
    return float(MAD_TO_SIGMA * np.median(np.abs(dd - np.median(dd))) / np.sqrt(6.0))


@dataclass(frozen=True)
class Noise:
    """Sensor noise estimated from a run: per axis, sigma [m], [N], [m]."""

    position_m: float
    force_n: float
    profile_m: float

    @property
    def by_stream(self) -> dict[str, float]:
        """Stream name -> its sigma per axis (SI): `position` [m], `force` [N], `profile` [m]."""
        return {"position": self.position_m, "force": self.force_n, "profile": self.profile_m}

    def summary(self) -> dict[str, float]:
        """JSON keys with units: `position_mm`, `force_n`, `profile_mm` (per axis sigma)."""
        return {
            "position_mm": 1e3 * self.position_m,
            "force_n": self.force_n,
            "profile_mm": 1e3 * self.profile_m,
        }


def estimate_noise(run: Run) -> Noise:
    """Estimate the tracker, force and profile noise of a run from the data alone."""
    position = second_difference_noise(run.tracker.values)
    force = second_difference_noise(run.forces.values) if run.forces is not None else float("nan")
    profile = second_difference_noise(run.part_profile[1]) if run.part_profile is not None else float("nan")
    floor = 1e-6  # 1 um: below any real tracker
    return Noise(
        max(position, floor),
        max(force, 0.1) if np.isfinite(force) else force,
        max(profile, floor) if np.isfinite(profile) else profile,
    )


def measured_streams(run: Run) -> dict[str, np.ndarray]:
    """What the run measured, by stream: `position` [m] (m, 3), `force` [N] (k, 3), `profile` [m] (p,)."""
    out = {"position": run.tracker.values, "force": None if run.forces is None else run.forces.values,
           "profile": None if run.part_profile is None else np.asarray(run.part_profile[1], dtype=float)}
    return {k: v for k, v in out.items() if v is not None}


class ResidualModel:
    """Replays one run on the twin with any set of effects and returns normalised residuals.

    Simulations are cached per configuration of the simulated effects (`Effects.simulated`), so effects of the
    measurement model (time offset, drift, springback) cost no new simulation.

    Args:
        run: The measured run (never its truth).
        spec: The twin (robot, process and force model, K_q); its effects are replaced by those asked for, its
            placement by the run's.
    """

    def __init__(self, run: Run, spec: TwinSpec | None = None) -> None:
        self.run = run
        self.spec = (spec or TwinSpec()).replace(placement=run_placement(run.meta), effects=Effects())
        self.noise = estimate_noise(run)
        self._sims: dict[Effects, tuple[Twin, SimResult]] = {}
        cmd = run.commanded
        pass_cmd, _ = label_passes(cmd.values[:, 0], deadband_m=PASS_DEADBAND_M)

        def passes_at(t: np.ndarray) -> np.ndarray:
            return pass_cmd[np.clip(np.searchsorted(cmd.t_s, t), 0, len(cmd.t_s) - 1)]

        self.tracker_pass = passes_at(run.tracker.t_s)
        self.force_pass = passes_at(run.forces.t_s) if run.forces is not None else np.zeros(0, dtype=int)
        self.profile_side = (run.part_profile[0] >= 0).astype(int) if run.part_profile is not None else None

    def simulate(self, effects: Effects) -> tuple[Twin, SimResult]:
        """The twin and its simulation of the run's command for the simulated part of `effects` (cached)."""
        key = effects.simulated()
        if key not in self._sims:
            twin = self.spec.replace(effects=key).build()
            cached = next(iter(self._sims.values()))[1].q_ik if self._sims else None
            self._sims[key] = (
                twin,
                twin.simulate(self.run.commanded.t_s, self.run.commanded.values, q_ik=cached),
            )
        return self._sims[key]

    def streams(self, effects: Effects) -> dict[str, np.ndarray]:
        """Raw residuals measured - predicted: `position` [m] (m, 3), `force` [N] (k, 3), `profile` [m] (p,)."""
        twin, sim = self.simulate(effects)
        out = {"position": self.run.tracker.values - predict_tracker(sim, self.run.tracker.t_s, effects)}
        if self.run.forces is not None:
            out["force"] = self.run.forces.values - predict_forces(twin, sim, self.run.forces.t_s, effects)
        if self.run.part_profile is not None:
            x_m, z_m = self.run.part_profile
            x_pred, z_pred = predict_part_profile(twin, sim, effects)
            out["profile"] = z_m - np.interp(x_m, x_pred, z_pred)
        return out

    def vector(self, effects: Effects) -> np.ndarray:
        """All residuals stacked and divided by the noise: reduced chi-square 1 for pure noise."""
        streams = self.streams(effects)
        parts = [streams["position"].ravel() / self.noise.position_m]
        if "force" in streams:
            parts.append(streams["force"].ravel() / self.noise.force_n)
        if "profile" in streams:
            parts.append(streams["profile"] / self.noise.profile_m)
        return np.concatenate(parts)

    def folds(self) -> list[np.ndarray]:
        """Two boolean masks over `vector` rows: passes 1-2, 5-6, ... (and x < 0 of the profile), and the rest.

        Passes go in pairs so that each fold holds both travel directions: a fold of odd passes only would
        hold one direction, and no effect that depends on the direction could be scored out of sample.
        """
        rows = [np.repeat(((self.tracker_pass - 1) // 2) % 2 == 0, 3)]
        if self.run.forces is not None:
            rows.append(np.repeat(((self.force_pass - 1) // 2) % 2 == 0, 3))
        if self.profile_side is not None:
            rows.append(self.profile_side == 0)
        first = np.concatenate(rows)
        return [first, ~first]
