"""The twin's replay loop in compiled code (numba): MuJoCo's chain parameters, the table field, the same solver.

`compiled_replay` runs `Twin.simulate`'s per-sample loop in one compiled call when the model is a chain of
hinges (`chain.chain_arrays`) and the force model declares a kernel (`ForceField.compiled_kernel`): `table`, the
per-pass `SheetForceField` (bare or inside the tool's `SlidingFriction`), or `isf`, the height-map ISF model
`IsfForceField` (`isf`); it returns None otherwise and the twin
runs its Python loop, which calls MuJoCo per Newton iteration. Both give the same equilibria (`tests/test_compiled_replay.py`: ≤ 1e-9 m).
`online` is the online compensator's cycle (`twin.sim.online`), on the same chain.

The kernels are compiled on their first call and cached in this package's `__pycache__` (numba `cache=True`).
numba re-validates a cached kernel against its own source file only, not against the files of the kernels it
calls, so `drop_stale_kernels` clears the whole cache when any kernel source changed.
"""

from __future__ import annotations

import hashlib
import warnings
from pathlib import Path

import mujoco
import numpy as np

from twin.process.force.base import ForceField
from twin.process.force.isf import IsfForceField
from twin.process.force.table import SheetForceField, TableState
from twin.process.force.tool_friction import SlidingFriction, SlipState
from twin.sim.compiled.chain import chain_arrays
from twin.sim.compiled.field import FieldArrays, field_arrays, idle_field_arrays
from twin.sim.compiled.isf import IsfArrays, idle_isf_arrays, isf_arrays, write_back
from twin.sim.compiled.loop import replay_loop
from twin.sim.compiled.work import work_arrays
from twin.sim.giving_frame import GivingFrame
from twin.sim.result import LoopOutput

#: The numba kernel modules (their sources together key the kernel cache).
KERNEL_SOURCES = (
    "chain.py", "field.py", "isf.py", "isf_map.py", "learned.py", "loop.py", "online.py", "progress.py", "rigid.py",
    "sheet.py", "work.py",
)


def drop_stale_kernels(here: Path = Path(__file__).parent) -> bool:
    """Delete the cached kernels in `here/__pycache__` when the sources they were compiled from changed.

    Returns:
        True when the cache was dropped (a first run counts), False when it was current or cannot be written.
    """
    digest = hashlib.sha256(b"".join((here / name).read_bytes() for name in KERNEL_SOURCES)).hexdigest()
    cache = here / "__pycache__"
    stamp = cache / "kernels.sha256"
    try:
        if stamp.is_file() and stamp.read_text() == digest:
            return False
        for stale in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
            stale.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # a read-only install: numba keeps its own per-file check
        return False
    return True


drop_stale_kernels()

#: Samples of every compiled replay whose tool tips (loaded and unloaded) MuJoCo recomputes from the poses.
CHECKED_SAMPLES = 8
#: Largest tool-tip difference to MuJoCo's `mj_kinematics` a compiled replay may show [m].
CHECK_TOL_M = 1e-9


def _agrees_with_mujoco(
    model: mujoco.MjModel, data: mujoco.MjData, tcp_site: int, origin: np.ndarray, R_base_sheet: np.ndarray,
    q_nominal: np.ndarray, out: LoopOutput,
) -> bool:
    """MuJoCo's tool tip at a few of the replay's poses equals the compiled chain's (<= `CHECK_TOL_M`)."""
    for i in np.unique(np.linspace(0, len(out.qpos) - 1, CHECKED_SAMPLES).round().astype(int)):
        for qpos, p in ((out.qpos[i], out.p_sheet_m[i]), (q_nominal[i], out.p_unloaded_sheet_m[i])):
            data.qpos[:] = qpos
            mujoco.mj_kinematics(model, data)
            if np.abs(R_base_sheet.T @ (data.site_xpos[tcp_site] - origin) - p).max() > CHECK_TOL_M:
                return False
    return True


def _kernel_arrays(
    inner: ForceField, friction: bool, passes: np.ndarray, n: int
) -> tuple[FieldArrays, IsfArrays | None] | None:
    """The kernel's arrays for the force model's declared kernel (`ForceField.kernel`): the table field's
    and None, or an idle table and the ISF model's; None where no kernel applies."""
    if inner.kernel() == "isf" and isinstance(inner, IsfForceField) and not friction:
        isf = isf_arrays(inner, n)
        return None if isf is None else (idle_field_arrays(), isf)
    if inner.kernel() == "table" and isinstance(inner, SheetForceField):
        if passes.min() < 1 or passes.max() > inner.n_passes or np.any(np.diff(passes) < 0):
            return None  # the Python loop raises the field's own error
        return field_arrays(inner), None
    return None


def _hand_back(field: ForceField, table: bool, state: np.ndarray, n: int) -> None:
    """Give the field the scalar state the kernel left: the table's current pass, the tool's slip state."""
    inner = field.inner if isinstance(field, SlidingFriction) else field
    if table:
        inner.restore(TableState(int(state[0])))
    if isinstance(field, SlidingFriction) and n:
        field.restore(SlipState(float(state[1]), float(state[2]), int(state[3])))


def compiled_replay(
    model: mujoco.MjModel, tcp_site: int, field: ForceField, q_nominal: np.ndarray, passes: np.ndarray,
    dirs: np.ndarray, origin: np.ndarray, k_diag: np.ndarray, h_const: np.ndarray, predict_active_set: bool,
    data: mujoco.MjData | None = None, R_base_sheet: np.ndarray | None = None,
) -> LoopOutput | None:
    """Run the loop compiled, or None where it does not apply (the caller then runs the Python loop).

    Args:
        model, tcp_site: The twin's model (its current springs and `dof_frictionloss`) and its tool site's id.
        field: The twin's field, reset: a model declaring the kernel `table` (optionally inside `SlidingFriction`)
            or `isf`, either on a `GivingFrame` (its compliance runs in the kernel, `twin.sim.compiled.sheet`).
        q_nominal: Unloaded poses (all joints) [rad], shape (n, nv).
        passes, dirs: Pass (1..N of the field's history) and direction (+1/-1) per sample.
        origin, R_base_sheet: The sheet frame in the base [m] (None: the base axes).
        k_diag, h_const: Joint springs [N·m/rad], shape (nv,), and K + dg/dq [N·m/rad], shape (nv, nv).
        predict_active_set: As `EquilibriumSolver.predict_active_set` (the links held unless the field declares
            `extrapolated_start`).
        data: The model's data, for the check against MuJoCo (qpos and kinematics overwritten); None: no check.

    Returns:
        The loop's outputs, the field left as the Python loop leaves it. With `data`, MuJoCo recomputes the tool
        tip at `CHECKED_SAMPLES` poses; a difference over `CHECK_TOL_M` warns and returns None (Python replays).
    """
    friction = isinstance(field, SlidingFriction)
    inner = field.inner if isinstance(field, SlidingFriction) else field
    frame = inner.compliance if isinstance(inner, GivingFrame) else 0.0  # the clamping frame's, in the kernel
    inner = inner.inner if isinstance(inner, GivingFrame) else inner
    n, nv = q_nominal.shape
    passes = np.asarray(passes, dtype=np.int64)
    kernel = _kernel_arrays(inner, friction, passes, n)
    if kernel is None:
        return None
    table, isf = kernel
    rot = np.eye(3) if R_base_sheet is None else np.asarray(R_base_sheet, dtype=float)
    chain = chain_arrays(model, tcp_site, origin, rot)
    if chain is None:
        return None
    qpos, p_out, p_unloaded, f_out = np.zeros((n, nv)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    iters, jac, stiffness, state = np.zeros(n, dtype=np.int64), np.zeros((n, 3, nv)), np.zeros((n, 3, 3)), np.zeros(4)
    gain = 2.0 / field.reversal_m if isinstance(field, SlidingFriction) else 0.0
    status, sample = replay_loop(
        chain, table, idle_isf_arrays() if isf is None else isf, np.int64(0 if isf is None else 1),  # type: ignore[arg-type]
        np.ascontiguousarray(q_nominal, dtype=float), passes,
        np.asarray(dirs, dtype=np.int64), np.asarray(k_diag, dtype=float),
        np.ascontiguousarray(h_const, dtype=float), model.dof_frictionloss.copy(), bool(predict_active_set),
        not field.extrapolated_start,
        friction, float(gain), float(frame), qpos, p_out, p_unloaded, f_out, iters, jac, stiffness, state, work_arrays(nv),
    )
    if isf is not None and isinstance(inner, IsfForceField):
        write_back(inner, isf)
    if status == 1:
        raise np.linalg.LinAlgError(f"singular Newton matrix at sample {sample}, q = {qpos[max(sample - 1, 0)]!r}")
    _hand_back(field, isf is None, state, n)
    out = LoopOutput(qpos, p_out, p_unloaded, f_out, iters, jac, stiffness)
    if data is not None and not _agrees_with_mujoco(model, data, tcp_site, origin, rot, q_nominal, out):
        warnings.warn("the compiled chain disagrees with MuJoCo's kinematics: replaying in Python", stacklevel=2)
        field.reset()
        return None
    return out
