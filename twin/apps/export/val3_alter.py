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
- `NAME.dtx` adds `siTwin` (a `sio` linked to the controller's socket `Socket\\twin`), the flags `bAlterRun`,
  `bAlterOn`, `bAlterOver` (the task's overrun flag), `nAlterMax`, the counters and `trAlter`.

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
UDP one; the controller's cycle allows a 4 ms synchronous task with this much work. If the manual says `alter`
is cumulative, `alterTask` must pass `alter` the difference between the new correction and the one applied
(`trAlter` before it is overwritten): as written it would add the whole correction at every fresh answer.

A VAL3 application is not split (`parts`): the path is data walked by a loop.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import twin.apps.export.val3 as val3
from twin.apps.export.program import ProgramPath, cell_lines
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

START_CODE = """begin
  // {name}: {n} points of {source}, sheet frame fSheet, tool tIsf, robot {robot}
{about}  // online correction: {task} (every {cycle_ms:g} ms) sends the joints to the twin (tx200-twin online) on siTwin
  // and applies its answer with alter(): the path's moves are alterMovel, altered in world
  bAlterOn = false
  bAlterRun = true
  nAlterHeld = 0
  nAlterBad = 0
  nTwinErr = 0
  movej(jHome, tIsf, mApproach)
  movej(pPath[0], tIsf, mApproach)
  waitEndMove()
  taskCreateSync "{task}", {cycle_s:g}, bAlterOver, {task}()
  alterBegin(world, mPath[1])
  bAlterOn = true
  for i = 1 to size(pPath) - 2
    alterMovel(pPath[i], tIsf, mPath[i])
  endFor
  waitEndMove()
  bAlterOn = false
  alterEnd()
  movel(pPath[size(pPath) - 1], tIsf, mPath[size(pPath) - 1])
  waitEndMove()
  movej(jHome, tIsf, mApproach)
  waitEndMove()
  bAlterRun = false
end"""

TASK_CODE = """begin
  // Synchronous task ({cycle_ms:g} ms): the twin's newest fresh answer into alter(), then the joints now to the twin.
  // Frames (twin.apps.online.alter_protocol), little-endian: request magic, seq, j1..j6 [deg] ({request} bytes);
  // answer magic, seq, dx dy dz [mm], absolute, world frame ({answer} bytes).
  sioCtrl(siTwin, "timeout", -1)
  clearBuffer(siTwin)
  l_nMagic = {magic}
  l_nSeq = 0
  l_nApplied = 0
  l_nGot = 0
  toBinary(l_nMagic, 1, "{int32}", l_nTx[0])
  while bAlterRun
    // the answers waiting, byte by byte (a frame may come in pieces), at most {answers} frames a cycle
    l_nFresh = 0
    l_nBytes = 0
    l_nRead = 1
    while l_nRead == 1
      l_nRead = 0
      if l_nBytes < {max_bytes}
        l_nRead = sioGet(siTwin, l_nByte)
      endIf
      if l_nRead == 1
        l_nRx[l_nGot] = l_nByte
        l_nGot = l_nGot + 1
        l_nBytes = l_nBytes + 1
      endIf
      if l_nGot == {answer}
        l_nGot = 0
        l_nOk = fromBinary(l_nRx[0], 4, "{int32}", l_nAnsMagic)
        l_nOk = l_nOk + fromBinary(l_nRx[4], 4, "{int32}", l_nAnsSeq)
        for l_nI = 0 to 2
          l_nOk = l_nOk + fromBinary(l_nRx[8 + 4 * l_nI], 4, "{float32}", l_nC[l_nI])
        endFor
        l_nUse = 0
        if l_nOk == 5
          if l_nAnsMagic == l_nMagic
            l_nUse = 1
          endIf
        endIf
        if l_nUse == 0
          nAlterBad = nAlterBad + 1
        endIf
        // fresh: newer than the last applied, not newer than the last sent, less than {max_age} requests behind it
        if l_nAnsSeq <= l_nApplied
          l_nUse = 0
        endIf
        if l_nAnsSeq > l_nSeq
          l_nUse = 0
        endIf
        if l_nAnsSeq <= l_nSeq - {max_age}
          l_nUse = 0
        endIf
        if l_nUse == 1
          l_nApplied = l_nAnsSeq
          l_nFresh = 1
          for l_nI = 0 to 2
            l_nA[l_nI] = l_nC[l_nI]
          endFor
        endIf
      endIf
    endWhile
    if l_nFresh == 1
      // second guard: at most nAlterMax mm, whatever came
      l_nNorm = sqrt(l_nA[0] * l_nA[0] + l_nA[1] * l_nA[1] + l_nA[2] * l_nA[2])
      l_nScale = 1
      if l_nNorm > nAlterMax
        l_nScale = nAlterMax / l_nNorm
      endIf
      trAlter.x = l_nA[0] * l_nScale
      trAlter.y = l_nA[1] * l_nScale
      trAlter.z = l_nA[2] * l_nScale
      if bAlterOn
        alter(trAlter)
      endIf
    else
      // no fresh answer: the alteration holds
      nAlterHeld = nAlterHeld + 1
    endIf
    // the joints now, with the next sequence number
    l_jNow = herej()
    l_nJ[0] = l_jNow.j1
    l_nJ[1] = l_jNow.j2
    l_nJ[2] = l_jNow.j3
    l_nJ[3] = l_jNow.j4
    l_nJ[4] = l_jNow.j5
    l_nJ[5] = l_jNow.j6
    l_nSeq = l_nSeq + 1
    toBinary(l_nSeq, 1, "{int32}", l_nTx[4])
    toBinary(l_nJ, {joints}, "{float32}", l_nTx[8])
    if sioSet(siTwin, l_nTx) != size(l_nTx)
      nTwinErr = nTwinErr + 1
    endIf
    delay(0)
  endWhile
  clearBuffer(siTwin)
end"""

#: The task's locals: name -> (type, size).
TASK_LOCALS = {
    "l_nTx": ("num", REQUEST_BYTES), "l_nRx": ("num", ANSWER_BYTES), "l_nJ": ("num", JOINTS),
    "l_nC": ("num", 3), "l_nA": ("num", 3), "l_jNow": ("jointRx", 1),
    **{name: ("num", 1) for name in ("l_nMagic", "l_nSeq", "l_nApplied", "l_nGot", "l_nFresh", "l_nBytes", "l_nRead",
                                     "l_nByte", "l_nOk", "l_nAnsMagic", "l_nAnsSeq", "l_nI", "l_nUse", "l_nNorm",
                                     "l_nScale")},
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
        *(_datum(flag, "bool", 'value="false"') for flag in ("bAlterRun", "bAlterOn", "bAlterOver")),
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
                            max_bytes=MAX_ANSWERS_PER_CYCLE * ANSWER_BYTES, max_age=MAX_AGE_CYCLES, joints=JOINTS)
    files[f"{TASK}.pgx"] = _program(TASK, task, TASK_LOCALS)
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
