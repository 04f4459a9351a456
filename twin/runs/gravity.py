"""Force sensor readings to the run format's force: sensor frame -> sheet frame, tool weight removed.

Assumptions (ISF with a vertical tool, thesis §3.3): the sensor's orientation in the sheet frame is fixed
during the run (`R_sheet_sensor`, from the mapping), and the sensor reads the force acting on everything
below its measuring plane, i.e. the sheet's force on the tool plus the tool's weight:

    f_sensor = R_sheet_sensorᵀ (f_contact_sheet + m g_sheet)

so `f_contact_sheet = R_sheet_sensor f_sensor - m g_sheet`. The tool's centre of mass only moves the
torque (`c × m g`), which the run format does not carry; it is checked and recorded, not applied.
"""

from __future__ import annotations

import numpy as np

from twin.errors import InputError


def contact_force_sheet(
    f_sensor_n: np.ndarray, R_sheet_sensor: np.ndarray, tool_mass_kg: float, gravity_sheet_m_s2: np.ndarray
) -> np.ndarray:
    """The sheet's force on the tool in the sheet frame, from sensor readings that include the tool weight.

    Args:
        f_sensor_n: Sensor force readings in the sensor frame, shape (n, 3) [N].
        R_sheet_sensor: Sensor axes in the sheet frame, a proper rotation, shape (3, 3).
        tool_mass_kg: Mass below the sensor's measuring plane [kg].
        gravity_sheet_m_s2: Gravity vector in the sheet frame, shape (3,) [m/s^2].

    Returns:
        Contact force, sheet frame, shape (n, 3) [N].
    """
    f = np.asarray(f_sensor_n, dtype=float)
    R = np.asarray(R_sheet_sensor, dtype=float)
    g = np.asarray(gravity_sheet_m_s2, dtype=float)
    if f.ndim != 2 or f.shape[1] != 3 or R.shape != (3, 3) or g.shape != (3,):
        raise InputError(f"shapes f {f.shape}, R {R.shape}, g {g.shape}; expected (n, 3), (3, 3), (3,)")
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise InputError(f"R_sheet_sensor is not a proper rotation: {R.tolist()}")
    if tool_mass_kg < 0:
        raise InputError(f"tool_mass_kg = {tool_mass_kg}, expected >= 0 [kg]")
    return f @ R.T - tool_mass_kg * g


def sensor_reading(
    f_contact_sheet_n: np.ndarray,
    R_sheet_sensor: np.ndarray,
    tool_mass_kg: float,
    gravity_sheet_m_s2: np.ndarray,
) -> np.ndarray:
    """What the sensor reads for a given contact force: the inverse of `contact_force_sheet`.

    Args:
        f_contact_sheet_n: Sheet's force on the tool, sheet frame, shape (n, 3) [N].
        R_sheet_sensor: Sensor axes in the sheet frame, shape (3, 3).
        tool_mass_kg: Mass below the sensor's measuring plane [kg].
        gravity_sheet_m_s2: Gravity vector in the sheet frame, shape (3,) [m/s^2].

    Returns:
        Sensor readings in the sensor frame, shape (n, 3) [N].
    """
    f = np.asarray(f_contact_sheet_n, dtype=float) + tool_mass_kg * np.asarray(
        gravity_sheet_m_s2, dtype=float
    )
    return f @ np.asarray(R_sheet_sensor, dtype=float)
