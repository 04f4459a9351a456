"""Compile the twin's two large kernels into numba's cache, once, before many processes need them.

Every compiled kernel is compiled on its first call and cached beside its module (`cache=True`). Until that cache
is written, each new process compiles it again: the replay loop (`twin.sim.compiled.loop.replay_loop`, with the
chain, field and ISF kernels it calls) takes ~20 s, the online cycle (`twin.sim.compiled.online.online_cycle`) ~7 s,
on this project's 2-core machine. A test suite on a fresh clone starts its workers, and they start CLI processes,
before either cache exists, so each compiles them side by side (measured: `make test` on a fresh clone 354 s, the
same run again 283 s). `make test` runs this first: the two compile at once, one process each, and every later
process loads them; the second process, done first, then compiles the rigid drives' and the plant sheets' kernels
(~18 s), which the suite would otherwise compile in its workers. Cold ~34 s in all; where the cache is already
written, the two processes' start-up (~2 s).

`python -m twin.apps.warm` prints what it compiled and how long it took.
"""

from __future__ import annotations

import multiprocessing
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np


def _replay() -> str:
    """A short quasi-static replay: the first groove pass, compiled loop."""
    from twin.process.toolpath.groove import groove_path
    from twin.sim.quasi_static import Twin
    from twin.sim.spec import TwinSpec

    path = groove_path()
    first = path.pass_index == 1
    Twin(TwinSpec()).simulate(path.t_s[first][:20].copy(), path.p_sheet_m[first][:20].copy())
    return "replay loop"


def _online() -> str:
    """One online compensator cycle at home under a groove-sized force."""
    from twin.sim.online import OnlineCompensator
    from twin.sim.spec import TwinSpec

    spec = TwinSpec()
    OnlineCompensator(spec).step(0.0, 0.0, np.array([300.0, -100.0, 1800.0]), np.array(spec.robot.q_home_rad))
    return "online cycle"


def _others() -> str:
    """The kernels a suite compiles beside those two, in the other process while the replay loop compiles: the rigid
    drives (`twin.sim.compiled.rigid`, the ISF model and the FE table) and the plant's sheets (laws 1 and 2) along
    the groove's first pass."""
    from twin.lab.dynamic.sheet import PlantSheet
    from twin.lab.dynamic.sheet_patch import PatchSheet
    from twin.process.description import Process
    from twin.process.force.isf import IsfForceField
    from twin.process.force.registry import build_force_field
    from twin.process.toolpath.groove import groove_path
    from twin.sim.compiled.rigid import rigid_forces

    path = groove_path()
    rigid_forces(IsfForceField(), path)
    rigid_forces(build_force_field(Process()), path)
    first = path.p_sheet_m[path.pass_index == 1]
    for sheet in (PlantSheet(Process(), 5e-5), PatchSheet(Process(), 5e-5)):
        sheet.start(first[0], 1.0)
        for p in first:
            sheet.force(p)
            sheet.advance(p)
    return "rigid drives and plant sheets"


def warm() -> list[str]:
    """Compile (or load) both kernels, each in its own process, at once; the names of the jobs done."""
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        jobs = [pool.submit(_replay), pool.submit(_online)]
        jobs.append(pool.submit(_others))  # queued behind the online cycle, in its process
        return [job.result() for job in jobs]


def main() -> int:
    """`python -m twin.apps.warm`."""
    start = time.perf_counter()
    done = warm()
    print(f"kernels compiled or loaded ({', '.join(done)}) in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
