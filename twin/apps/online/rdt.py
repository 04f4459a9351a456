"""ATI Net F/T RDT: the F/T sensor's own UDP stream (the thesis's Omega160 family), read by the twin's server.

The host sends the sensor 8 bytes, big-endian: uint16 0x1234, uint16 command, uint32 sample count (command 2
starts real-time streaming, count 0 = without end; 0 stops it; 0x42 sets the software bias). Each sample comes back
as 36 bytes, big-endian: uint32 RDT sequence, uint32 F/T sequence, uint32 status, then Fx Fy Fz Tx Ty Tz as int32
counts; the counts per N and per N·m are the sensor's calibration (its web page or `netftapi2.xml`). This is the
layout of ATI's RDT interface as its Java sample `NetFTRDTCommand` writes it (`shared/stack-notes.md`).

`RdtSource` is a `ForceSource`: `poll` reads the waiting datagrams without blocking (at most `MAX_READS_PER_POLL`
a call: bounded work), each into one buffer allocated when it is built (the counts are a big-endian view of it), and
keeps the newest good sample: its force turned into the sheet frame (`R_sheet_sensor`, constant: the ISF tool stays
vertical) less `offset_sheet_n`, stamped with the server's clock when it was read. A UDP datagram is one record, so
a bad one never puts the next out of step. Every datagram that is not a good sample is counted, by why, and
skipped (the last good sample stays):

* `malformed`: not 36 bytes (a request's 8 bytes starting 0x1234 echoed back, another program's packet, a record
  cut short or run long);
* `faulted`: the record's status is not 0 (the sensor's own error flags);
* `absurd`: a force count at the int32 limits (saturated) or a force above `max_force_n` (a broken record or a
  wrong `counts_per_n`; beyond any forming force and any Net F/T's range);
* `stale`: its RDT sequence (compared modulo 2**32) is not newer than the last good one (reordered, repeated);
  `RESTART_RUN` such records in a row are a sensor that restarted its stream, and the next is taken (`restarts`).

A gap in the sequence counts the samples `lost`. The rule for a sensor that gives nothing good: the source keeps
no sample (`stamp_s` NaN), so the compensator corrects nothing (no start without a sensor); `log` is told once
after `SILENT_WARN_S`, and the task reports the counts and fails the session. A sensor that stops mid-session
leaves its last sample, ageing: the compensator's watchdog holds the correction, then ramps it out.
"""

from __future__ import annotations

import contextlib
import math
import socket
import struct
import time
from collections.abc import Callable

import numpy as np

from twin.errors import InputError

#: The sensor's RDT port.
RDT_PORT = 49152
HEADER = 0x1234
START_STREAMING, STOP_STREAMING, SET_BIAS = 2, 0, 0x42
RECORD_BYTES = 36
#: Most datagrams one `poll` reads: a 7 kHz stream brings ~28 per 4 ms cycle, and a full socket buffer (the
#: stream while the server waits for its robot) a few hundred, read at once so that the sample kept is the newest.
MAX_READS_PER_POLL = 1024
#: Out-of-order records in a row taken as a restarted stream.
RESTART_RUN = 16
#: A force above this is no sensor's reading [N] (the runs' bound on a force component, 50 kN).
MAX_FORCE_N = 50_000.0
#: With no good sample this long after the start, `log` is told once [s].
SILENT_WARN_S = 1.0
_INT32_LIMITS = (2**31 - 1, -(2**31))
#: ATI's default Net F/T calibration counts (counts per N, counts per N·m): the sensor reports its own.
DEFAULT_COUNTS_PER_N = 1_000_000.0
DEFAULT_COUNTS_PER_NM = 1_000_000.0


def request(command: int, count: int = 0) -> bytes:
    """The 8-byte RDT request (module docstring)."""
    return struct.pack(">HHI", HEADER, command, count)


def parse_request(packet: bytes) -> tuple[int, int]:
    """A request's command and sample count (what a sensor reads; the test's sensor uses it).

    Raises:
        InputError: Not 8 bytes starting 0x1234.
    """
    if len(packet) != 8 or struct.unpack_from(">H", packet)[0] != HEADER:
        raise InputError(f"RDT request must be 8 bytes starting 0x1234; got {packet[:16]!r}")
    _, command, count = struct.unpack(">HHI", packet)
    return command, count


def record(rdt_sequence: int, ft_sequence: int, status: int, counts: np.ndarray | tuple[int, ...]) -> bytes:
    """One 36-byte RDT sample (what a sensor sends; the test's sensor uses it)."""
    return struct.pack(">III6i", rdt_sequence, ft_sequence, status, *(int(c) for c in counts))


class RdtSource:
    """The newest sample of an ATI Net F/T sensor's RDT stream (module docstring).

    Args:
        host: The sensor's address.
        port: Its RDT port.
        counts_per_n: Force calibration [counts/N].
        R_sheet_sensor: The sensor's axes in the sheet frame, shape (3, 3).
        offset_sheet_n: Subtracted from every force (e.g. the tool's weight, when the sensor is not biased), sheet
            frame [N].
        bias: Ask the sensor to zero itself (`SET_BIAS`) before streaming: do it with the tool in the air.
        bind_host: The local address to read from; None: the one the system routes to the sensor (connecting a UDP
            socket binds it there: a sensor on 127.0.0.1 is read on the loopback only).
        max_force_n: A force above this is absurd, skipped [N].
        log: Told once when no good sample came `SILENT_WARN_S` after the start; None: nobody.

    Attributes:
        force_n: The newest force, sheet frame [N].
        stamp_s: When it was read (`time.perf_counter`) [s]; NaN before a first sample.
        samples, lost, faulted, stale, malformed, absurd, restarts: Samples taken; missing from the sequence; with
            an error status; older than the newest (reordered); not 36 bytes; beyond `max_force_n` or saturated;
            restarts of the stream (module docstring).
    """

    def __init__(self, host: str, port: int = RDT_PORT, *, counts_per_n: float = DEFAULT_COUNTS_PER_N,
                 R_sheet_sensor: np.ndarray | None = None, offset_sheet_n: np.ndarray | None = None,
                 bias: bool = False, bind_host: str | None = None, max_force_n: float = MAX_FORCE_N,
                 log: Callable[[str], None] | None = None) -> None:
        if not (math.isfinite(counts_per_n) and counts_per_n > 0):
            raise InputError(f"RDT counts per N {counts_per_n!r}: expected a positive number (the sensor's "
                             "calibration, e.g. 1000000)")
        R = np.eye(3) if R_sheet_sensor is None else np.asarray(R_sheet_sensor, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise InputError(f"R_sheet_sensor must be a proper rotation (3x3); got {R.tolist()}")
        self.R_sheet_sensor = R / counts_per_n  # counts straight into N in the sheet frame: one product a sample
        self.offset_sheet_n = np.zeros(3) if offset_sheet_n is None else np.asarray(offset_sheet_n, dtype=float)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            if bind_host is not None:
                self.sock.bind((bind_host, 0))
            self.sock.connect((host, port))
        except OSError as exc:
            self.sock.close()
            raise InputError(f"cannot reach the F/T sensor at {host}:{port} (UDP): {exc.strerror}") from None
        self.sock.setblocking(False)
        self.address = f"{host}:{port}"
        self.max_force_n, self.log = max_force_n, log
        self._buffer = bytearray(RECORD_BYTES + 1)  # one byte more: a datagram that runs long reads as 37
        self._header = np.frombuffer(self._buffer, dtype=">u4", count=3)  # RDT sequence, F/T sequence, status
        self._counts = np.frombuffer(self._buffer, dtype=">i4", count=3, offset=12)  # Fx Fy Fz
        self._counts_f = np.zeros(3)
        self._force = np.zeros(3)  # the record being checked, sheet frame [N]
        self.force_n = np.zeros(3)
        self.stamp_s = math.nan
        self.samples = self.lost = self.faulted = self.stale = self.malformed = self.absurd = self.restarts = 0
        self._last_sequence = -1
        self._older_run = 0
        self._started_s = time.perf_counter()
        self._warned = log is None
        if bias:
            self.sock.send(request(SET_BIAS))
        self.sock.send(request(START_STREAMING, 0))

    def poll(self) -> int:
        """Read the waiting datagrams (at most `MAX_READS_PER_POLL`); keep the newest good sample. Returns the
        datagrams read."""
        read = 0
        while read < MAX_READS_PER_POLL:
            try:
                n = self.sock.recv_into(self._buffer)
            except (BlockingIOError, InterruptedError):
                break
            except ConnectionRefusedError:  # the sensor is not there (an ICMP answer): no sample
                break
            read += 1
            self._take(n)
        if not self._warned and self.samples == 0 and time.perf_counter() - self._started_s > SILENT_WARN_S:
            self._warned = True
            if self.log is not None:
                self.log(f"online: no good F/T sample from the RDT sensor at {self.address} in {SILENT_WARN_S:g} s "
                         f"({self.counts()}): nothing is corrected until one comes")
        return read

    def _take(self, n: int) -> None:
        """One datagram of `n` bytes in the buffer: counted by why it is not a good sample, or taken."""
        if n != RECORD_BYTES:
            self.malformed += 1
            return
        sequence, status = int(self._header[0]), int(self._header[2])
        if status != 0:
            self.faulted += 1
            return
        c0, c1, c2 = int(self._counts[0]), int(self._counts[1]), int(self._counts[2])
        if c0 in _INT32_LIMITS or c1 in _INT32_LIMITS or c2 in _INT32_LIMITS:
            self.absurd += 1
            return
        ahead = (sequence - self._last_sequence) % 2**32
        if self._last_sequence >= 0 and not 0 < ahead < 2**31:
            self._older_run += 1
            if self._older_run < RESTART_RUN:
                self.stale += 1
                return
            self.restarts += 1  # the stream restarted: take it from here
            ahead = 1
        self._counts_f[0], self._counts_f[1], self._counts_f[2] = c0, c1, c2
        np.dot(self.R_sheet_sensor, self._counts_f, out=self._force)
        self._force -= self.offset_sheet_n
        f = self._force
        if not math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) <= self.max_force_n:  # NaN fails too
            self.absurd += 1
            return
        if self._last_sequence >= 0:
            self.lost += ahead - 1
        self._older_run = 0
        self._last_sequence = sequence
        self.force_n[:] = f
        self.stamp_s = time.perf_counter()
        self.samples += 1

    def counts(self) -> str:
        """The counts in words: good samples, then each kind of bad datagram."""
        return (f"{self.samples} good samples; {self.malformed} malformed, {self.faulted} with an error status, "
                f"{self.absurd} absurd, {self.stale} out of order, {self.lost} lost, {self.restarts} restarts")

    def close(self) -> None:
        """Stop the stream and release the socket."""
        with contextlib.suppress(OSError):
            self.sock.send(request(STOP_STREAMING, 0))
        self.sock.close()
