"""`online`: the twin's online compensator served behind a robot's real-time interface (`INTERFACES`: KUKA RSI,
ABB EGM, Stäubli VAL3 alter), for a bounded number of cycles, with what it measured of itself; the F/T sample from the robot's
packets or from the sensor's own stream (`--ft-rdt`: ATI Net F/T RDT).

A session fails (exit code 1, its summary saying why) when it answered no packet (no robot within the start
timeout) or when the compensator never had an F/T sample (a sensor that never gave a good one, packets without
`FT`): then nothing was corrected. Its summary counts what it ignored: unreadable packets, another sender's,
cycles without a sample or with a stale one, spikes, and the RDT stream's bad datagrams by kind."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from twin.analysis.resolve import resolve_spec
from twin.apps.tasks.base import Note, Report, silent
from twin.errors import InputError
from twin.process.toolpath.placement import Placement
from twin.robot.controller import DEFAULT_MAX_RATE_MM_S
from twin.sim.online_settings import OnlineSettings, check_max_correction_mm, check_max_rate_mm_s

if TYPE_CHECKING:
    from twin.apps.online.cycle import ServeReport


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
        idle_timeout_s: Stop when no packet was answered for this long after the last [s].
        ft: The F/T sensor's own stream; None: the robot's packets carry the force.
        cell: A `--cell` file's record (`CellDeclaration.record`): its tool is the twin's (`resolve_spec`).
        start_timeout_s: Stop when no first packet was answered for this long [s] (the robot's program is started
            after the twin).
        max_rate_mm_s: Largest rate of change of the correction [mm/s], per second of the controller's clock and
            of the server's, not per packet (`twin.apps.online.cycle`).
        guidance: `--serve egm` only: the guidance table `NAME_egm_pose.csv` of an EGM position-guidance program
            (`twin.apps.online.egm_pose`: the path's poses plus the correction); None: EGM path correction.
        max_correction_mm: The correction's size limit [mm] (`OnlineSettings.max_correction_mm`): the exported
            program's (`export --online --max-correction-mm`).
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
    start_timeout_s: float = 60.0
    max_rate_mm_s: float = DEFAULT_MAX_RATE_MM_S
    guidance: Path | None = None
    max_correction_mm: float = OnlineSettings.max_correction_mm

    def __post_init__(self) -> None:
        check_max_correction_mm(self.max_correction_mm)
        if self.serve not in INTERFACES:
            raise InputError(f"--serve {self.serve!r}: expected one of {', '.join(INTERFACES)}")
        if self.guidance is not None and self.serve != "egm":
            raise InputError(f"--guidance with --serve {self.serve}: the guidance table is ABB EGM position guidance's; "
                             "expected --serve egm")
        defaulted = self.port is None
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
        for option, value in (("--idle-timeout-s", self.idle_timeout_s), ("--start-timeout-s", self.start_timeout_s)):
            if not 0 < value <= MAX_IDLE_TIMEOUT_S:
                raise InputError(f"{option} {value:g}: expected seconds > 0 and <= {MAX_IDLE_TIMEOUT_S:g}")
        check_max_rate_mm_s(self.max_rate_mm_s)
        self._check_ports(defaulted)

    def _check_ports(self, defaulted: bool) -> None:
        """One UDP port on this machine for the server and the sensor's stream is refused: the server would read
        the sensor's datagrams, or the sensor the robot's. This machine: the sensor on a loopback address, or on
        the address the server binds."""
        ft, transport = self.ft, INTERFACES[self.serve].transport
        if ft is None or transport != "UDP" or self.port == 0 or ft.port != self.port:
            return
        if ft.host in ("localhost", "::1", self.host) or ft.host.startswith("127."):
            named = f"--port {self.port}" + (f" ({self.serve}'s default)" if defaulted else "")
            raise InputError(f"{named} and --ft-rdt {ft.host}:{ft.port} name the same UDP port on this machine: the "
                             "server would read the sensor's stream; give --port or the sensor's port another number")


@dataclass(frozen=True)
class OnlineReport(Report):
    """A served session (`twin.apps.online.cycle.ServeReport`: its counts), what it was served with, and the F/T
    stream's counts (`RdtSource.counts`, None without `--ft-rdt`). Fails (exit code 1) when it answered no packet
    or the compensator never had an F/T sample."""

    serve: str
    port: int
    transport: str
    served: ServeReport
    start_timeout_s: float
    ft_source: str | None = None
    ft_counts: dict[str, int] | None = None

    def _stats(self) -> dict[str, float]:
        c = self.served.compute_us
        if c.size == 0:
            return {}
        return {"compute_p50_us": float(np.percentile(c, 50)), "compute_p99_us": float(np.percentile(c, 99)),
                "compute_max_us": float(c.max())}

    def failure(self) -> str | None:
        """Why the session failed, in words; None: it did not."""
        r = self.served
        if r.cycles == 0:
            return (f"no packet answered: no robot sent a readable packet within --start-timeout-s "
                    f"{self.start_timeout_s:g} s; nothing was served")
        if not r.sampled:
            source = (f"the RDT sensor at {self.ft_source} gave no good sample" if self.ft_source
                      else "no packet carried an F/T sample")
            return f"no F/T sample in any of the {r.cycles} cycles answered ({source}): the correction stayed zero"
        return None

    @property
    def exit_code(self) -> int:
        return 0 if self.failure() is None else 1

    def lines(self) -> list[str]:
        r, s = self.served, self._stats()
        timing = "" if not s else (f"; compute p50 {s['compute_p50_us']:.0f} / p99 {s['compute_p99_us']:.0f} / max "
                                   f"{s['compute_max_us']:.0f} µs")
        lines = [f"online {self.serve} on {self.transport} {self.port}: {r.cycles} cycles answered, {r.unreadable} "
                 f"unreadable, stopped by {r.stopped}{timing}"
                 + (f"; {r.refused} further connection(s) refused (one peer per session)" if r.refused else "")
                 + (f"; {r.foreign} packet(s) from another sender ignored (one peer per session)" if r.foreign else "")]
        if r.no_sample or r.stale or r.spikes:
            lines.append(f"F/T: {r.no_sample} cycle(s) before any sample (no correction), {r.stale} with a stale "
                         f"sample (held, then ramped out), {r.spikes} spike(s) rejected")
        if r.at_limit:  # the cell needs more than the compensator may give: say so
            lines.append(f"correction: at its size limit ({r.limit_mm:g} mm) in {r.at_limit} of the {r.cycles} cycles: "
                         "the arm bends further than the limit lets it correct (--max-correction-mm)")
        if self.ft_counts is not None:
            c = self.ft_counts
            lines.append(f"F/T RDT {self.ft_source}: {c['samples']} good samples; {c['malformed']} malformed, "
                         f"{c['faulted']} with an error status, {c['absurd']} absurd, {c['stale']} out of order, "
                         f"{c['lost']} lost, {c['restarts']} restarts")
        failure = self.failure()
        return lines if failure is None else [*lines, f"FAILED: {failure}"]

    def record(self) -> dict[str, Any]:
        r = self.served
        return {"serve": self.serve, "port": self.port, "transport": self.transport, "cycles": r.cycles,
                "unreadable": r.unreadable, "stopped": r.stopped, "refused": r.refused, "foreign": r.foreign,
                "no_sample": r.no_sample, "stale": r.stale, "spikes": r.spikes, "sampled": r.sampled,
                "at_limit": r.at_limit, "limit_mm": r.limit_mm, "rate_mm_s": r.rate_mm_s,
                "failure": self.failure(), "ft": self.ft_counts, **self._stats()}


def online_task(request: OnlineRequest, note: Note = silent) -> OnlineReport:
    """Serve the compensator until the request's bound.

    Raises:
        InputError: A port that cannot be bound, a bad model file.
    """
    from twin.apps.online.egm_pose import EgmPoseServer, GuidancePath
    from twin.apps.online.rdt import RdtSource
    from twin.robot.ft_mount import sensor_in_sheet
    from twin.sim.online import OnlineCompensator, OnlineSettings

    interface = INTERFACES[request.serve]
    guided = None if request.guidance is None else GuidancePath.load(request.guidance)
    if guided is not None:
        note(f"online: EGM position guidance along {request.guidance} ({len(guided.t_s)} points, "
             f"{guided.duration_s:.1f} s at the programmed feeds)")
    spec = resolve_spec(cell=request.cell, model=request.model, robot=request.robot, placement=request.placement)
    twin = spec.build()
    ft = request.ft
    mount = (request.cell or {}).get("ft_sensor")  # a cell's sensor mounting turns its axes into the sheet's
    R_sheet_sensor = None if mount is None else sensor_in_sheet(
        spec.robot, mount["rpy_deg"], math.degrees(spec.placement.yaw_rad))
    force = None if ft is None else RdtSource(ft.host, ft.port, counts_per_n=ft.counts_per_n, bias=ft.bias, log=note,
                                              R_sheet_sensor=R_sheet_sensor)
    try:
        compensator = OnlineCompensator(spec, OnlineSettings(max_rate_mm_s=request.max_rate_mm_s,
                                                             max_correction_mm=request.max_correction_mm))
        server = interface.server(compensator, twin.robot, request.port, request.host, force) if guided is None else \
            EgmPoseServer(compensator, twin.robot, guided, request.port or 0, request.host, force)
        try:
            note(f"online: serving {request.serve} on {request.host}:{server.port} ({interface.transport}), at most "
                 f"{request.cycles} cycles, waiting {request.start_timeout_s:g} s for the robot"
                 + ("" if ft is None else f"; F/T from RDT {ft.host}:{ft.port}"))
            served = server.serve(twin.R_base_sheet, request.cycles, request.idle_timeout_s,
                                  start_timeout_s=request.start_timeout_s)
        finally:
            server.close()
    finally:
        if force is not None:
            force.close()
    counts = None if force is None else {k: int(getattr(force, k)) for k in RDT_COUNTS}
    return OnlineReport(request.serve, server.port, interface.transport, served, request.start_timeout_s,
                        None if ft is None else f"{ft.host}:{ft.port}", counts)


#: The RDT stream's counts a report carries (`twin.apps.online.rdt.RdtSource`).
RDT_COUNTS = ("samples", "malformed", "faulted", "absurd", "stale", "lost", "restarts")
