"""The dynamic lab's sensor chain: a laser tracker and a flange F/T sensor, each on its own clock.

Written apart from the twin's measurement model. Each sensor samples the physical log of the plant
(`simulate.DynamicLog`, every servo tick) through its own imperfections, all knobs (`knobs.py`):

* clock: a sample stamped t on the shared (controller) clock was taken when the sensor's own clock read t;
  the sensor clock runs at (1 + skew) and is ahead by `offset`, so the physical time is
  (t - offset) / (1 + skew), and the value shown is the state `latency` earlier still;
* tracker: the tool tip through a registration error of the tracker frame (a rotation about (1,1,1)/sqrt 3 at
  the sheet origin and a translation along (1,-1,1)/sqrt 3), white noise per axis, quantisation;
* F/T sensor: MuJoCo's `ft_force` (the force the sensor body exerts on the tool, in the sensor frame), the
  tool's weight tared (m g, as the thesis compensates it), sign flipped to the force of the sheet on the tool,
  a cross-talk matrix (off-diagonals +/- c), a bias on each axis, white noise, quantisation, and finally
  turned into the sheet frame with the sensor's orientation.

* part profile: the formed groove bottom after unclamping (the plant's own springback, `twin.lab.dynamic.sheet`),
  scanned every 0.5 mm over +/- 45 mm with white noise.

The stamps are uniform on the shared clock from t = 0, so the run format's rate and clock checks hold.
One `numpy` generator, seeded by the caller, draws the tracker noise, then the force noise, then the profile's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from twin.base.signals import interp_rows
from twin.lab.dynamic.knobs import Knobs
from twin.process.part.springback import scanned_profile
from twin.process.part.surface import surface_points

if TYPE_CHECKING:
    from twin.lab.dynamic.simulate import DynamicLog

GRAVITY_M_PER_S2 = 9.81
_REG_TRANSLATION_AXIS = np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0)
_REG_ROTATION_AXIS = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)
_CROSSTALK_PATTERN = np.array([[0.0, 1.0, -1.0], [-1.0, 0.0, 1.0], [1.0, -1.0, 0.0]])


def stamp_times(t_end_s: float, rate_hz: float) -> np.ndarray:
    """Stamps 0, 1/rate, ... not after `t_end_s` [s] (shared clock)."""
    n = int(np.floor(t_end_s * rate_hz + 1e-9)) + 1
    return np.arange(n) / rate_hz


def physical_times(stamps_s: np.ndarray, *, latency_s: float, offset_s: float, skew_ppm: float) -> np.ndarray:
    """When the state a sample shows really happened [s] (see the module docstring)."""
    return (np.asarray(stamps_s) - offset_s) / (1.0 + 1e-6 * skew_ppm) - latency_s


def _quantise(values: np.ndarray, quantum: float) -> np.ndarray:
    return values if quantum <= 0.0 else quantum * np.round(values / quantum)


def _rotation(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rodrigues' rotation matrix."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle_rad) * k + (1.0 - np.cos(angle_rad)) * (k @ k)


def tracker_reading(log: DynamicLog, knobs: Knobs, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The tracker stream: stamps [s] and tool tip in the (registered) sheet frame [m], shape (m, 3)."""
    stamps = stamp_times(float(log.t_s[-1]), knobs["tracker_rate_hz"])
    t_phys = physical_times(
        stamps,
        latency_s=knobs["tracker_latency_s"],
        offset_s=knobs["tracker_clock_offset_s"],
        skew_ppm=knobs["tracker_clock_skew_ppm"],
    )
    tip = interp_rows(t_phys, log.t_s, log.p_tip_sheet_m)
    R_reg = _rotation(_REG_ROTATION_AXIS, 1e-3 * knobs["tracker_reg_mrad"])
    tip = tip @ R_reg.T + 1e-3 * knobs["tracker_reg_mm"] * _REG_TRANSLATION_AXIS
    tip = tip + rng.normal(0.0, 1e-3 * knobs["tracker_noise_mm"], tip.shape)
    return stamps, _quantise(tip, 1e-3 * knobs["tracker_quantum_mm"])


def ft_reading(
    log: DynamicLog, knobs: Knobs, rng: np.random.Generator, tool_mass_kg: float
) -> tuple[np.ndarray, np.ndarray]:
    """The F/T stream: stamps [s] and the force of the sheet on the tool, sheet frame [N], shape (m, 3)."""
    stamps = stamp_times(float(log.t_s[-1]), knobs["ft_rate_hz"])
    t_phys = physical_times(
        stamps,
        latency_s=knobs["ft_latency_s"],
        offset_s=knobs["ft_clock_offset_s"],
        skew_ppm=knobs["ft_clock_skew_ppm"],
    )
    reading = interp_rows(t_phys, log.t_s, log.f_ft_local_n)
    R_world_ft = interp_rows(t_phys, log.t_s, log.R_world_ft.reshape(-1, 9)).reshape(-1, 3, 3)
    noise = rng.normal(0.0, knobs["ft_noise_n"], reading.shape)
    return stamps, ft_chain(reading, R_world_ft, noise, knobs, tool_mass_kg, log.R_world_sheet)


def ft_chain(reading_n: np.ndarray, R_world_ft: np.ndarray, noise_n: np.ndarray, knobs: Knobs, tool_mass_kg: float,
             R_world_sheet: np.ndarray) -> np.ndarray:
    """The F/T chain from MuJoCo's `ft_force` to the force of the sheet on the tool, sheet frame [N], (n, 3): the
    tool's weight tared, the sign flipped, cross-talk, bias, the white noise drawn by the caller, quantisation,
    the sensor's orientation. Shapes: readings (n, 3), orientations (n, 3, 3), noise (n, 3). The recorded stream
    (`ft_reading`) and the controller's online samples (`online.OnlineFt`) both go through it."""
    weight_world = np.array([0.0, 0.0, -GRAVITY_M_PER_S2 * tool_mass_kg])
    weight_local = np.einsum("nji,j->ni", R_world_ft, weight_world)
    f_local = -reading_n - weight_local  # sheet on tool = -(sensor on tool) - weight, static tare
    crosstalk = np.eye(3) + knobs["ft_crosstalk"] * _CROSSTALK_PATTERN
    f_local = f_local @ crosstalk.T + knobs["ft_bias_n"]
    f_local = _quantise(f_local + noise_n, knobs["ft_quantum_n"])
    return np.einsum("nij,nj->ni", R_world_ft, f_local) @ R_world_sheet  # world, then sheet frame


def profile_scan(log: DynamicLog, knobs: Knobs, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The part after unclamping (the plant's own springback, `twin.lab.dynamic.sheet`), scanned: x [m] and
    groove bottom z [m] along the centre line."""
    x_m, z_m = scanned_profile(log.formed_x_m, log.unloaded_z_m)
    return x_m, z_m + rng.normal(0.0, 1e-3 * knobs["profile_noise_mm"], z_m.shape)


def part_scan(log: DynamicLog, knobs: Knobs, rng: np.random.Generator) -> np.ndarray | None:
    """The part after unclamping, scanned as a point cloud [m], shape (n, 3), with the profile scanner's
    noise in z; None where the force model keeps no 2-D surface (the groove's table field)."""
    if log.formed_surface is None:
        return None
    points = surface_points(*log.formed_surface)
    points[:, 2] += rng.normal(0.0, 1e-3 * knobs["profile_noise_mm"], len(points))
    return points
