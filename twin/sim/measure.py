"""Measurement model: what a tracker, a force sensor and a profile scan see of a simulated run.

Used twice with the same code: by the virtual lab (with its hidden effects and noise) and by the twin's
replay (with the effects the twin knows, no noise), so the two differ only by what the lab hides.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from twin.base.signals import interp_rows
from twin.process.part.springback import scanned_profile, unloaded_profile
from twin.sim.effects import EFFECTS, Effects
from twin.sim.result import SimResult

if TYPE_CHECKING:
    from twin.sim.quasi_static import Twin


def predict_tracker(result: SimResult, t_s: np.ndarray, effects: Effects) -> np.ndarray:
    """Tool tip the tracker reports at `t_s`, sheet frame [m], shape (m, 3) (no noise).

    The simulated tip is interpolated linearly in time (at the tracker clock's own time, `Instruments`), the
    instruments' registration and drift act on it, and every effect on the tracker adds its reading
    (`EffectSpec.tracker`, e.g. `tracker_drift`).
    """
    t_s = np.asarray(t_s, dtype=float)
    inst, t0 = effects.instruments, float(result.t_s[0])
    t_taken = np.clip(inst.tracker_times(t_s, t0), result.t_s[0], result.t_s[-1])
    tip = interp_rows(t_taken, result.t_s, result.p_sheet_m)
    reading = tip.copy() if inst.neutral else inst.tracker_reading(tip, t_s, t0)
    for name, value in effects.values.items():
        action = EFFECTS[name].tracker
        if action is not None:
            reading += action(t_s - result.t_s[0], tip, value)
    return reading


def predict_forces(twin: Twin, result: SimResult, t_s: np.ndarray, effects: Effects) -> np.ndarray:
    """Force the flange sensor reports at stamped times `t_s`: sheet on tool, sheet frame [N], shape (m, 3).

    With `stream_time_offset` tau the sample stamped t was measured at t - tau (clamped to the run), the
    instruments' F/T clock shifting it further; the instruments' bias, gain and cross-talk act on what it reads.
    """
    inst = effects.instruments
    t_stamped = np.asarray(t_s, dtype=float) - effects.stream_time_offset_s
    t_true = np.clip(inst.force_times(t_stamped, float(result.t_s[0])), result.t_s[0], result.t_s[-1])
    return inst.force_reading(twin.sensor_forces(result, t_true))


def predict_part_profile(twin: Twin, result: SimResult, effects: Effects) -> tuple[np.ndarray, np.ndarray]:
    """Groove centre line after unclamping [m].

    The loaded, formed bottom recovers elastically by the force the tool last carried there over the sheet's
    unloading stiffness (`twin.process.part.springback`, the twin's force model's own stiffness and tool), scaled by
    the model's `recovery_scale` and `depth_ratio` where it has them (1: none); the `sheet_springback` effect
    then takes away a further fraction of the depth.
    """
    sheet = twin.sheet_field
    params = getattr(sheet, "params", None)  # a model's own springback constants (`identify --springback`, `learn`)
    recovery_scale, depth_ratio = getattr(params, "recovery_scale", 1.0), getattr(params, "depth_ratio", 1.0)
    z_after = unloaded_profile(
        result.formed_x_m,
        result.formed_z_m,
        result.p_sheet_m[:, 0],
        result.f_sheet_n[:, 2],
        k_unload_n_per_m=sheet.k_unload / recovery_scale,
        radius_m=sheet.radius,
    )
    x_m, z_m = scanned_profile(result.formed_x_m, depth_ratio * z_after)
    return x_m, z_m * (1.0 - effects.springback_ratio)
