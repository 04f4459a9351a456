"""`export --online` for a Stäubli (twin/apps/export/val3_alter.py): the `val3` application whose contact moves are
`alterMovel`, between `alterBegin` and `alterEnd`, and a 4 ms synchronous task that exchanges the frames of
`twin.apps.online.alter_protocol` with the twin. Every file passes the grammar check; the bytes the task writes
and reads are the protocol module's layout, read back from the VAL3 text."""

from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import pytest

from twin.apps.export import EXPORT_FORMATS, export_path, online_format, robot_format, val3_alter
from twin.apps.export.val3_check import check_application
from twin.apps.online import alter_protocol as proto
from twin.errors import InputError
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.robot.description import load_robot
from twin.runs.write import write_path_csv


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """A 2-pass groove written as `val3-alter` (application `ISF`): file name -> text."""
    work = tmp_path_factory.mktemp("alter")
    path_csv = write_path_csv(groove_path(GrooveSpec(passes=2, bottom_length_m=0.066)), work / "short.csv")
    files = export_path(path_csv, "val3-alter", work / "ISF").files
    return {f.name: f.read_text(encoding="utf-8") for f in files}


def _code(pgx: str) -> list[str]:
    """A program's instructions, comments and blank lines left out."""
    code = ET.fromstring(pgx).find(".//{*}Code")
    text = "" if code is None else code.text or ""
    return [line.split("//", 1)[0].strip() for line in text.splitlines() if line.split("//", 1)[0].strip()]


def _points(app: dict[str, str]) -> int:
    root = ET.fromstring(app["ISF.dtx"])
    return int(next(d for d in root.iterfind(".//{*}Data") if d.get("name") == "pPath").get("size", "0"))


def test_the_application_passes_the_grammar_check_and_is_one_program(app: dict[str, str]) -> None:
    check_application(app)
    assert set(app) == {"ISF.pjx", "ISF.dtx", "start.pgx", "stop.pgx", "alterTask.pgx"}
    assert "resetMotion()" in _code(app["stop.pgx"])  # not empty: the motion reset when the application stops
    assert EXPORT_FORMATS["val3-alter"].online and EXPORT_FORMATS["val3-alter"].language == "VAL3"
    tx200 = load_robot("tx200")
    assert online_format(tx200) == "val3-alter" and robot_format(tx200) == "val3"


def test_contact_points_are_alter_moves_between_alter_begin_and_end(app: dict[str, str]) -> None:
    code = _code(app["start.pgx"])
    n = _points(app)
    moves = [i for i, line in enumerate(code) if re.match(r"(movej|movel|alterMovel)\(", line)]
    assert [code[i].split("(")[0] for i in moves] == ["movej", "movej", "alterMovel", "movel", "movej"]
    home, approach, alter, retract, back = moves
    assert code[home] == code[back] == "movej(jHome, tIsf, mApproach)" and code[back + 1 :] == [
        "waitEndMove()", "endIf", "bAlterRun = false", "end"]  # HOME first and last, the task stopped after it
    assert code[approach] == "movej(pPath[0], tIsf, mApproach)"  # the approach point: a joint move, not altered
    assert code[retract] == "movel(pPath[size(pPath) - 1], tIsf, mPath[size(pPath) - 1])"  # the retract: linear
    loop = re.fullmatch(r"for i = (\d+) to size\(pPath\) - (\d+)", code[alter - 2])
    assert loop is not None and code[alter] == "alterMovel(pPath[i], tIsf, mPath[i])"
    assert code[alter - 1] == "if bTwinLost == false" and code[alter + 1 : alter + 3] == ["endIf", "endFor"]
    altered = range(int(loop.group(1)), n - int(loop.group(2)) + 1)
    assert list(altered) == list(range(1, n - 1))  # every point but the approach and the retract
    begin, end = code.index("alterBegin(world, mPath[1])"), code.index("alterEnd()")
    task = next(i for i, line in enumerate(code) if line.startswith("taskCreateSync"))
    assert approach < task < begin < alter - 2 and alter + 2 < end < retract
    assert code[end - 2 : end] == ["waitEndMove()", "bAlterOn = false"]  # the altered moves done, then the end
    assert code[task] == f'taskCreateSync "alterTask", {proto.CYCLE_S:g}, bAlterOver, alterTask()'
    assert code[-2:] == ["bAlterRun = false", "end"]


def _binary_calls(code: list[str], name: str) -> list[tuple[str, int, str, int]]:
    """(buffer, byte offset, format, count) of each `toBinary(value, count, fmt, buf[off])` or
    `fromBinary(buf[off], bytes, fmt, value)` call; the offsets of a `for l_nI = 0 to k` loop unrolled."""
    calls = []
    for i, line in enumerate(code):
        m = re.search(name + r"\((.*)\)$", line)
        if m is None:
            continue
        parts = [a.strip() for a in m.group(1).split(",")]
        buf = re.fullmatch(r"(\w+)\[(\d+)(?: \+ (\d+) \* l_nI)?\]", parts[3] if name == "toBinary" else parts[0])
        assert buf is not None, line
        loop = re.fullmatch(r"for l_nI = 0 to (\d+)", code[i - 1])
        for k in range(int(loop.group(1)) + 1 if loop else 1):
            offset = int(buf.group(2)) + k * int(buf.group(3) or 0)
            calls.append((buf.group(1), offset, parts[2].strip('"'), int(parts[1])))
    return calls


def test_the_sync_task_writes_and_reads_the_protocols_frames(app: dict[str, str]) -> None:
    code = _code(app["alterTask.pgx"])
    local = {e.get("name"): int(e.get("size", "0")) for e in ET.fromstring(app["alterTask.pgx"]).iterfind(".//{*}Local")}
    assert local["l_nTx"] == proto.REQUEST_BYTES and local["l_nRx"] == proto.ANSWER_BYTES
    assert f"l_nMagic = {proto.MAGIC}" in code
    size = {proto.VAL3_INT32: 4, proto.VAL3_FLOAT32: 4}
    fmt = {proto.VAL3_INT32: "i", proto.VAL3_FLOAT32: "f"}
    # the request: toBinary counts values; the layout must be the protocol's struct
    sent = sorted(_binary_calls(code, "toBinary"), key=lambda c: c[1])
    assert {c[0] for c in sent} == {"l_nTx"}
    layout = "<" + "".join(fmt[f] * n for _, _, f, n in sent)
    assert struct.calcsize(layout) == proto.REQUEST_BYTES and layout == "<ii" + "f" * proto.JOINTS
    assert [o for _, o, _, _ in sent] == [0, 4, 8]
    # the answer: fromBinary counts bytes, one value each
    read = sorted(_binary_calls(code, "fromBinary"), key=lambda c: c[1])
    assert {c[0] for c in read} == {"l_nRx"} and all(n == size[f] for _, _, f, n in read)
    assert "<" + "".join(fmt[f] for _, _, f, _ in read) == "<ii" + "f" * 3 and proto.ANSWER.format == "<ii3f"
    assert [o for _, o, _, _ in read] == [struct.calcsize("<" + "iifff"[:k]) for k in range(5)]
    # one exchange a cycle: the answers read whole (seq and magic checked, at most 4 a cycle), then one request
    assert f"if l_nGot == {proto.ANSWER_BYTES}" in code and "l_nRead = sioGet(siTwin, l_nByte)" in code
    assert f"if l_nBytes < {val3_alter.MAX_ANSWERS_PER_CYCLE * proto.ANSWER_BYTES}" in code
    assert code.index("if l_nAnsMagic == l_nMagic") < code.index("alter(trAlter)")
    assert {"if l_nAnsSeq <= l_nApplied", "if l_nAnsSeq > l_nSeq",
            f"if l_nAnsSeq <= l_nSeq - {proto.MAX_AGE_CYCLES}"} <= set(code)
    assert code.index("alter(trAlter)") < code.index("l_jNow = herej()") < code.index("l_nSeq = l_nSeq + 1")
    assert code.index("if sioSet(siTwin, l_nTx) != size(l_nTx)") < code.index("delay(0)")
    # the second guard: the alteration is limited to nAlterMax = 5 mm before alter(); a stale answer holds
    assert "if l_nNorm > nAlterMax" in code and "l_nScale = nAlterMax / l_nNorm" in code
    data = {d.get("name"): d for d in ET.fromstring(app["ISF.dtx"]).iterfind(".//{*}Data")}
    assert float(data["nAlterMax"][0].get("value", "nan")) == val3_alter.MAX_ALTER_MM == 5.0
    assert data["siTwin"].get("type") == "sio" and data["siTwin"][0].get("link") == "Socket\\twin"
    assert code[code.index("if l_nFresh == 1") :].index("nAlterHeld = nAlterHeld + 1") > 0


def test_the_program_is_not_split_and_needs_its_approach(tmp_path: Path, app: dict[str, str]) -> None:
    path_csv = write_path_csv(groove_path(GrooveSpec(passes=2, bottom_length_m=0.066)), tmp_path / "s.csv")
    exported = export_path(path_csv, "val3-alter", tmp_path / "ISF", max_points=10)
    assert sorted(f.name for f in exported.files) == sorted(app)  # VAL3 walks data in a loop: never split
    with pytest.raises(InputError, match="approach"):
        val3_alter.application_files(replace(exported.path, approach=False))
    with pytest.raises(InputError, match="folder is its name"):
        export_path(path_csv, "val3-alter", tmp_path / "my app", max_points=10)


def test_a_failed_link_stops_forming_and_stop_resets_the_motion_and_closes_the_socket(app: dict[str, str]) -> None:
    """A socket error (`sioGet` -1, a failed `sioSet`) or `MAX_SILENT_CYCLES` without a fresh answer while altering
    sets `bTwinLost` and resets the motion (every cycle after, sending nothing more); `start` then queues no more
    alter moves and makes no retract or HOME; `stop` resets the motion, kills the task and closes the socket, as
    ros-industrial staubli_val3_driver's stop.pgx."""
    task = _code(app["alterTask.pgx"])
    lost = task.index("if l_nRead < 0")
    assert task[lost + 1] == "bTwinLost = true"
    silent = task.index(f"if l_nSilent >= {val3_alter.MAX_SILENT_CYCLES}")
    assert task[silent - 1] == "if bAlterOn" and task[silent + 1] == "bTwinLost = true"
    stop_at = task.index("if bTwinLost")
    assert lost < silent < stop_at and task[stop_at + 1] == "resetMotion()"
    assert stop_at < task.index("if l_nFresh == 1", stop_at) < task.index("alter(trAlter)")  # no alter once lost
    send = task.index("if sioSet(siTwin, l_nTx) != size(l_nTx)")
    assert task[send + 1 : send + 5] == ["nTwinErr = nTwinErr + 1", "bTwinLost = true", "resetMotion()", "endIf"]
    assert task.index("if bTwinLost == false") < task.index("l_jNow = herej()") < send  # nothing sent once lost
    start = _code(app["start.pgx"])
    assert start.index("bTwinLost = false") < start.index("alterBegin(world, mPath[1])")
    retract = start.index("movel(pPath[size(pPath) - 1], tIsf, mPath[size(pPath) - 1])")
    assert start[retract - 1] == "if bTwinLost == false" and start.index("alterEnd()") < retract - 1
    stop = _code(app["stop.pgx"])
    assert stop[0] == "begin" and stop[-1] == "end"
    assert {"resetMotion()", 'taskKill("alterTask")', "clearBuffer(siTwin)", "bAlterRun = false"} <= set(stop)
    data = {d.get("name"): d for d in ET.fromstring(app["ISF.dtx"]).iterfind(".//{*}Data")}
    assert data["bTwinLost"].get("type") == "bool"


@pytest.mark.parametrize(
    ("name", "old", "new", "pattern"),
    [
        ("stop.pgx", 'taskKill("alterTask")', "taskKill(alterTask)", "string literal"),
        ("stop.pgx", "\n  resetMotion()", "\n  resetMotion(siTwin)", "takes 0 argument"),
        ("alterTask.pgx", "bTwinLost = true", "bTwinLst = true", "not a declared variable"),
        ("start.pgx", "alterMovel(pPath[i], tIsf, mPath[i])", "alterMovel(pPath[i], mPath[i], tIsf)", "not a tool"),
        ("start.pgx", "alterBegin(world, mPath[1])", "alterBegin(tIsf, mPath[1])", "not a frame"),
        ("start.pgx", "alterEnd()", "alterEnd(1)", "takes 0 argument"),
        ("start.pgx", ", bAlterOver, alterTask()", ", nAlterMax, alterTask()", "not a bool"),
        ("start.pgx", ", bAlterOver, alterTask()", ", bAlterOver, alterTsk()", "not another program"),
        ("alterTask.pgx", "alter(trAlter)", "alter(l_nA)", "not a trsf"),
        ("alterTask.pgx", '"4.0l"', '"8.0l"', "format"),
        ("alterTask.pgx", 'sioCtrl(siTwin, "timeout", -1)', "sioCtrl(siTwin, timeout, -1)", "string literal"),
        ("alterTask.pgx", "l_jNow.j6", "l_jNow.j7", "no field"),
        ("alterTask.pgx", "l_nMagic = ", 'l_nMagic = "x" + ', "unexpected"),
        ("ISF.dtx", 'link="Socket\\twin"', 'link="twin"', "link"),
        ("ISF.dtx", 'value="false"', 'value="0"', "'true' or 'false'"),
    ],
)
def test_the_grammar_check_stays_strict_on_the_new_instructions(
    app: dict[str, str], name: str, old: str, new: str, pattern: str
) -> None:
    files = dict(app)
    assert old in files[name]
    files[name] = files[name].replace(old, new, 1)
    with pytest.raises(InputError, match=pattern):
        check_application(files)
