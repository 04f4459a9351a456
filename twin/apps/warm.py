"""Compile the twin's two large kernels into numba's cache, once, before many processes need them.

Every compiled kernel is compiled on its first call and cached beside its module (`cache=True`). Until that cache
is written, each new process compiles it again: the replay loop (`twin.sim.compiled.loop.replay_loop`, with the
chain, field and ISF kernels it calls) takes ~20 s, the online cycle (`twin.sim.compiled.online.online_cycle`) ~7 s,
on this project's 2-core machine. A test suite on a fresh clone starts its workers, and they start CLI processes,
before either cache exists, so each compiles them side by side (measured: `make test` on a fresh clone 354 s, the
same run again 283 s). `make test` runs this first: the two compile at once, one process each, and every later
process loads them. Where the cache is already written it takes the two processes' start-up (~3 s).

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


def warm() -> list[str]:
    """Compile (or load) both kernels, each in its own process, at once; the names of the jobs done."""
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        return [job.result() for job in [pool.submit(_replay), pool.submit(_online)]]


def main() -> int:
    """`python -m twin.apps.warm`."""
    start = time.perf_counter()
    done = warm()
    print(f"kernels compiled or loaded ({', '.join(done)}) in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
