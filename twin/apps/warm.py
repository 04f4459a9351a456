"""Compile the kernels a test suite needs into numba's cache, once, before many processes need them.

Every compiled kernel is compiled on its first call and cached beside its module (`cache=True`). Until that cache
is written, each new process compiles it again. A suite on a fresh clone starts its workers, and they start CLI
processes, before any cache exists, so each compiled the same kernels side by side (CHANGELOG has the times).
`make test` runs this first, in two processes at once: one compiles the replay loop
(`twin.sim.compiled.loop.replay_loop`, with the chain, field and ISF kernels it calls; the longest compile) and then
the ISF model's rigid drive, which calls the same ISF kernels; the other the online cycle
(`twin.sim.compiled.online.online_cycle`) and then, whichever process is free first, the FE table's rigid drive
(`twin.sim.compiled.rigid`) and the plant's two sheet laws. Every later process loads them. Where the cache is
already written it costs the processes' start-up.

`python -m twin.apps.warm` prints what it compiled and how long it took.
"""

from __future__ import annotations

import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from twin.process.toolpath.groove import ToolPath


def _groove() -> tuple[ToolPath, np.ndarray, np.ndarray]:
    """The thesis groove, and its first pass: sample times [s] (n,) and tool tips [m] (n, 3), sheet frame."""
    from twin.process.toolpath.groove import groove_path

    path = groove_path()
    keep = path.pass_index == 1
    return path, path.t_s[keep], path.p_sheet_m[keep]


def _replay() -> str:
    """A short quasi-static replay (the first 20 samples of the groove's first pass): the compiled loop; then the ISF
    model's rigid drive along the groove, whose kernels the replay loop has just compiled in this process."""
    from twin.process.force.isf import IsfForceField
    from twin.sim.compiled.rigid import rigid_forces
    from twin.sim.quasi_static import Twin
    from twin.sim.spec import TwinSpec

    path, t_s, p_sheet_m = _groove()
    Twin(TwinSpec()).simulate(t_s[:20], p_sheet_m[:20])
    rigid_forces(IsfForceField(), path)
    return "replay loop"


def _online() -> str:
    """One online compensator cycle at home under a groove-sized force."""
    from twin.sim.online import OnlineCompensator
    from twin.sim.spec import TwinSpec

    spec = TwinSpec()
    OnlineCompensator(spec).step(0.0, 0.0, np.array([300.0, -100.0, 1800.0]), np.array(spec.robot.q_home_rad))
    return "online cycle"


def _others() -> str:
    """The other kernels a suite compiles: the FE table's rigid drive (`twin.sim.compiled.rigid`) along the groove,
    the plant's sheets (laws 1 and 2) along its first pass."""
    from twin.lab.dynamic.sheet import PlantSheet
    from twin.lab.dynamic.sheet_patch import PatchSheet
    from twin.process.description import Process
    from twin.process.force.registry import build_force_field
    from twin.sim.compiled.rigid import rigid_forces

    path, _, first = _groove()
    rigid_forces(build_force_field(Process()), path)
    for sheet in (PlantSheet(Process(), 5e-5), PatchSheet(Process(), 5e-5)):
        sheet.start(first[0], 1.0)
        for p in first:
            sheet.force(p)
            sheet.advance(p)
    return "rigid drives and plant sheets"


def warm() -> list[str]:
    """Compile (or load) the kernels in two processes at once (module docstring); the names of the jobs done."""
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        jobs = [pool.submit(job) for job in (_replay, _online, _others)]  # the third: the first process free
        return [job.result() for job in jobs]


def main() -> int:
    """`python -m twin.apps.warm`."""
    start = time.perf_counter()
    done = warm()
    print(f"kernels compiled or loaded ({', '.join(done)}) in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
