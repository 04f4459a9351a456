"""Stäubli VAL3 with the twin's online correction (`export --online` for a VAL3 robot): the `val3` application
whose path moves are `alter` moves, corrected each 4 ms from `tx200-twin online` over a socket.

The application is `twin.apps.export.val3`'s (same `fSheet`, `tIsf`, `jHome`, `pPath`, `mPath`, `mApproach`), and:

- `start.pgx`: `movej` HOME (`jHome`) and to the approach point, `waitEndMove()`; `taskCreateSync "alterTask",
  0.004, bAlterOver, alterTask()`; `alterBegin(world, mPath[1])`; every path point (the descent onto the sheet and
  the path: the contact part) an `alterMovel(pPath[i], tIsf, mPath[i])`; `waitEndMove()`, `alterEnd()`; the
  retract a plain `movel`, then `movej` HOME; the task told to stop (`bAlterRun = false`).
- `alterTask.pgx`, the synchronous task (4 ms): each cycle it takes the twin's answers waiting on the socket `siTwin`
  (byte by byte, as a frame may come in pieces, at most four frames a cycle), keeps the newest one whose magic
  and sequence number pass (`twin.apps.online.alter_protocol`: newer than the last applied, not newer than the
  last sent, less than `MAX_AGE_CYCLES` behind it), limits it to `nAlterMax` = 5 mm (a second guard behind the
  compensator's own limit), puts it in `trAlter` and calls `alter(trAlter)` while the alteration is on; a cycle
  without such an answer holds the alteration (counted in `nAlterHeld`; refused frames in `nAlterBad`, failed
  sends in `nTwinErr`). Then it sends the joints now (`herej()`, degrees) with the next sequence number.
- **A failed link stops forming** rather than freezing the correction and going on: a socket error (`sioGet`
  returning -1, a `sioSet` that writes less than the frame) or `MAX_SILENT_CYCLES` (25 = 100 ms) without a fresh
  answer while the alteration is on sets `bTwinLost`; from then the task calls `resetMotion()` every cycle (so a move
  `start` queued after the failure is cancelled too), applies and sends nothing; `start` queues no more
  `alterMovel` and makes neither the retract nor the move HOME: the robot stands where the link failed, the tool on
  the sheet, for the operator. As ros-industrial `staubli_val3_driver` and ICube's driver stop the motion with
  `resetMotion()` when their link fails.
- `stop.pgx` (the application stopped by the operator or an error): `bAlterRun = false`, `resetMotion()`,
  `taskKill("alterTask")`, `clearBuffer(siTwin)` (the socket closed), as ros-industrial `staubli_val3_driver`'s
  `val3/ros_server/stop.pgx` (`resetMotion()`, `taskKill` of its tasks; read).
- `NAME.dtx` adds `siTwin` (a `sio` linked to the controller's socket `Socket\\twin`), the flags `bAlterRun`,
  `bAlterOn`, `bAlterOver` (the task's overrun flag), `bTwinLost` (the link failed), `nAlterMax`, the counters and `trAlter`.

The controller's socket `twin` must be set up on the controller as a TCP **client** of the PC that runs
`tx200-twin online` (its address, port `alter_protocol.DEFAULT_PORT`), timeout -1 (non-blocking). The correction is
in the robot's world frame (`alterBegin(world, ...)`), which this exporter, like `val3`, takes to be the base.

What the VAL3 here rests on, and where it comes from. Confirmed from public VAL3 code (read, not run):
`taskCreateSync "name", period, bOverrunFlag, program()` with a 0.004 s period, the task a `while` loop that ends
each cycle with `delay(0)`; a `sio` datum as `<Value key="0" link="Socket\\Name" />` and a bool datum as
`value="false"`; `sioGet(sio, num)` reading one byte (1: a byte, 0: none waiting, -1: error); `sioSet(sio, num[])`
returning the bytes written; `clearBuffer(sio)`; `sioCtrl(sio, "timeout", -1)` for a non-blocking socket;
`fromBinary(bytes[i], 4, "-4l" | "4.0l", value)` returning 1 per value decoded and `toBinary(values, count, format,
bytes[i])` (ros-industrial `staubli_val3_driver`: `val3/ros_server/start.pgx`, `dataStreamer.pgx`,
`recvData.pgx`, `sendData.pgx`, `decTrajPt.pgx`, `encodeJState.pgx`, `ros_server.dtx`; ICube-Robotics
`staubli_driver_ros2`: `val3/userapp/ros2_server/start.pgx`, `controlTask.pgx`, `Comm/resetControlSocket.pgx`,
`Comm/readDataOnce.pgx`, `ros2_server.dtx`); `herej()` giving a `jointRx` whose `j1` .. `j6` are degrees
(`toJointArrayRad.pgx` there). That the `alter` option exists and is licensed separately (ICube's README).
Assumed, to be checked against Stäubli's VAL3 reference manual ("alter" option) before a first run, as no public
source we could read shows them: `alterMovel(point, tool, mdesc)` queues a linear move that accepts an alteration;
`alterBegin(frame, mdesc)` starts the alteration in that frame, may be called before the alterable moves it
alters are executed, with the nominal speed `mdesc`; `alter(trsf)` sets the **whole** alteration relative to the
unaltered path (absolute, not added to the last one), which is what the twin sends (as RSI's `#ABSOLUTE` mode on
the KUKA side); `alter` is to be called from a synchronous task, and only when the correction changes (a cycle
without a call keeps the alteration); `alterEnd()` ends it and the retract after it keeps the last alteration;
`toBinary`'s count counts values (as ros-industrial uses it; ICube passes byte counts); the `sioCtrl` timeout -1
and `clearBuffer` (which ros-industrial uses to close a connection) act on a TCP client socket as they do on ICube's
UDP one; the controller's cycle allows a 4 ms synchronous task with this much work; `resetMotion()` may be called
from the synchronous task, stops the arm and cancels the queued moves, after which `start`'s `waitEndMove()`
returns; `taskKill` of a synchronous task from `stop`. None of this can be checked without a controller. If the manual says `alter`
is cumulative, `alterTask` must pass `alter` the difference between the new correction and the one applied
(`trAlter` before it is overwritten): as written it would add the whole correction at every fresh answer.

A VAL3 application is not split (`parts`): the path is data walked by a loop.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import twin.apps.export.val3 as val3
from twin.apps.export.program import ProgramPath, cell_lines
from twin.apps.export.val3_alter_code import START_CODE, STOP_CODE, TASK_CODE
from twin.apps.online.alter_protocol import (
    ANSWER_BYTES,
    CYCLE_S,
    JOINTS,
    MAGIC,
    MAX_AGE_CYCLES,
    REQUEST_BYTES,
    VAL3_FLOAT32,
    VAL3_INT32,
)
from twin.errors import InputError

#: The synchronous task's program and name.
TASK = "alterTask"
#: The controller's socket the `sio` links to (set up on the controller: module docstring).
SOCKET = "twin"
#: The task's own limit on the alteration [mm] (the compensator's default limit: a second guard).
MAX_ALTER_MM = 5.0
#: At most this many answers are read in one cycle (a backlog drains without overrunning the task).
MAX_ANSWERS_PER_CYCLE = 4
#: Cycles without a fresh answer, while altering, after which the link counts as failed and forming stops
#: (25 x 4 ms = 100 ms; the compensator holds a correction for fewer).
MAX_SILENT_CYCLES = 25

#: The task's locals: name -> (type, size).
TASK_LOCALS = {
    "l_nTx": ("num", REQUEST_BYTES), "l_nRx": ("num", ANSWER_BYTES), "l_nJ": ("num", JOINTS),
    "l_nC": ("num", 3), "l_nA": ("num", 3), "l_jNow": ("jointRx", 1),
    **{name: ("num", 1) for name in ("l_nMagic", "l_nSeq", "l_nApplied", "l_nGot", "l_nFresh", "l_nBytes", "l_nRead",
                                     "l_nByte", "l_nOk", "l_nAnsMagic", "l_nAnsSeq", "l_nI", "l_nUse", "l_nNorm",
                                     "l_nScale", "l_nSilent")},
}


def _program(name: str, code: str, local: dict[str, tuple[str, int]]) -> str:
    """A `.pgx` file of one program (the layout `val3` writes)."""
    locals_xml = "".join(f'      <Local name="{k}" type="{t}" xsi:type="array" size="{s}" />\n'
                         for k, (t, s) in local.items())
    return (
        f'<?xml version="1.0" encoding="utf-8"?>\n<Programs xmlns="{val3.NS_PROGRAM}" xmlns:xsi="{val3.XSI}">\n'
        f'  <Program name="{name}">\n    <Locals>\n{locals_xml}    </Locals>\n'
        f"    <Code><![CDATA[{code}]]></Code>\n  </Program>\n</Programs>\n"
    )


def _datum(name: str, kind: str, value: str) -> str:
    """One datum of size 1 in the `.dtx` layout `val3` writes."""
    return (f'    <Data name="{name}" access="private" xsi:type="array" type="{kind}" size="1">\n'
            f'      <Value key="0" {value} />\n    </Data>')


def application_files(path: ProgramPath) -> dict[str, str]:
    """The application's files: name -> XML text (`val3`'s, with the alter start, the task and their data).

    Raises:
        InputError: A program without its approach and retract points (`motion.with_moves`), which the alter
            moves go between.
    """
    if not path.approach or len(path.points_mm) < 3:
        raise InputError(f"val3-alter: a program of {len(path.points_mm)} points "
                         f"{'with' if path.approach else 'without'} approach and retract; expected the approach "
                         "point, at least one path point and the retract point (export's with_moves)")
    files = val3.application_files(path)
    data = [
        _datum("siTwin", "sio", f'link="Socket\\{SOCKET}"'),
        *(_datum(flag, "bool", 'value="false"') for flag in ("bAlterRun", "bAlterOn", "bAlterOver", "bTwinLost")),
        _datum("nAlterMax", "num", f'value="{MAX_ALTER_MM:g}"'),
        *(_datum(count, "num", 'value="0"') for count in ("nAlterHeld", "nAlterBad", "nTwinErr")),
        _datum("trAlter", "trsf", 'x="0" y="0" z="0" rx="0" ry="0" rz="0"'),
    ]
    dtx = f"{path.name}.dtx"
    files[dtx] = files[dtx].replace("\n  </Datas>", "\n" + "\n".join(data) + "\n  </Datas>", 1)
    pjx = f"{path.name}.pjx"
    files[pjx] = files[pjx].replace('<Program file="stop.pgx" />',
                                    f'<Program file="stop.pgx" />\n    <Program file="{TASK}.pgx" />', 1)
    cycle_ms = 1e3 * CYCLE_S
    start = START_CODE.format(name=path.name, n=len(path.points_mm), source=path.source.name, robot=path.cell.robot,
                              about="".join(f"  // {line}\n" for line in cell_lines(path.cell)),
                              task=TASK, cycle_s=CYCLE_S, cycle_ms=cycle_ms)
    files["start.pgx"] = _program("start", start, {"i": ("num", 1)})
    task = TASK_CODE.format(cycle_ms=cycle_ms, request=REQUEST_BYTES, answer=ANSWER_BYTES, magic=MAGIC,
                            int32=VAL3_INT32, float32=VAL3_FLOAT32, answers=MAX_ANSWERS_PER_CYCLE,
                            max_bytes=MAX_ANSWERS_PER_CYCLE * ANSWER_BYTES, max_age=MAX_AGE_CYCLES, joints=JOINTS,
                            silent=MAX_SILENT_CYCLES)
    files[f"{TASK}.pgx"] = _program(TASK, task, TASK_LOCALS)
    files["stop.pgx"] = _program("stop", STOP_CODE.format(task=TASK), {})
    return files


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the VAL3 application folder `out` atomically (checked first; never over an input), as `val3.write`.

    Args:
        path: The path to export (with its approach and retract points).
        out: The application folder (its name is the application's name).
        protect: Inputs that must not be inside `out`.

    Returns:
        The files written.
    """
    return val3.write_application(application_files(path), out, protect)
