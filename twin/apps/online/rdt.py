"""ATI Net F/T RDT: the F/T sensor's own UDP stream (the thesis's Omega160 family), read by the twin's server.

The host sends the sensor 8 bytes, big-endian: uint16 0x1234, uint16 command, uint32 sample count (command 2
starts real-time streaming, count 0 = without end; 0 stops it; 0x42 sets the software bias). Each sample comes back
as 36 bytes, big-endian: uint32 RDT sequence, uint32 F/T sequence, uint32 status, then Fx Fy Fz Tx Ty Tz as int32
counts; the counts per N and per N·m are the sensor's calibration (its web page or `netftapi2.xml`). This is the
layout of ATI's RDT interface as its Java sample `NetFTRDTCommand` writes it (`shared/stack-notes.md`).

`RdtSource` is a `ForceSource`: `poll` reads every waiting datagram without blocking, into one buffer allocated
when it is built (the counts are a big-endian view of it), and keeps the newest sample: its force turned into
the sheet frame (`R_sheet_sensor`, constant: the ISF tool stays vertical) less `offset_sheet_n`, stamped with the
server's clock when it was read. A sample whose status is not 0 (the sensor's own error flags), or whose RDT
sequence is not newer than the last, is counted and skipped; a gap in the sequence counts the samples lost.
"""

from __future__ import annotations

import contextlib
import math
import socket
import struct
import time

import numpy as np

from twin.errors import InputError

#: The sensor's RDT port.
RDT_PORT = 49152
HEADER = 0x1234
START_STREAMING, STOP_STREAMING, SET_BIAS = 2, 0, 0x42
RECORD_BYTES = 36
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

    Attributes:
        force_n: The newest force, sheet frame [N].
        stamp_s: When it was read (`time.perf_counter`) [s]; NaN before a first sample.
        samples, lost, faulted, stale: Samples taken; missing from the sequence; with an error status; older than
            the newest (reordered).
    """

    def __init__(self, host: str, port: int = RDT_PORT, *, counts_per_n: float = DEFAULT_COUNTS_PER_N,
                 R_sheet_sensor: np.ndarray | None = None, offset_sheet_n: np.ndarray | None = None,
                 bias: bool = False, bind_host: str | None = None) -> None:
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
        self._buffer = bytearray(RECORD_BYTES)
        self._header = np.frombuffer(self._buffer, dtype=">u4", count=3)  # RDT sequence, F/T sequence, status
        self._counts = np.frombuffer(self._buffer, dtype=">i4", count=3, offset=12)  # Fx Fy Fz
        self._counts_f = np.zeros(3)
        self.force_n = np.zeros(3)
        self.stamp_s = math.nan
        self.samples = self.lost = self.faulted = self.stale = 0
        self._last_sequence = -1
        if bias:
            self.sock.send(request(SET_BIAS))
        self.sock.send(request(START_STREAMING, 0))

    def poll(self) -> int:
        """Read every waiting sample; keep the newest good one. Returns the samples read."""
        read = 0
        while True:
            try:
                n = self.sock.recv_into(self._buffer)
            except (BlockingIOError, InterruptedError):
                return read
            except ConnectionRefusedError:  # the sensor is not there (an ICMP answer): no sample
                return read
            read += 1
            if n != RECORD_BYTES:
                self.faulted += 1
                continue
            sequence, status = int(self._header[0]), int(self._header[2])
            if status != 0:
                self.faulted += 1
                continue
            if sequence <= self._last_sequence:
                self.stale += 1
                continue
            if self._last_sequence >= 0:
                self.lost += sequence - self._last_sequence - 1
            self._last_sequence = sequence
            self._counts_f[:] = self._counts
            np.dot(self.R_sheet_sensor, self._counts_f, out=self.force_n)
            self.force_n -= self.offset_sheet_n
            self.stamp_s = time.perf_counter()
            self.samples += 1

    def close(self) -> None:
        """Stop the stream and release the socket."""
        with contextlib.suppress(OSError):
            self.sock.send(request(STOP_STREAMING, 0))
        self.sock.close()
