"""The thesis's CNC validation as a lab scenario (§2.3): the groove, or any path, formed on a rigid machine.

The FAMUP MCX500 (accuracy 15 µm) follows the ideal path exactly, so the tool is where it was commanded and the
sheet's forces are those of the field driven rigidly (the FE history's own forces, with the field's state).
The force sensor samples at 10 Hz on the CNC (§2.3, 30 Hz on the robot); the machine's position is recorded at
50 Hz with its 15 µm accuracy as white noise; the part is scanned after unclamping, its depth set by the
sheet's elastic recovery (`twin.process.part.springback`; the thesis measured 8.7 mm of the 10 mm target, §2.3.1):
the section y = 0 as a profile and, where the force model keeps a surface (any part), a scan of that surface.
The run records the process it was formed with (`meta.json`'s `process`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from twin.base.signals import interp_rows, uniform_times
from twin.process.description import Process
from twin.process.force.registry import build_force_field
from twin.process.part.springback import form_rigidly, scanned_profile
from twin.process.part.surface import formed_surface, surface_points
from twin.process.toolpath.groove import ToolPath, groove_path
from twin.robot.description import load_robot
from twin.runs.format import Run, Stream, run_meta


@dataclass(frozen=True)
class CncSettings:
    """Rates and noise of the CNC test.

    Attributes:
        tracker_rate_hz: Machine position recording rate [Hz] (the run's tracker.csv, as for the labs).
        ft_rate_hz: Force sensor rate on the CNC [Hz] (thesis §2.3: 10 Hz).
        tracker_noise_m: Machine accuracy as white noise per axis [m] (FAMUP MCX500: 15 µm).
        ft_noise_n: Force sensor white noise per axis [N].
        profile_noise_m: Part-profile scan white noise [m].
    """

    tracker_rate_hz: float = 50.0
    ft_rate_hz: float = 10.0
    tracker_noise_m: float = 15e-6
    ft_noise_n: float = 5.0
    profile_noise_m: float = 2e-5


def run_cnc(
    *,
    seed: int,
    path: ToolPath | None = None,
    process: Process | None = None,
    settings: CncSettings | None = None,
) -> tuple[Run, dict[str, Any]]:
    """Form a path on the rigid CNC and measure it.

    Args:
        seed: Seed of the noise generator.
        path: Ideal path (any part); default the thesis's groove.
        process: The sheet, tool and force model (and its FE history); default the thesis's.
        settings: Rates and noise levels.

    Returns:
        The run (not yet written) and the truth record for `truth.json`.
    """
    settings = settings or CncSettings()
    path = path or groove_path()
    process = process or Process()
    field = build_force_field(process)
    forces, z_after = form_rigidly(path, field)
    rng = np.random.default_rng(seed)
    t_end = float(path.t_s[-1])
    t_pos = uniform_times(t_end, settings.tracker_rate_hz)
    t_sensor = uniform_times(t_end, settings.ft_rate_hz)
    position = interp_rows(t_pos, path.t_s, path.p_sheet_m)
    position = position + rng.normal(0.0, settings.tracker_noise_m, position.shape)
    f_sensor = interp_rows(t_sensor, path.t_s, forces)
    f_sensor = f_sensor + rng.normal(0.0, settings.ft_noise_n, f_sensor.shape)
    x_profile, z_profile = scanned_profile(field.x_grid_m, z_after)
    z_profile = z_profile + rng.normal(0.0, settings.profile_noise_m, z_profile.shape)
    scan = None  # where the force model keeps a 2-D surface (any part, not the groove's table field)
    surface = formed_surface(field)
    if surface is not None:
        scan = surface_points(*surface)
        scan[:, 2] += rng.normal(0.0, settings.profile_noise_m, len(scan))
    meta = run_meta(
        scenario="cnc",
        source="tx200-twin virtual lab: rigid CNC (FAMUP MCX500 class, thesis sec. 2.3)",
        tracker_rate_hz=settings.tracker_rate_hz,
        sensor_rate_hz=settings.ft_rate_hz,
        seed=seed,
        tool_length_m=load_robot().tool_length_m,
        force_model=process.force_model,
        process=process,
    )
    run = Run(
        directory=None,
        meta=meta,
        commanded=Stream(path.t_s, path.p_sheet_m),
        tracker=Stream(t_pos, position),
        forces=Stream(t_sensor, f_sensor),
        part_profile=(x_profile, z_profile),
        part_scan=scan,
    )
    truth = {
        "machine": "rigid CNC",
        "settings": asdict(settings),
        "seed": seed,
        "k_unload_n_per_m": field.k_unload,
        "loaded_depth_mm": -1e3 * float(np.min(field.formed_z_m)),
        "formed_depth_after_springback_mm": -1e3 * float(np.min(z_after)),
        "peak_fz_n": float(np.max(forces[:, 2])),
    }
    return run, truth
