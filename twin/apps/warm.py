"""Compile the kernels a test suite needs into numba's cache, once, before many processes need them.

Every compiled kernel is compiled on its first call and cached beside its module (`cache=True`). Until that cache
is written, each new process compiles it again. A suite on a fresh clone starts its workers, and they start CLI
processes, before any cache exists, so each compiled the same kernels side by side (CHANGELOG has the times).
`make test` runs this first, in two processes at once. The replay loop (`twin.sim.compiled.loop.replay_loop`) is the
longest compile, and a kernel it calls that is already in the cache is loaded, not compiled again (its ISF kernels are a
quarter of it). So one process compiles the online cycle (`twin.sim.compiled.online.online_cycle`, with the chain
kernels the loop calls too), waits for the ISF kernels (at most `WAIT_S`) and compiles the replay loop on them; the
other compiles the ISF kernels (through the ISF model's rigid drive), then the FE table's rigid drive
(`twin.sim.compiled.rigid`) and the plant's two sheet laws. Every later process loads them.
Where the cache is already written it costs the processes' start-up.

`python -m twin.apps.warm` prints what it compiled and how long it took.
"""

from __future__ import annotations

import multiprocessing
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
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


#: The longest the replay loop's process waits for the ISF kernels before it compiles them itself [s].
WAIT_S = 120.0


def _isf() -> str:
    """The ISF model's rigid drive along the groove: the ISF kernels the replay loop calls."""
    from twin.process.force.isf import IsfForceField
    from twin.sim.compiled.rigid import rigid_forces

    rigid_forces(IsfForceField(), _groove()[0])
    return "ISF kernels"


def _table() -> str:
    """The FE table's rigid drive along the groove (`twin.sim.compiled.rigid`)."""
    from twin.process.description import Process
    from twin.process.force.registry import build_force_field
    from twin.sim.compiled.rigid import rigid_forces

    rigid_forces(build_force_field(Process()), _groove()[0])
    return "FE table's rigid drive"


def _replay() -> str:
    """A short quasi-static replay (the first 20 samples of the groove's first pass): the compiled loop."""
    from twin.sim.quasi_static import Twin
    from twin.sim.spec import TwinSpec

    _, t_s, p_sheet_m = _groove()
    Twin(TwinSpec()).simulate(t_s[:20], p_sheet_m[:20])
    return "replay loop"


def _online() -> str:
    """One online compensator cycle at home under a groove-sized force."""
    from twin.sim.online import OnlineCompensator
    from twin.sim.spec import TwinSpec

    spec = TwinSpec()
    OnlineCompensator(spec).step(0.0, 0.0, np.array([300.0, -100.0, 1800.0]), np.array(spec.robot.q_home_rad))
    return "online cycle"


def _sheets() -> str:
    """The plant's sheets (laws 1 and 2) along the groove's first pass."""
    from twin.lab.dynamic.sheet import PlantSheet
    from twin.lab.dynamic.sheet_patch import PatchSheet
    from twin.process.description import Process

    _, _, first = _groove()
    for sheet in (PlantSheet(Process(), 5e-5), PatchSheet(Process(), 5e-5)):
        sheet.start(first[0], 1.0)
        for p in first:
            sheet.force(p)
            sheet.advance(p)
    return "plant sheets"


def _loop_side(ready: str, wait_s: float = WAIT_S) -> list[str]:
    """The online cycle, then the replay loop once the file `ready` says the ISF kernels are cached."""
    done = [_online()]
    deadline = time.monotonic() + wait_s
    while not Path(ready).exists() and time.monotonic() < deadline:  # bounded: at most wait_s
        time.sleep(0.05)
    return [*done, _replay()]


def _kernel_side(ready: str) -> list[str]:
    """The ISF kernels (then the file `ready`, written even where they failed), the FE table's drive, the sheets."""
    try:
        done = [_isf()]
    finally:
        Path(ready).touch()
    return [*done, _table(), _sheets()]


def warm() -> list[str]:
    """Compile (or load) the kernels in two processes at once (module docstring); the names of the jobs done."""
    with tempfile.TemporaryDirectory(prefix="tx200-warm-") as tmp, \
            ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        ready = str(Path(tmp) / "isf-ready")
        jobs = [pool.submit(_loop_side, ready), pool.submit(_kernel_side, ready)]
        return [name for job in jobs for name in job.result()]


def main() -> int:
    """`python -m twin.apps.warm`."""
    start = time.perf_counter()
    done = warm()
    print(f"kernels compiled or loaded ({', '.join(done)}) in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
