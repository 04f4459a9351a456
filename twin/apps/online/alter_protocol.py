"""The frames the Stäubli's `alter` task and the twin exchange over TCP, defined once for both sides: the VAL3
application `export --online` writes (`twin.apps.export.val3_alter`) and the twin's server
(`twin.apps.online.val3`).

The robot is the TCP client (a `sio` socket configured on the controller), the twin the server. Each 4 ms cycle
of the robot's synchronous task sends one **request** and the twin answers it with one **answer**; both are
fixed-size binary frames, little-endian:

- request, `REQUEST_BYTES` = 32 bytes: int32 `MAGIC`, int32 sequence number (1, 2, ... per request), then the
  robot's six joints as float32 [deg], the controller's convention (`herej()`'s `j1` .. `j6`);
- answer, `ANSWER_BYTES` = 20 bytes: int32 `MAGIC`, int32 the request's sequence number, then the correction
  dx dy dz as float32 [mm]: absolute (the whole correction, not a step), in the robot's world/base frame.

Why binary and not a text line `"<seq> <j1> ... <j6>\\n"`: VAL3 reads a socket as bytes. `sioGet(sio, num)` takes
one byte (returning 1, 0 when nothing waits, -1 on error) and `sioSet(sio, num[])` writes a byte array;
`fromBinary` / `toBinary` turn bytes into numbers and back with a format string ("-4l": int32, "4.0l": float32,
little-endian). That is how both public VAL3 drivers for Stäubli's controllers talk to a PC at 4 ms
(ros-industrial `staubli_val3_driver`: `val3/ros_server/recvData.pgx`, `sendData.pgx`, `decTrajPt.pgx`,
`encodeJState.pgx`; ICube-Robotics `staubli_driver_ros2`: `val3/userapp/ros2_server/Comm/*.pgx` and
`Serialization/*.pgx`). A text line would need a string read from the socket and its numbers parsed one by one
in every 4 ms cycle of the synchronous task, which neither driver does; a fixed frame is one byte loop and five
`fromBinary` calls with nothing to allocate. float32 keeps the joints to ~3e-5 deg and a correction of a few mm to
~1e-6 mm, well below what the correction means.

`MAGIC` (the bytes "TWA1" on the wire) lets each side refuse a frame that is not one of these (another program on
the port, a stream out of step); the robot also refuses an answer whose sequence number is not newer than the last
it applied, newer than the last it sent, or `MAX_AGE_CYCLES` or more requests behind the last it sent: it then holds
its alteration.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from twin.errors import InputError

#: The first int32 of every frame: b"TWA1" little-endian.
MAGIC = 0x31415754
#: `MAGIC` as it is on the wire: where a stream out of step finds its next frame.
MAGIC_BYTES = struct.pack("<i", MAGIC)
#: Joints in a request.
JOINTS = 6
REQUEST = struct.Struct("<ii6f")
ANSWER = struct.Struct("<ii3f")
REQUEST_BYTES = REQUEST.size
ANSWER_BYTES = ANSWER.size
#: Largest sequence number (int32).
MAX_SEQ = 2**31 - 1
#: The robot's cycle: its synchronous task's period [s].
CYCLE_S = 0.004
#: An answer this many requests behind the robot's last one, or more, is stale: the robot holds its alteration.
MAX_AGE_CYCLES = 5
#: The VAL3 `fromBinary`/`toBinary` formats of the frames' fields: int32 and float32, little-endian.
VAL3_INT32 = "-4l"
VAL3_FLOAT32 = "4.0l"
#: The TCP port the twin listens on and the controller's socket connects to.
DEFAULT_PORT = 49153
_FLOAT32_MAX = float(np.finfo(np.float32).max)


class Request(NamedTuple):
    """A decoded request: its sequence number and the robot's joints [deg] (controller convention)."""

    seq: int
    joints_deg: tuple[float, ...]


class Answer(NamedTuple):
    """A decoded answer: the request's sequence number and the correction dx dy dz [mm] (base frame)."""

    seq: int
    correction_mm: tuple[float, float, float]


def _check_seq(seq: int, what: str) -> None:
    if not 0 <= seq <= MAX_SEQ:
        raise InputError(f"{what} sequence number {seq!r}: expected an integer 0..{MAX_SEQ} (int32)")


def _check_floats(values: Sequence[float] | np.ndarray, what: str, unit: str) -> None:
    for v in values:
        if not (math.isfinite(v) and abs(v) <= _FLOAT32_MAX):
            raise InputError(f"{what} {tuple(float(x) for x in values)}: expected finite numbers [{unit}] "
                             "(float32)")


def encode_request(seq: int, joints_deg: Sequence[float] | np.ndarray) -> bytes:
    """The request the robot sends (module docstring); the server's tests play the robot with it.

    Raises:
        InputError: A sequence number outside int32 0..MAX_SEQ, not `JOINTS` joints, or a joint not finite.
    """
    _check_seq(seq, "request")
    if len(joints_deg) != JOINTS:
        raise InputError(f"request joints {tuple(joints_deg)}: expected {JOINTS} joints [deg]")
    _check_floats(joints_deg, "request joints", "deg")
    return REQUEST.pack(MAGIC, seq, *(float(j) for j in joints_deg))


def frame_seq(frame: bytes | bytearray | memoryview) -> int:
    """The sequence number field of a request or answer frame, whatever else it holds (what the server echoes to a
    frame it cannot read)."""
    return int(struct.unpack_from("<i", frame, 4)[0])


def decode_request_into(frame: bytes | bytearray | memoryview, joints_deg: np.ndarray) -> int:
    """Read a request into `joints_deg` (shape (JOINTS,), [deg]) without allocating an array; returns its sequence
    number.

    Raises:
        InputError: Not `REQUEST_BYTES` bytes, not `MAGIC`, a negative sequence number or a joint not finite.
    """
    if len(frame) != REQUEST_BYTES:
        raise InputError(f"request of {len(frame)} bytes: expected {REQUEST_BYTES}")
    fields = REQUEST.unpack_from(frame)
    if fields[0] != MAGIC:
        raise InputError(f"request magic {fields[0]:#x}: expected {MAGIC:#x} (b'TWA1')")
    _check_seq(fields[1], "request")
    for i in range(JOINTS):
        value = fields[2 + i]
        if not math.isfinite(value):
            raise InputError(f"request {fields[1]}: joint {i + 1} is {value!r}, expected a finite angle [deg]")
        joints_deg[i] = value
    return int(fields[1])


def decode_request(frame: bytes | bytearray | memoryview) -> Request:
    """A request frame as its sequence number and joints [deg] (`decode_request_into` raises as this does)."""
    joints = np.zeros(JOINTS)
    seq = decode_request_into(frame, joints)
    return Request(seq, tuple(float(j) for j in joints))


def encode_answer_into(buffer: bytearray, seq: int, correction_mm: Sequence[float] | np.ndarray) -> None:
    """Write the answer into `buffer` (`ANSWER_BYTES` long, allocated once by the server).

    Raises:
        InputError: A sequence number outside int32 0..MAX_SEQ or a correction not finite.
    """
    _check_seq(seq, "answer")
    c0, c1, c2 = float(correction_mm[0]), float(correction_mm[1]), float(correction_mm[2])
    if not (abs(c0) <= _FLOAT32_MAX and abs(c1) <= _FLOAT32_MAX and abs(c2) <= _FLOAT32_MAX):  # NaN fails too
        raise InputError(f"answer {seq}: correction ({c0}, {c1}, {c2}) mm, expected finite numbers (float32)")
    ANSWER.pack_into(buffer, 0, MAGIC, seq, c0, c1, c2)


def encode_answer(seq: int, correction_mm: Sequence[float] | np.ndarray) -> bytes:
    """The answer frame (`encode_answer_into` raises as this does)."""
    buffer = bytearray(ANSWER_BYTES)
    encode_answer_into(buffer, seq, correction_mm)
    return bytes(buffer)


def decode_answer(frame: bytes | bytearray | memoryview) -> Answer:
    """An answer frame as the robot reads it: sequence number and correction [mm] (float32 precision).

    Raises:
        InputError: Not `ANSWER_BYTES` bytes, not `MAGIC`, or a correction not finite.
    """
    if len(frame) != ANSWER_BYTES:
        raise InputError(f"answer of {len(frame)} bytes: expected {ANSWER_BYTES}")
    magic, seq, c0, c1, c2 = ANSWER.unpack_from(frame)
    if magic != MAGIC:
        raise InputError(f"answer magic {magic:#x}: expected {MAGIC:#x} (b'TWA1')")
    _check_floats((c0, c1, c2), f"answer {seq}: correction", "mm")
    return Answer(int(seq), (c0, c1, c2))
