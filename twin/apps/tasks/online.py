"""`online`: the twin's online compensator served behind a robot's real-time interface (`--serve rsi`: KUKA RSI
over UDP, `twin.apps.online.rsi`), for a bounded number of cycles, with what it measured of itself."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twin.analysis.resolve import resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.errors import InputError
from twin.process.toolpath.placement import Placement

INTERFACES = ("rsi",)


@dataclass(frozen=True)
class OnlineRequest:
    """What to serve.

    Attributes:
        serve: The interface ("rsi").
        port: UDP port (0: any free one).
        host: Address to bind.
        model: The compensator's twin (a model file), or None for the default.
        robot: A robot name or file; None: the model's, else the default.
        placement: The sheet in the robot base; None keeps the model's.
        cycles: Most packets to answer.
        idle_timeout_s: Stop when no packet came for this long [s].
    """

    serve: str
    port: int = 0
    host: str = "127.0.0.1"
    model: Path | None = None
    robot: str | Path | None = None
    placement: Placement | None = field(default=None)
    cycles: int = 15000
    idle_timeout_s: float = 5.0

    def __post_init__(self) -> None:
        if self.serve not in INTERFACES:
            raise InputError(f"--serve {self.serve!r}: expected one of {', '.join(INTERFACES)} (EGM is not built yet)")
        if not 0 <= self.port <= 65535:
            raise InputError(f"--port {self.port}: expected 0..65535")
        if self.cycles < 1 or not self.idle_timeout_s > 0:
            raise InputError(f"--cycles {self.cycles} must be >= 1 and --idle-timeout-s {self.idle_timeout_s} > 0")


@dataclass(frozen=True)
class OnlineReport(Report):
    """A served session: cycles, unreadable packets, why it stopped, per-cycle compute [µs]."""

    serve: str
    port: int
    cycles: int
    unreadable: int
    stopped: str
    compute_us: np.ndarray

    def _stats(self) -> dict[str, float]:
        c = self.compute_us
        if c.size == 0:
            return {}
        return {"compute_p50_us": float(np.percentile(c, 50)), "compute_p99_us": float(np.percentile(c, 99)),
                "compute_max_us": float(c.max())}

    def lines(self) -> list[str]:
        s = self._stats()
        timing = "" if not s else (f"; compute p50 {s['compute_p50_us']:.0f} / p99 {s['compute_p99_us']:.0f} / max "
                                   f"{s['compute_max_us']:.0f} µs")
        return [f"online {self.serve} on UDP {self.port}: {self.cycles} cycles answered, {self.unreadable} "
                f"unreadable, stopped by {self.stopped}{timing}"]

    def record(self) -> dict[str, Any]:
        return {"serve": self.serve, "port": self.port, "cycles": self.cycles, "unreadable": self.unreadable,
                "stopped": self.stopped, **self._stats()}


def online_task(request: OnlineRequest, note: Note = silent) -> OnlineReport:
    """Serve the compensator until the request's bound.

    Raises:
        InputError: A port that cannot be bound, a bad model file.
    """
    from twin.apps.online.rsi import RsiServer
    from twin.sim.online import OnlineCompensator

    spec = resolve_spec(model=request.model, robot=request.robot, placement=request.placement)
    twin = spec.build()
    server = RsiServer(OnlineCompensator(spec), twin.robot, request.port, request.host)
    note(f"online: serving {request.serve} on {request.host}:{server.port} (UDP), at most {request.cycles} cycles")
    try:
        served = server.serve(twin.R_base_sheet, request.cycles, request.idle_timeout_s)
    finally:
        server.close()
    return OnlineReport(request.serve, server.port, served.cycles, served.unreadable, served.stopped,
                        served.compute_us)
