"""The virtual lab: a richer plant than the twin that produces measured runs in the run format.

It is the twin of a `TwinSpec` whose effects (`twin.sim.effects`) are hidden from every reader,
a tracker at 50 Hz with white noise (sigma 0.02 mm, Krypton K-610 class, thesis sec. 3.2.1), a flange
force sensor at 30 Hz with white noise (sigma 5 N, ATI Omega160 at this range) and a profile scan of the
part after unclamping (sigma 0.02 mm). Every random draw comes from one `numpy` generator seeded by the
caller, in a fixed order, so the same seed gives identical files. The effects and noise levels go to
`truth.json`, which no reader of runs opens.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np

from twin.base.signals import uniform_times
from twin.process.part.surface import formed_surface, surface_points
from twin.process.toolpath.groove import groove_path
from twin.robot.description import robot_record
from twin.runs.format import Run, Stream, run_meta
from twin.sim.measure import predict_forces, predict_part_profile, predict_tracker
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec


@dataclass(frozen=True)
class LabSettings:
    """Stream rates and noise levels of the virtual lab.

    Attributes:
        tracker_rate_hz: Optical tracker rate [Hz] (thesis sec. 3.2.1: 50 Hz).
        ft_rate_hz: Force/torque sensor rate [Hz] (thesis sec. 3.3: 30 Hz in the robot tests).
        tracker_noise_m: Tracker white noise per axis [m].
        ft_noise_n: Force sensor white noise per axis [N].
        profile_noise_m: Part-profile scan white noise [m].
    """

    tracker_rate_hz: float = 50.0
    ft_rate_hz: float = 30.0
    tracker_noise_m: float = 2e-5
    ft_noise_n: float = 5.0
    profile_noise_m: float = 2e-5


def nominal_commanded() -> tuple[np.ndarray, np.ndarray]:
    """The ideal groove path U_ID as a commanded path: times [s] and sheet-frame tool tip [m]."""
    path = groove_path()
    return path.t_s, path.p_sheet_m


def run_lab(
    t_s: np.ndarray,
    p_cmd_sheet_m: np.ndarray,
    *,
    scenario: str,
    seed: int,
    spec: TwinSpec | None = None,
    settings: LabSettings | None = None,
) -> tuple[Run, dict[str, Any]]:
    """Run the commanded path on the lab plant and measure it.

    Args:
        t_s: Commanded sample times [s].
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], shape (n, 3).
        scenario: Label stored in meta.json (`nominal`, `compensated`, or free text).
        seed: Seed of the noise generator.
        spec: The lab's cell, its effects the hidden truth (robot, process and force model, placement, joint
            friction: zeros give the purely elastic robot, e.g. to test identification maths); default the
            thesis's cell without effects.
        settings: Rates and noise levels.

    Returns:
        The run (not yet written) and the truth record for `truth.json`.
    """
    spec = spec or TwinSpec()
    settings = settings or LabSettings()
    twin = spec.build()
    result = twin.simulate(t_s, p_cmd_sheet_m)
    measured = _measure(twin, result, settings, np.random.default_rng(seed))
    meta = run_meta(
        scenario=scenario,
        source="tx200-twin virtual lab",
        tracker_rate_hz=settings.tracker_rate_hz,
        sensor_rate_hz=settings.ft_rate_hz,
        seed=seed,
        tool_length_m=spec.robot.tool_length_m,
        placement=spec.placement,
        robot=robot_record(spec.robot),
        force_model=spec.process.force_model,
        process=spec.process,
    )
    commanded = Stream(np.asarray(t_s, dtype=float), np.asarray(p_cmd_sheet_m, dtype=float))
    run = Run(None, meta, commanded, measured.tracker, measured.forces, measured.part_profile, measured.part_scan)
    effects = spec.effects
    truth = {
        "effects": dict(effects.values),
        "effect_parameters": effects.named_parameters(),
        "lost_motion_takeup_m": effects.lost_motion_takeup_m,
        "settings": asdict(settings),
        "seed": seed,
        "force_model": spec.process.force_model,
        "max_deflection_mm": 1e3 * float(np.max(np.linalg.norm(result.deflection_sheet_m, axis=1))),
        "peak_force_n": float(np.max(np.linalg.norm(result.f_sheet_n, axis=1))),
    }
    return run, truth


class _Measured(NamedTuple):
    """What the lab's sensors read of one simulated run."""

    tracker: Stream
    forces: Stream
    part_profile: tuple[np.ndarray, np.ndarray]
    part_scan: np.ndarray | None


def _measure(twin: Twin, result: SimResult, settings: LabSettings, rng: np.random.Generator) -> _Measured:
    """Tracker, force sensor, profile scan and (where the force model keeps a surface) part scan, with noise, in
    the order of the draws that makes a seed give the same files."""
    effects = twin.effects
    t_end = float(result.t_s[-1])
    t_tracker = uniform_times(t_end, settings.tracker_rate_hz)
    t_sensor = uniform_times(t_end, settings.ft_rate_hz)
    tracker = predict_tracker(result, t_tracker, effects)
    tracker = tracker + rng.normal(0.0, settings.tracker_noise_m, tracker.shape)
    forces = predict_forces(twin, result, t_sensor, effects)
    forces = forces + rng.normal(0.0, settings.ft_noise_n, forces.shape)
    x_profile, z_profile = predict_part_profile(twin, result, effects)
    z_profile = z_profile + rng.normal(0.0, settings.profile_noise_m, z_profile.shape)
    scan = None  # a 2-D scan of the part where the force model keeps a surface (any part, not the groove table)
    surface = formed_surface(twin.field)
    if surface is not None:  # the `sheet_springback` effect takes the same further fraction of the depth as above
        x_m, y_m, z_m = surface
        scan = surface_points(x_m, y_m, z_m * (1.0 - effects.springback_ratio))
        scan[:, 2] += rng.normal(0.0, settings.profile_noise_m, len(scan))
    return _Measured(Stream(t_tracker, tracker), Stream(t_sensor, forces), (x_profile, z_profile), scan)


def load_test(
    loads_n: np.ndarray, *, seed: int, spec: TwinSpec | None = None, settings: LabSettings | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Thesis Method 1 load test at `home`: apply each load at the tool tip and measure the deflection.

    Args:
        loads_n: Loads on the tool tip, base frame [N], shape (m, 3) (Table 4.2 pushes the tool).
        seed: Seed of the tracker noise.
        spec: The lab's cell, its robot-side effects hidden; default the thesis's cell without effects.
        settings: Noise levels (tracker noise on each of the two readings, loaded and unloaded).

    Returns:
        The loads [N] and the measured deflections [m], shape (m, 3) each.
    """
    settings = settings or LabSettings()
    twin = (spec or TwinSpec()).build()
    rng = np.random.default_rng(seed)
    loads = np.asarray(loads_n, dtype=float)
    deflections = np.array([twin.static_deflection(f) for f in loads])
    noise = rng.normal(0.0, settings.tracker_noise_m, (2, *deflections.shape))
    return loads, deflections + noise[0] - noise[1]
