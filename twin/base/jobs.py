"""Where independent jobs run: this process, a process pool on every usable core, or a Dask distributed cluster.

`Jobs` is the one place that maps jobs to workers, used by the placement search and the Monte Carlo sweep.
A job is a module-level function `job(state, item)`; `state` is `prepare(setup)`, built once per worker (process
and thread) and kept there for every later item of the same `map` call, so a worker loads a robot or a twin
once, not per item. Results come back in the order of the items whatever order the workers finish in, so a
result never depends on where it ran.

Locally the pool is the standard library's `ProcessPoolExecutor` (no cluster to start: the jobs begin at once).
With `scheduler=ADDRESS` the same jobs run on an existing Dask distributed cluster (`distributed.Client`): an
existing engine for work beyond one machine, instead of a pool of our own. Its workers must have this package
installed. Dask is imported only then.
"""

from __future__ import annotations

import os
import threading
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from typing import Any

from twin.errors import InputError

#: How long a connection to a Dask scheduler may take before `--scheduler` is refused [s].
CONNECT_TIMEOUT_S = 10.0
#: Prepared worker states kept per worker process (older `map` calls' states are dropped).
KEPT_STATES = 4

_STATES: dict[tuple[str, int], Any] = {}


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _identity(setup: Any) -> Any:
    return setup


def _state(token: str, prepare: Callable[[Any], Any], setup: Any) -> Any:
    """The prepared state of one `map` call in this worker (process and thread), built on first use."""
    key = (token, threading.get_ident())
    if key not in _STATES:
        while len(_STATES) >= KEPT_STATES:
            _STATES.pop(next(iter(_STATES)))
        _STATES[key] = prepare(setup)
    return _STATES[key]


def _run(job: Callable[[Any, Any], Any], prepare: Callable[[Any], Any], token: str, setup: Any, index: int,
         item: Any) -> tuple[int, Any]:
    return index, job(_state(token, prepare, setup), item)


class Jobs:
    """Workers for independent jobs (module docstring); a context manager that closes its pool or client.

    Args:
        workers: Local worker processes; None: every usable core (1: in this process). Ignored with `scheduler`.
        scheduler: Address of a Dask distributed scheduler (e.g. `tcp://10.0.0.5:8786`); None: local.

    Raises:
        InputError: `workers` < 1, or no Dask scheduler answers at `scheduler` (names the address).
    """

    def __init__(self, workers: int | None = None, scheduler: str | None = None) -> None:
        self.scheduler = scheduler
        self._client: Any = None
        self._pool: Executor | None = None
        if scheduler is not None:
            self._client = _connect(scheduler)
            self.workers = max(1, sum(self._client.nthreads().values()))
            return
        self.workers = usable_cores() if workers is None else workers
        if self.workers < 1:
            raise InputError(f"workers = {workers!r}: expected an integer >= 1")

    @property
    def where(self) -> str:
        """Where the jobs run, in words."""
        if self._client is not None:
            return f"Dask cluster {self.scheduler} ({self.workers} worker threads)"
        return f"{self.workers} local process{'es' if self.workers > 1 else ''}"

    def map(
        self,
        job: Callable[[Any, Any], Any],
        items: Sequence[Any],
        setup: Any = None,
        *,
        prepare: Callable[[Any], Any] = _identity,
        progress: Callable[[int, int], None] | None = None,
    ) -> list[Any]:
        """`job(prepare(setup), item)` for every item, on the workers; the results in the order of `items`.

        Args:
            job: A module-level function (it is pickled to the workers).
            items: The jobs' inputs.
            setup: What every job shares (sent once to each Dask worker, with each task to a local process).
            prepare: Builds a worker's state from `setup`, once per worker (module-level function).
            progress: Called with (items done, items) as jobs complete.
        """
        token = uuid.uuid4().hex  # names this call's worker states; never enters a result
        n = len(items)
        out: list[Any] = [None] * n
        if self._client is not None:
            self._map_dask(job, items, setup, prepare, token, out, progress)
            return out
        if self.workers == 1 or n <= 1:
            for i, item in enumerate(items):
                out[i] = _run(job, prepare, token, setup, i, item)[1]
                if progress is not None:
                    progress(i + 1, n)
            _STATES.pop((token, threading.get_ident()), None)
            return out
        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=self.workers)
        futures = [self._pool.submit(_run, job, prepare, token, setup, i, item) for i, item in enumerate(items)]
        for done, future in enumerate(as_completed(futures), start=1):
            i, value = future.result()
            out[i] = value
            if progress is not None:
                progress(done, n)
        return out

    def _map_dask(self, job: Callable[[Any, Any], Any], items: Sequence[Any], setup: Any,
                  prepare: Callable[[Any], Any], token: str, out: list[Any],
                  progress: Callable[[int, int], None] | None) -> None:
        from distributed import as_completed as dask_completed

        client = self._client
        shared = client.scatter([setup], broadcast=True, hash=False)[0]  # a list: one future, not one per element
        futures = [client.submit(_run, job, prepare, token, shared, i, item, pure=False)
                   for i, item in enumerate(items)]
        for done, future in enumerate(dask_completed(futures, loop=client.loop), start=1):
            i, value = future.result()
            out[i] = value
            if progress is not None:
                progress(done, len(items))

    def close(self) -> None:
        """Shut the local pool down, or disconnect from the Dask scheduler (the cluster keeps running)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        if self._client is not None:
            self._client.close()
            self._client = None

    def __enter__(self) -> Jobs:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _connect(address: str) -> Any:
    """A `distributed.Client` of the scheduler at `address`.

    Raises:
        InputError: The address is ill-formed or no scheduler answers within `CONNECT_TIMEOUT_S` (names it).
    """
    expected = "expected the address of a running Dask scheduler, e.g. tcp://HOST:8786 (`dask scheduler`)"
    if not isinstance(address, str) or not address.strip():
        raise InputError(f"--scheduler {address!r}: {expected}")
    from distributed import Client

    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"--scheduler {address}: {exc}; {expected}") from None
