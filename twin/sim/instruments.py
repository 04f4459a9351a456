"""What the cell's instruments add to what they measure: the F/T sensor's and the tracker's calibration, carried.

The effect vocabulary (`twin.sim.effects`) holds one scalar per effect, which suits the robot and the sheet; a
sensor re-tared, re-mounted or re-calibrated, and a tracker re-registered or on a clock of its own, are vectors.
`Instruments` holds them, in the forms of the discrepancy families that find them
(`twin.analysis.discrepancy.families.sensors`, `.tracker`), so what `discrepancy` names is what a model file
carries and `replay --model` applies (`twin.sim.measure`):

| field | unit | the reading of ... |
|---|---|---|
| force_bias_n | N (x, y, z) | the F/T sensor: f_read = (I + M + diag(g - 1)) f + b, sheet frame |
| force_gain | - (x, y, z) | g: its calibration per axis |
| force_crosstalk | - (x<-y, x<-z, y<-x, y<-z, z<-x, z<-y) | M, zero on its diagonal (a rotated mount, to first order) |
| force_clock_offset_s, force_clock_rate | s, - | a force sample stamped t was measured at t - offset - rate (t - t0) |
| tracker_rotation_mrad, tracker_shift_mm | mrad, mm | the tracker: p_read = R(w) p + s, about the sheet origin |
| tracker_drift_mm_per_s | mm/s (x, y, z) | ... plus (t - t0) x rate |
| tracker_time_offset_s, tracker_time_rate | s, - | a tracker sample stamped t was taken at t - offset - rate (t - t0) |

t0 is the run's first commanded time. Neutral values switch each off; `Instruments()` changes nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from twin.errors import InputError

#: (row, column) of each `force_crosstalk` ratio in M.
CROSSTALK_PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
#: Field -> (length, neutral value, unit, largest magnitude of a plausible value).
FIELDS: dict[str, tuple[int, float, str, float]] = {
    "force_bias_n": (3, 0.0, "N", 1e4),
    "force_gain": (3, 1.0, "-", 10.0),
    "force_crosstalk": (6, 0.0, "-", 0.5),
    "force_clock_offset_s": (1, 0.0, "s", 10.0),
    "force_clock_rate": (1, 0.0, "-", 0.05),
    "tracker_rotation_mrad": (3, 0.0, "mrad", 50.0),
    "tracker_shift_mm": (3, 0.0, "mm", 50.0),
    "tracker_drift_mm_per_s": (3, 0.0, "mm/s", 1.0),
    "tracker_time_offset_s": (1, 0.0, "s", 10.0),
    "tracker_time_rate": (1, 0.0, "-", 0.05),
}


@dataclass(frozen=True)
class Instruments:
    """The instruments' calibration the twin carries (module docstring); every field a tuple of floats."""

    force_bias_n: tuple[float, ...] = (0.0, 0.0, 0.0)
    force_gain: tuple[float, ...] = (1.0, 1.0, 1.0)
    force_crosstalk: tuple[float, ...] = (0.0,) * 6
    force_clock_offset_s: tuple[float, ...] = (0.0,)
    force_clock_rate: tuple[float, ...] = (0.0,)
    tracker_rotation_mrad: tuple[float, ...] = (0.0, 0.0, 0.0)
    tracker_shift_mm: tuple[float, ...] = (0.0, 0.0, 0.0)
    tracker_drift_mm_per_s: tuple[float, ...] = (0.0, 0.0, 0.0)
    tracker_time_offset_s: tuple[float, ...] = (0.0,)
    tracker_time_rate: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        for name, (n, _, unit, bound) in FIELDS.items():
            given = getattr(self, name)
            try:
                arr = np.atleast_1d(np.asarray(given, dtype=float))
            except (TypeError, ValueError):
                raise InputError(f"instruments.{name} = {given!r}: expected {n} number(s) [{unit}]") from None
            neutral = FIELDS[name][1]
            if arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(np.abs(arr - neutral) > bound):
                raise InputError(f"instruments.{name} = {given!r}: expected {n} finite number(s) [{unit}] within "
                                 f"{bound:g} of {neutral:g} (a plausible calibration)")
            object.__setattr__(self, name, tuple(float(v) for v in arr))

    @property
    def neutral(self) -> bool:
        """Whether the instruments read the truth (every field neutral)."""
        return self == Instruments()

    def changed(self) -> dict[str, list[float]]:
        """The fields off their neutral value, as lists (the model file's `instruments`)."""
        return {f.name: list(getattr(self, f.name)) for f in fields(self)
                if getattr(self, f.name) != getattr(Instruments(), f.name)}

    def plus(self, increments: Mapping[str, Any]) -> Instruments:
        """These instruments with field increments added (a gain's increment multiplies it)."""
        values: dict[str, Any] = {}
        for name, inc in increments.items():
            if name not in FIELDS:
                raise InputError(f"instrument field {name!r}; valid: {', '.join(FIELDS)}")
            now, add = np.asarray(getattr(self, name)), np.atleast_1d(np.asarray(inc, dtype=float))
            values[name] = tuple(now * add) if name == "force_gain" else tuple(now + add)
        return replace(self, **values)

    def reset(self, names: list[str], to: Instruments) -> Instruments:
        """A copy with the fields `names` taken from `to`."""
        return replace(self, **{n: getattr(to, n) for n in names})

    @classmethod
    def from_json(cls, entry: Any, where: str) -> Instruments:
        """The model file's `instruments` object (fields left out are neutral).

        Raises:
            InputError: Not an object, an unknown field or a bad value (naming `where`).
        """
        if not isinstance(entry, Mapping):
            raise InputError(f"{where}: instruments = {entry!r}: expected an object of {', '.join(FIELDS)}")
        unknown = sorted(set(entry) - set(FIELDS))
        if unknown:
            raise InputError(f"{where}: instruments has unknown field(s) {unknown}; valid: {', '.join(FIELDS)}")
        try:
            return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in entry.items()})
        except (InputError, TypeError) as exc:
            raise InputError(f"{where}: {exc}") from None

    # -- what the instruments read ----------------------------------------------------------------------------

    def force_times(self, t_s: np.ndarray, t0_s: float) -> np.ndarray:
        """When the force samples stamped `t_s` were measured [s] (the F/T clock; `stream_time_offset` aside)."""
        return t_s - self.force_clock_offset_s[0] - self.force_clock_rate[0] * (t_s - t0_s)

    def _force_matrix(self) -> np.ndarray | None:
        """I + M + diag(g - 1) of the F/T reading (module docstring), or None where the sensor reads the truth."""
        if self.force_gain == (1.0, 1.0, 1.0) and not any(self.force_crosstalk) and not any(self.force_bias_n):
            return None
        m = np.diag(self.force_gain)
        for (i, j), ratio in zip(CROSSTALK_PAIRS, self.force_crosstalk, strict=True):
            m[i, j] += ratio
        return m

    def force_reading(self, f_n: np.ndarray) -> np.ndarray:
        """What the F/T sensor reads of forces `f_n` [N], shape (k, 3)."""
        m = self._force_matrix()
        return f_n if m is None else f_n @ m.T + np.asarray(self.force_bias_n)

    def force_from_reading(self, f_read_n: np.ndarray) -> np.ndarray:
        """The forces [N], shape (k, 3), the F/T sensor read as `f_read_n`: `force_reading` undone (a cell's
        measured forces taken back to the sheet's, with the calibration a model file carries)."""
        m, f_read = self._force_matrix(), np.asarray(f_read_n, dtype=float)
        return f_read if m is None else np.linalg.solve(m, (f_read - np.asarray(self.force_bias_n)).T).T

    def tracker_times(self, t_s: np.ndarray, t0_s: float) -> np.ndarray:
        """When the tracker samples stamped `t_s` were taken [s]."""
        return t_s - self.tracker_time_offset_s[0] - self.tracker_time_rate[0] * (t_s - t0_s)

    def tracker_reading(self, p_sheet_m: np.ndarray, t_s: np.ndarray, t0_s: float) -> np.ndarray:
        """What the tracker reads of tips `p_sheet_m` at stamped times `t_s` [m], shape (m, 3)."""
        out = p_sheet_m @ rotation(1e-3 * np.asarray(self.tracker_rotation_mrad)).T
        out = out + 1e-3 * np.asarray(self.tracker_shift_mm)
        return out + np.outer(t_s - t0_s, 1e-3 * np.asarray(self.tracker_drift_mm_per_s))


def rotation(w_rad: np.ndarray) -> np.ndarray:
    """The rotation matrix of rotation vector `w_rad` (Rodrigues), shape (3, 3)."""
    angle = float(np.linalg.norm(w_rad))
    if angle < 1e-15:
        return np.eye(3)
    k = np.asarray(w_rad) / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * kx + (1.0 - np.cos(angle)) * kx @ kx
