"""`online`: the twin's online compensator served behind a robot's real-time interface (`INTERFACES`: KUKA RSI,
ABB EGM, Stäubli VAL3 alter), for a bounded number of cycles, with what it measured of itself; the F/T sample from the robot's
packets or from the sensor's own stream (`--ft-rdt`: ATI Net F/T RDT)."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from twin.analysis.resolve import resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.errors import InputError
from twin.process.toolpath.placement import Placement


class Interface(NamedTuple):
    """One robot real-time interface the compensator is served behind.

    Attributes:
        name: The `--serve` choice.
        transport: "UDP" or "TCP".
        default_port: Where the exported program's configuration looks for the twin.
        server: Builds the server (a `twin.apps.online.cycle.Server`) from (compensator, robot, port, host, force
            source or None).
    """

    name: str
    transport: str
    default_port: int
    server: Callable[..., Any]


def _rsi(*args: Any) -> Any:
    from twin.apps.online.rsi import RsiServer

    return RsiServer(*args)


def _val3(*args: Any) -> Any:
    from twin.apps.online.val3 import Val3Server

    return Val3Server(*args)


def _egm(*args: Any) -> Any:
    from twin.apps.online.egm import EgmServer

    return EgmServer(*args)


#: The interfaces, by `--serve` name.
INTERFACES: dict[str, Interface] = {
    "rsi": Interface("rsi", "UDP", 49152, _rsi),  # twin.apps.export.krl_rsi.DEFAULT_PORT
    "egm": Interface("egm", "UDP", 6510, _egm),  # twin.apps.export.rapid_egm.DEFAULT_PORT
    "val3": Interface("val3", "TCP", 49153, _val3),  # twin.apps.online.alter_protocol.DEFAULT_PORT
}
_RDT = re.compile(r"^(?P<host>[A-Za-z0-9.\-]+)(:(?P<port>\d{1,5}))?$")


@dataclass(frozen=True)
class RdtSettings:
    """The F/T sensor's own stream (ATI Net F/T RDT, `twin.apps.online.rdt`).

    Attributes:
        host: The sensor's address.
        port: Its RDT port.
        counts_per_n: Its force calibration [counts/N].
        bias: Zero the sensor before streaming (tool in the air).
    """

    host: str
    port: int = 49152
    counts_per_n: float = 1_000_000.0
    bias: bool = False

    @classmethod
    def parse(cls, text: str, counts_per_n: float = 1_000_000.0, bias: bool = False) -> RdtSettings:
        """From `--ft-rdt HOST[:PORT]`.

        Raises:
            InputError: Not HOST or HOST:PORT with a port 1..65535, or a calibration that is not positive.
        """
        match = _RDT.match(text.strip())
        port = int(match.group("port")) if match and match.group("port") else 49152
        if match is None or not 1 <= port <= 65535:
            raise InputError(f"--ft-rdt {text!r}: expected the sensor's HOST or HOST:PORT (e.g. 192.168.1.1 or "
                             "192.168.1.1:49152)")
        if not (math.isfinite(counts_per_n) and counts_per_n > 0):
            raise InputError(f"--ft-counts-per-n {counts_per_n!r}: expected the sensor's positive calibration "
                             "(e.g. 1000000)")
        return cls(match.group("host"), port, counts_per_n, bias)


@dataclass(frozen=True)
class OnlineRequest:
    """What to serve.

    Attributes:
        serve: The interface (a key of `INTERFACES`).
        port: Port to listen on (0: any free one; None: the interface's default).
        host: Address to bind.
        model: The compensator's twin (a model file), or None for the default.
        robot: A robot name or file; None: the model's, else the default.
        placement: The sheet in the robot base; None keeps the model's.
        cycles: Most packets to answer.
        idle_timeout_s: Stop when no packet came for this long [s].
        ft: The F/T sensor's own stream; None: the robot's packets carry the force.
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
    """

    serve: str
    port: int | None = 0
    host: str = "127.0.0.1"
    model: Path | None = None
    robot: str | Path | None = None
    placement: Placement | None = field(default=None)
    cycles: int = 15000
    idle_timeout_s: float = 5.0
    ft: RdtSettings | None = None
    cell: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.serve not in INTERFACES:
            raise InputError(f"--serve {self.serve!r}: expected one of {', '.join(INTERFACES)}")
        if self.port is None:
            object.__setattr__(self, "port", INTERFACES[self.serve].default_port)
        if self.serve == "val3" and self.ft is None:
            raise InputError("--serve val3 needs --ft-rdt HOST[:PORT]: a VAL3 request carries the joints only, so the "
                             "force must come from the sensor's own stream (without it nothing would be corrected)")
        if not 0 <= self.port <= 65535:  # type: ignore[operator]
            raise InputError(f"--port {self.port}: expected 0..65535")
        from twin.apps.online.cycle import MAX_IDLE_TIMEOUT_S

        if self.cycles < 1:
            raise InputError(f"--cycles {self.cycles}: expected a count of packets >= 1")
        if not 0 < self.idle_timeout_s <= MAX_IDLE_TIMEOUT_S:
            raise InputError(f"--idle-timeout-s {self.idle_timeout_s:g}: expected seconds > 0 and <= "
                             f"{MAX_IDLE_TIMEOUT_S:g}")


@dataclass(frozen=True)
class OnlineReport(Report):
    """A served session: cycles, unreadable packets, why it stopped, per-cycle compute [µs], further connections
    refused (a TCP interface serves one peer per session)."""

    serve: str
    port: int
    transport: str
    cycles: int
    unreadable: int
    stopped: str
    compute_us: np.ndarray
    refused: int = 0

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
        return [f"online {self.serve} on {self.transport} {self.port}: {self.cycles} cycles answered, {self.unreadable} "
                f"unreadable, stopped by {self.stopped}{timing}"
                + (f"; {self.refused} further connection(s) refused (one peer per session)" if self.refused else "")]

    def record(self) -> dict[str, Any]:
        return {"serve": self.serve, "port": self.port, "transport": self.transport, "cycles": self.cycles, "unreadable": self.unreadable,
                "stopped": self.stopped, "refused": self.refused, **self._stats()}


def online_task(request: OnlineRequest, note: Note = silent) -> OnlineReport:
    """Serve the compensator until the request's bound.

    Raises:
        InputError: A port that cannot be bound, a bad model file.
    """
    from twin.apps.online.rdt import RdtSource
    from twin.sim.online import OnlineCompensator

    interface = INTERFACES[request.serve]
    spec = resolve_spec(cell=request.cell, model=request.model, robot=request.robot, placement=request.placement)
    twin = spec.build()
    ft = request.ft
    force = None if ft is None else RdtSource(ft.host, ft.port, counts_per_n=ft.counts_per_n, bias=ft.bias)
    try:
        server = interface.server(OnlineCompensator(spec), twin.robot, request.port, request.host, force)
        try:
            note(f"online: serving {request.serve} on {request.host}:{server.port} ({interface.transport}), at most "
                 f"{request.cycles} cycles" + ("" if ft is None else f"; F/T from RDT {ft.host}:{ft.port}"))
            served = server.serve(twin.R_base_sheet, request.cycles, request.idle_timeout_s)
        finally:
            server.close()
    finally:
        if force is not None:
            force.close()
    return OnlineReport(request.serve, server.port, interface.transport, served.cycles, served.unreadable,
                        served.stopped, served.compute_us, served.refused)
