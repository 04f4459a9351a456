"""Springback: the part's profile after the tool has left, from the loaded profile and the contact forces.

While the tool presses, the groove bottom under it sits at the loaded, formed surface (the lower envelope of
the tool sphere, `SheetForceField.formed_z_m`). When the tool leaves, the sheet recovers elastically by the
force it last carried there over the sheet's unloading stiffness, the same k_unload that makes the force fall
when the tool lifts in the field (§2.3.1: the rigid CNC formed 8.7 mm of the 10 mm target):

    z_after(x) = min(z_loaded(x) + Fz_last(x) / k_unload, 0),

with Fz_last(x) the vertical force of the last sample whose tool sphere covered x. The recovery cannot lift
the sheet above its flat, unformed plane (z = 0). `form_rigidly` is a rigid machine's forming (the thesis's
CNC test, §2.3): the field driven exactly along the path, then this springback.
"""

from __future__ import annotations

import math

import numpy as np

from twin.errors import InputError
from twin.process.force.base import ForceField
from twin.process.toolpath.groove import ToolPath

#: A part-profile scan reads x in [-45, 45] mm (the 70 mm groove and a margin) every 0.5 mm [m].
PROFILE_HALF_SPAN_M = 0.045
PROFILE_SPACING_M = 5e-4


def scanned_profile(x_grid_m: np.ndarray, z_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A profile on its grid, read where a profile scan reads it: scan x [m] and z there [m]."""
    x_scan = np.arange(-PROFILE_HALF_SPAN_M, PROFILE_HALF_SPAN_M + 1e-12, PROFILE_SPACING_M)
    return x_scan, np.interp(x_scan, x_grid_m, z_m)


def last_contact_force(
    x_grid_m: np.ndarray, x_tool_m: np.ndarray, fz_n: np.ndarray, radius_m: float
) -> np.ndarray:
    """Vertical force of the last tool sample whose sphere covered each grid point [N].

    Args:
        x_grid_m: Profile grid along the groove, increasing [m], shape (g,).
        x_tool_m: Tool-tip x of the samples in time order [m], shape (n,).
        fz_n: Vertical force on the tool at those samples [N], shape (n,).
        radius_m: Tool sphere radius [m].

    Returns:
        Fz_last on the grid [N], 0 where the tool never passed, shape (g,).
    """
    x_grid = np.asarray(x_grid_m, dtype=float)
    x_tool = np.asarray(x_tool_m, dtype=float)
    fz = np.asarray(fz_n, dtype=float)
    if x_tool.shape != fz.shape or x_tool.ndim != 1:
        raise InputError(f"x_tool_m {x_tool.shape} and fz_n {fz.shape} must be equal-length 1-D arrays")
    if not (math.isfinite(radius_m) and radius_m > 0):
        raise InputError(f"radius_m = {radius_m!r}: expected a finite number > 0")
    lo = np.searchsorted(x_grid, x_tool - radius_m, side="left")
    hi = np.searchsorted(x_grid, x_tool + radius_m, side="right")
    out = np.zeros(len(x_grid))
    for i0, i1, f in zip(lo.tolist(), hi.tolist(), fz.tolist(), strict=True):
        out[i0:i1] = f
    return out


def unloaded_profile(
    x_grid_m: np.ndarray,
    z_loaded_m: np.ndarray,
    x_tool_m: np.ndarray,
    fz_n: np.ndarray,
    *,
    k_unload_n_per_m: float,
    radius_m: float,
) -> np.ndarray:
    """Groove bottom after the tool has left: loaded profile plus elastic recovery [m].

    Args:
        x_grid_m: Profile grid along the groove, increasing [m], shape (g,).
        z_loaded_m: Loaded, formed profile on that grid [m] (<= 0), shape (g,).
        x_tool_m: Tool-tip x of the run's samples in time order [m], shape (n,).
        fz_n: Vertical force on the tool at those samples [N], shape (n,).
        k_unload_n_per_m: Elastic unloading stiffness of the formed sheet [N/m].
        radius_m: Tool sphere radius [m].

    Returns:
        z after springback on the grid [m], shape (g,).
    """
    if not (math.isfinite(k_unload_n_per_m) and k_unload_n_per_m > 0):
        raise InputError(f"k_unload_n_per_m = {k_unload_n_per_m!r}: expected a finite number > 0")
    z_loaded = np.asarray(z_loaded_m, dtype=float)
    if z_loaded.shape != np.shape(x_grid_m):
        raise InputError(f"z_loaded_m {z_loaded.shape} must match x_grid_m {np.shape(x_grid_m)}")
    recovery = last_contact_force(x_grid_m, x_tool_m, fz_n, radius_m) / k_unload_n_per_m
    return np.minimum(z_loaded + recovery, 0.0)


def form_rigidly(path: ToolPath, field: ForceField) -> tuple[np.ndarray, np.ndarray]:
    """Drive the field rigidly along the path (a machine that follows it exactly), then let the part spring back.

    Args:
        path: The tool path, followed exactly.
        field: A sheet force field (reset here); afterwards its `formed_z_m` is the loaded part.

    Returns:
        The forces of the sheet on the tool along the path [N], shape (n, 3), and the part's section after
        springback on `field.x_grid_m` [m].
    """
    forces = field.rigid_forces(path)
    z_after = unloaded_profile(
        field.x_grid_m,
        field.formed_z_m,
        path.p_sheet_m[:, 0],
        forces[:, 2],
        k_unload_n_per_m=field.k_unload,
        radius_m=field.radius,
    )
    return forces, z_after
