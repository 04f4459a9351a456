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

import ipaddress
import os
import re
import socket
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from typing import Any

from twin.errors import InputError

#: How long a connection to a Dask scheduler may take before `--scheduler` is refused [s]: the whole check (name
#: lookup, TCP probe, Dask handshake) ends within it, so a wrong address costs seconds, not a hang.
CONNECT_TIMEOUT_S = 5.0
#: Address schemes `--scheduler` accepts: Dask's TCP transport (TLS would need certificates no option passes; a bare
#: HOST:PORT is `tcp://`) and `inproc://` (a cluster started in this process, e.g. `LocalCluster(processes=False)`).
SCHEMES = ("tcp://", "inproc://")  # with their separator: a bare "tcp" reads as the robot's site of that name
_INPROC = re.compile(r"^[\w.:-]+/\d+/\d+$")
_EXPECTED = "expected the address of a running Dask scheduler, e.g. tcp://HOST:8786 (`dask scheduler`)"
_HOST = re.compile(r"^(?=.{1,253}$)[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?(?:\.[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}"
                   r"[A-Za-z0-9])?)*$")
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


def scheduler_address(address: object) -> tuple[str, str, int]:
    """The (scheme, host, port) of a `--scheduler` address, checked by its form alone (nothing is contacted).

    Accepted: `tcp://HOST:PORT` or `HOST:PORT`, HOST a name or an IPv4 address, or an IPv6
    address in brackets (`tcp://[::1]:8786`), PORT 1..65535; `inproc://HOST/PID/N` (returned with port 0), a
    cluster started in this process.

    Raises:
        InputError: Any other form (names the address as typed and the part at fault).
    """
    if not isinstance(address, str) or not address.strip():
        raise InputError(f"--scheduler {address!r}: empty; {_EXPECTED}")
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = SCHEMES[0][:-3], address
    if scheme + "://" not in SCHEMES:
        raise InputError(f"--scheduler {address}: unknown address scheme {scheme!r} (accepted: "
                         f"{', '.join(SCHEMES)}); {_EXPECTED}")
    if scheme + "://" == SCHEMES[1]:
        if not _INPROC.match(rest):
            raise InputError(f"--scheduler {address}: expected inproc://HOST/PID/N (an in-process cluster's address)")
        return scheme, rest, 0
    host, colon, port_text = rest.rpartition(":")
    if not colon or not host:
        raise InputError(f"--scheduler {address}: missing port number (HOST:PORT); {_EXPECTED}")
    if not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
        raise InputError(f"--scheduler {address}: port {port_text!r} is not an integer in 1..65535; {_EXPECTED}")
    if host.startswith("[") and host.endswith("]"):
        try:
            host = str(ipaddress.IPv6Address(host[1:-1]))
        except ValueError:
            raise InputError(f"--scheduler {address}: {host} is not an IPv6 address; {_EXPECTED}") from None
    elif not _HOST.match(host):
        raise InputError(f"--scheduler {address}: host {host!r} is not a host name or IPv4 address; {_EXPECTED}")
    return scheme, host, int(port_text)


def _within(seconds: float, what: Callable[[], Any]) -> tuple[bool, Any]:
    """Run `what()` on a daemon thread; (True, its result or its exception) if it ends within `seconds`, else
    (False, None) (a stuck name lookup or a silent peer ignores socket timeouts; the thread is abandoned)."""
    outcome: list[Any] = []

    def attempt() -> None:
        try:
            outcome.append(what())
        except Exception as exc:  # handed back to the caller, who names it
            outcome.append(exc)

    worker = threading.Thread(target=attempt, daemon=True)
    worker.start()
    worker.join(seconds)
    return (True, outcome[0]) if outcome else (False, None)


async def _scheduler_identity(url: str, timeout_s: float) -> Any:
    """The scheduler's `identity` reply over one Dask comm, or an exception."""
    from distributed.comm import connect

    comm = await connect(url, timeout=timeout_s)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        await comm.close()


def _connect(address: str) -> Any:
    """A `distributed.Client` of the scheduler at `address`: its form checked first (nothing contacted), then a plain
    TCP probe, then the scheduler's `identity` over a Dask comm, each ending within `CONNECT_TIMEOUT_S`; the client
    is made only once a scheduler has answered (a failed `Client` would wait ~20 s more in its finaliser).

    Raises:
        InputError: The address is ill-formed, or no Dask scheduler answers there within `CONNECT_TIMEOUT_S` (names
            the address as typed and what went wrong).
    """
    scheme, host, port = scheduler_address(address)
    if scheme == "inproc":
        return _connect_inproc(address, host)
    url = f"{scheme}://{f'[{host}]' if ':' in host else host}:{port}"
    limit, deadline = CONNECT_TIMEOUT_S, time.monotonic() + CONNECT_TIMEOUT_S
    ended, failure = _within(limit, lambda: socket.create_connection((host, port), timeout=limit).close())
    if not ended:
        raise InputError(f"--scheduler {address}: no answer from {host}:{port} within {limit:g} s; {_EXPECTED}")
    if isinstance(failure, OSError):
        reason = failure.strerror or type(failure).__name__
        raise InputError(f"--scheduler {address}: cannot connect to {host}:{port} ({reason}); {_EXPECTED}")
    import asyncio

    left = deadline - time.monotonic()
    ended, reply = (False, None) if left <= 0 else _within(
        left, lambda: asyncio.run(asyncio.wait_for(_scheduler_identity(url, left), left)))
    if not ended or isinstance(reply, Exception) or not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        seen = "no answer" if not ended or isinstance(reply, TimeoutError) else (
            f"{type(reply).__name__}: {reply}" if isinstance(reply, Exception) else "an answer that is not a scheduler's")
        raise InputError(f"--scheduler {address}: {host}:{port} is not a Dask scheduler ({seen} within {limit:g} s); "
                         f"{_EXPECTED}")
    from distributed import Client

    try:
        return Client(url, timeout=limit, set_as_default=False)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"--scheduler {address}: {exc}; {_EXPECTED}") from None


def _connect_inproc(address: str, where: str) -> Any:
    """A client of a scheduler running in this process (its listener looked up first: a `Client` of an address
    nobody listens on would wait out its timeout)."""
    from distributed import Client
    from distributed.comm.inproc import global_manager

    try:
        listening = global_manager.get_listener_for(where) is not None
    except ValueError as exc:
        raise InputError(f"--scheduler {address}: {exc}; {_EXPECTED}") from None
    if not listening:
        raise InputError(f"--scheduler {address}: no scheduler of this process listens there; {_EXPECTED}")
    return Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
