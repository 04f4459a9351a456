# mypy: disable-error-code="arg-type, assignment, return-value"
# (numba kernels: the numpy scalars they pass, typed non-literal on purpose, are not the annotated builtins)
"""A force model driven along a path by a rigid robot, in compiled code: `ForceField.rigid_forces`'s loop.

`rigid_forces(field, path)` resets the field, then at each sample takes the force at the path's point and
commits the point (`force`, then `advance`), as `twin.process.force.base.ForceField.rigid_forces` does in
Python, with the kernels of the replay loop: the table field's (`twin.sim.compiled.field`) and the ISF
model's (`twin.sim.compiled.isf`, the learned model's terms too). The field is left as the Python loop leaves
it (formed surface, pass, travel state). A model without a kernel, a table field asked for passes it does not
hold or out of order, or a direction other than ±1, runs the Python loop (which raises the field's own error);
`tests/test_rigid_forces.py` holds the two together (~1e-9 relative).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from twin.process.force.base import ForceField
from twin.process.force.isf import IsfForceField
from twin.process.force.table import SheetForceField, TableState
from twin.process.toolpath.groove import ToolPath
from twin.sim.compiled.field import FieldArrays, field_advance, field_arrays, field_force
from twin.sim.compiled.isf import IsfArrays, isf_advance_from, isf_arrays, isf_eval, write_back


@njit(cache=True)
def isf_rigid_loop(M: IsfArrays, p: np.ndarray, out: np.ndarray) -> None:
    """The ISF model along `p` (n, 3) [m]: each sample's force into `out` (n, 3) [N], then the commit."""
    f, S = np.zeros(3), np.zeros((3, 3))
    for i in range(p.shape[0]):
        x, y, z = p[i, 0], p[i, 1], p[i, 2]
        vx, vy = isf_eval(M, x, y, z, f, S)
        out[i, 0], out[i, 1], out[i, 2] = f[0], f[1], f[2]
        isf_advance_from(M, x, y, z, f[2], vx, vy)


@njit(cache=True)
def table_rigid_loop(F: FieldArrays, p: np.ndarray, passes: np.ndarray, dirs: np.ndarray, out: np.ndarray) -> int:
    """The table field along `p` (n, 3) [m] with its passes and directions: each sample's force into `out`
    (n, 3) [N] (Fy = 0), then the commit; returns the current pass at the end."""
    current = np.int64(0)  # typed, not literal: the field kernels compile once
    for i in range(p.shape[0]):
        x, z = p[i, 0], p[i, 2]
        fx, fz = field_force(F, current, x, z, passes[i], dirs[i])
        out[i, 0], out[i, 1], out[i, 2] = fx, 0.0, fz
        current = field_advance(F, current, x, z, passes[i])
    return current


def rigid_forces(field: ForceField, path: ToolPath) -> np.ndarray:
    """`field.rigid_forces(path)` in compiled code where the model declares a kernel (module docstring).

    Args:
        field: The force model (its state is reset first).
        path: The path, with pass labels and directions.

    Returns:
        Forces exerted by the sheet on the tool at each sample [N], shape (n, 3), sheet frame.
    """
    p = np.array(path.p_sheet_m, dtype=float, order="C")  # a writable copy: a read-only path is another compile
    n = p.shape[0]
    out = np.empty((n, 3))
    if n and field.kernel() == "isf" and isinstance(field, IsfForceField):
        field.reset()
        arrays = isf_arrays(field, n)
        if arrays is not None:
            isf_rigid_loop(arrays, p, out)
            write_back(field, arrays)
            return out
    if n and field.kernel() == "table" and isinstance(field, SheetForceField):
        passes = np.array(path.pass_index, dtype=np.int64)  # writable copies, as `p`
        dirs = np.array(path.direction, dtype=np.int64)
        if (passes.min() >= 1 and passes.max() <= field.n_passes and not np.any(np.diff(passes) < 0)
                and np.all(np.abs(dirs) == 1)):
            field.reset()
            current = table_rigid_loop(field_arrays(field), p, passes, dirs, out)
            field.restore(TableState(int(current)))
            return out
    return field.rigid_forces(path)
