"""KUKA KRL with RSI: the `krl` program with the twin's online correction switched on around the path, the RSI
context its `RSI_CREATE` names and the ETHERNET object's configuration that connects the controller to
`tx200-twin online --serve rsi`.

Targets KUKA.RobotSensorInterface 4.x (KSS 8.5/8.6, KR C4): the context is one `.rsix` file, the layout RSIVisual
(WorkVisual) generates, as in ros-industrial `kuka_experimental`, `kuka_rsi_hw_interface/krl/KR_C4/ros_rsi.rsix`
("RobotSensorInterface 4.0"; read). RSI 3.x (KSS 8.3) reads a `.rsi` + `.rsi.xml` pair instead, which this
exporter does not write.

The program is `twin.apps.export.krl`'s (its tool and base slots, its `$STOPMESS` interrupt), with the RSI calls of
the ros-industrial `kuka_rsi_hw_interface` programs (`krl/KR_C4/ros_rsi.src`, `krl/KR_C4_RSI_4+/ros_rsi.src`,
read) around its path: after the joint move to the approach point (`PTP P_PATH[1]`),
`RSI_CREATE("NAME_RSI.rsix",CONTID,TRUE)`, the context file named with its extension, and
`RSI_ON(#ABSOLUTE,#IPO_FAST)`: absolute, as the server sends the whole correction each cycle (not an increment),
and the 4 ms sensor cycle (`#IPO_FAST`; `#IPO` would be 12 ms); after the retract, the path's last move,
`RSI_OFF()`, before the joint move HOME; a failing call halts. The moves HOME are never corrected. A split program
switches RSI on in its first part, after the approach, and off at the end of its last part, after the retract
(each part that calls RSI declares `ret`). That RSI corrects the path's spline motions (`SPLINE` blocks, `SLIN`)
as it does `LIN`s is assumed, from KUKA's RSI manuals as recalled: check it with the controller's RSI version
before a first run.

**The correction's frame.** `tx200-twin online --serve rsi` (`twin.apps.online.rsi`) sends `RKorr` X Y Z in the
robot's base frame, while the program's `$BASE` is the sheet frame (`BASE_DATA[b]`, rotated by the sheet's yaw).
They agree because the POSCORR object corrects in `#WORLD` (`CORRECTION_FRAME`), not `#BASE`: the robot base is
the world when `$ROBROOT` is the null frame, a floor-mounted robot on no linear axis (KSS's default). A cell whose
`$ROBROOT` is not null must rotate the correction (or the server must send it in the sheet frame with POSCORR in
`#BASE`). The program's header says so.

`NAME_RSI.rsix` (`rsi_context`) holds, each object as RSIVisual names it:

- the **ETHERNET** object (`Ethernet`, type id 64, as in `ros_rsi.rsix`) with its `ConfigFile`
  (`NAME_rsi_ethernet.xml`), its `Timeout` (`LATE_PACKET_LIMIT`: the late or lost packets the controller accepts
  before it stops the robot; `ros_rsi.rsix` uses 100), `Flag` and `Precision`;
- the **POSCORR** object (`PosCorr`, type id 27) fed by the ETHERNET object's outputs 1-6 (`RKorr` X Y Z A B C),
  its limits `LowerLimX..Z` / `UpperLimX..Z` = -/+ the program's `max_correction_mm` (the compensator's own
  limit, 5 mm unless `export --max-correction-mm` gives the one its server is given: RSI clips what passes it), `MaxRotAngle` 0 (the twin corrects no orientation) and its reference
  frame `RefCorrSys` = `#WORLD`;
- the **correction monitor** (`PosCorrMon`), `MaxTrans` = sqrt(3) x the limit (the most the clipped correction
  can reach: it stops the robot only if the limits failed) and `MaxRotAngle` 1 deg.

Its Ethernet configuration (`ETHERNET`) sends the actual pose and axes (`DEF_RIst`, `DEF_AIPos`), the set-point
axes (`DEF_ASPos`: the planned motion without the correction, which signs the friction's lag in the compensator,
`twin.sim.online`) and the late-packet count (`DEF_Delay`), each `INDX="INTERNAL"` as ros-industrial's
`kuka_rsi_hw_interface/krl/KR_C4/ros_rsi_ethernet.xml` declares them, and the F/T sample on channels 1-3.

What could be read in public files: the `.rsix` layout (`RsiContext`, `RsiObjects`, `RsiObject ObjTypeId ObjType
ObjId`, `Inputs/Input InIdx OutObjId OutIdx`, `Parameters/Parameter Name ParamId ParamValue`), the ETHERNET object
and its four parameters (`ros_rsi.rsix`); `PosCorr` type 27 with `LowerLimX..UpperLimZ` at ids 0-5 and inputs 0-5
the correction X..C (third-party public `.rsix` files, read, not primary). Not found in public code and taken
from KUKA's RSI manuals as recalled, to be checked by opening the file in RSIVisual (and regenerating it there)
before a first run: `MaxRotAngle` and `RefCorrSys` of POSCORR and their ids, the value `#WORLD`, the `PosCorrMon`
object's type id and parameters, `RSI_ON`'s second argument `#IPO_FAST`, and that `RSI_CREATE` takes the
`.rsix` name with its extension (ros-industrial's RSI 4 program passes `"ros_rsi"` without one). Nothing of this
can be checked without a controller: the tests check that the program names a context that is written, that the
context's ETHERNET object names the configuration written beside it, and the limits and frame said here.
The force sensor's three channels must still be wired to the ETHERNET object's inputs 1-3 (`FT.Fx/Fy/Fz` of the
configuration) in RSIVisual, from whichever object reads the cell's sensor; or the server reads the sensor's own
stream (`online --serve rsi --ft-rdt`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import twin.apps.export.krl as krl
from twin.apps.export.program import ProgramPath
from twin.base.csvio import write_text

#: Where `tx200-twin online --serve rsi` listens by default.
DEFAULT_PORT = 49152
#: The correction mode (the server sends the whole correction each cycle) and the sensor cycle (4 ms).
MODE, CYCLE = "#ABSOLUTE", "#IPO_FAST"
#: POSCORR's reference frame: the robot base as the world (`$ROBROOT` null; module docstring).
CORRECTION_FRAME = "#WORLD"
#: The ETHERNET object's `Timeout`: late or lost packets accepted before the controller stops the robot.
LATE_PACKET_LIMIT = 100
MONITOR_MAX_DEG = 1.0


def monitor_max_mm(limit_mm: float) -> float:
    """The correction monitor's limit [mm]: the most a correction limited to `limit_mm` a axis can reach (POSCORR's
    per-axis limit is the program's `ProgramPath.max_correction_mm`, the compensator's own)."""
    return math.ceil(math.sqrt(3.0) * limit_mm * 10.0) / 10.0


RSI_OFF = ["ret=RSI_OFF()", "IF (ret<>RSIOK) THEN", "  HALT", "ENDIF"]


def context_file(name: str) -> str:
    """The RSI context's file of program `name` (what `RSI_CREATE` names, with its extension)."""
    return f"{name}_RSI.rsix"


def ethernet_file(name: str) -> str:
    """The ETHERNET object's configuration file of program `name`."""
    return f"{name}_rsi_ethernet.xml"


def rsi_on(name: str) -> list[str]:
    """The lines that create the context and switch RSI on (module docstring)."""
    return [f'ret=RSI_CREATE("{context_file(name)}",CONTID,TRUE)', "IF (ret<>RSIOK) THEN", "  HALT", "ENDIF",
            f"ret=RSI_ON({MODE},{CYCLE})", "IF (ret<>RSIOK) THEN", "  HALT", "ENDIF"]


def frame_lines(name: str, limit_mm: float) -> list[str]:
    """The program header's comment on the RSI context and the correction's frame."""
    return [f"; RSI (KUKA.RobotSensorInterface 4.x): context {context_file(name)}, Ethernet {ethernet_file(name)}, "
            f"RSI_ON({MODE},{CYCLE}): 4 ms, each RKorr the whole correction",
            f"; RKorr X Y Z from tx200-twin online --serve rsi is in the ROBOT BASE frame, not $BASE (the sheet): "
            f"POSCORR corrects in {CORRECTION_FRAME},",
            "; the robot base when $ROBROOT is the null frame (check $ROBROOT on this cell); "
            f"limits +/-{limit_mm:g} mm a axis, monitor {monitor_max_mm(limit_mm):g} mm"]


_CONTEXT = """<?xml version="1.0" encoding="utf-8"?>
<!-- tx200-twin: RSI context {context} for KUKA.RobotSensorInterface 4.x (the layout RSIVisual generates);
     open it in RSIVisual and check it before a first run (twin/apps/export/krl_rsi.py says what is assumed). -->
<!-- RKorr comes in the robot base frame; POSCORR corrects in {frame} (the robot base when $ROBROOT is null). -->
<RsiContext xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns:xsd="http://www.w3.org/2001/XMLSchema" Version="0.1.0">
  <RsiObjects>
    <RsiObject ObjTypeId="64" ObjType="Ethernet" ObjId="Ethernet_1">
      <Parameters>
        <Parameter IsRuntime="false" Name="ConfigFile" ParamId="0" ParamValue="{ethernet}" />
        <Parameter Name="Timeout" ParamId="0" ParamValue="{timeout}" />
        <Parameter Name="Flag" ParamId="3" ParamValue="1" />
        <Parameter Name="Precision" ParamId="7" ParamValue="4" />
      </Parameters>
    </RsiObject>
    <RsiObject ObjTypeId="27" ObjType="PosCorr" ObjId="PosCorr_1">
      <Inputs>
{inputs}
      </Inputs>
      <Parameters>
{limits}
        <Parameter Name="MaxRotAngle" ParamId="6" ParamValue="0" />
        <Parameter Name="RefCorrSys" ParamId="7" ParamValue="{frame}" />
      </Parameters>
    </RsiObject>
    <RsiObject ObjTypeId="28" ObjType="PosCorrMon" ObjId="PosCorrMon_1">
      <Parameters>
        <Parameter Name="MaxTrans" ParamId="0" ParamValue="{monitor_mm:g}" />
        <Parameter Name="MaxRotAngle" ParamId="1" ParamValue="{monitor_deg:g}" />
      </Parameters>
    </RsiObject>
  </RsiObjects>
</RsiContext>
"""


def rsi_context(name: str, limit_mm: float) -> str:
    """The RSI context `context_file(name)`: ETHERNET, POSCORR and its monitor (module docstring)."""
    inputs = "\n".join(f'        <Input InIdx="{i}" OutObjId="Ethernet_1" OutIdx="{i}" />'
                       for i, _ in enumerate("XYZABC"))  # POSCORR's six channels
    limits = "\n".join(f'        <Parameter Name="{side}Lim{axis}" ParamId="{3 * k + j}" ParamValue="{sign}{limit_mm:g}" />'
                       for k, (side, sign) in enumerate((("Lower", "-"), ("Upper", "")))
                       for j, axis in enumerate("XYZ"))
    return _CONTEXT.format(context=context_file(name), frame=CORRECTION_FRAME, ethernet=ethernet_file(name),
                           timeout=LATE_PACKET_LIMIT, inputs=inputs, limits=limits, monitor_mm=monitor_max_mm(limit_mm),
                           monitor_deg=MONITOR_MAX_DEG)
ETHERNET = """<ROOT>
   <CONFIG>
      <IP_NUMBER>{host}</IP_NUMBER>   <!-- the PC that serves the twin (tx200-twin online, RSI) -->
      <PORT>{port}</PORT>
      <SENTYPE>ImFree</SENTYPE>
      <ONLYSEND>FALSE</ONLYSEND>
   </CONFIG>
   <SEND>
      <ELEMENTS>
         <ELEMENT TAG="DEF_RIst" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_AIPos" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_ASPos" TYPE="DOUBLE" INDX="INTERNAL" />
         <ELEMENT TAG="DEF_Delay" TYPE="LONG" INDX="INTERNAL" />
         <ELEMENT TAG="FT.Fx" TYPE="DOUBLE" INDX="1" />
         <ELEMENT TAG="FT.Fy" TYPE="DOUBLE" INDX="2" />
         <ELEMENT TAG="FT.Fz" TYPE="DOUBLE" INDX="3" />
      </ELEMENTS>
   </SEND>
   <RECEIVE>
      <ELEMENTS>
{receive}
      </ELEMENTS>
   </RECEIVE>
</ROOT>
"""


def ethernet_config(host: str = "192.168.1.2", port: int = DEFAULT_PORT) -> str:
    """The ETHERNET object's configuration (module docstring)."""
    receive = "\n".join(f'         <ELEMENT TAG="RKorr.{axis}" TYPE="DOUBLE" INDX="{i}" HOLDON="1" />'
                        for i, axis in enumerate("XYZABC", start=1))
    return ETHERNET.format(host=host, port=port, receive=receive)


def program_files(path: ProgramPath) -> dict[str, str]:
    """The `krl` files with RSI switched on around the path (module docstring), the RSI context and the Ethernet
    configuration."""
    files = krl.program_files(path)
    sources = [name for name in files if name.endswith(".src")]
    approach = "PTP P_PATH[1]"
    on = next(name for name in sources if approach in files[name].splitlines())
    off = sources[-1]  # the whole program, or the last part: the one with the retract
    lines = {name: files[name].splitlines() for name in dict.fromkeys((on, off))}
    at = lines[on].index(approach) + 1
    lines[on][at:at] = rsi_on(path.name)
    last = lines[off]
    end = len(last) - 1 - last[::-1].index("END")
    at = end - 1 if last[end - 1] == f"PTP {krl.HOME}" else end  # after the retract, before the move HOME
    last[at:at] = RSI_OFF
    for name, text in lines.items():
        declare = next(i for i, line in enumerate(text) if line.startswith("DEF ")) + 1
        text[declare:declare] = ["DECL INT ret"] + (["DECL INT CONTID"] if name == on else [])
        files[name] = "\n".join(text) + "\n"
    main = f"{path.name}.src"
    text = files[main].splitlines()
    header = next(i for i, line in enumerate(text) if line.startswith("DEF ")) + 1
    text[header:header] = frame_lines(path.name, path.max_correction_mm)
    files[main] = "\n".join(text) + "\n"
    files[ethernet_file(path.name)] = ethernet_config()
    files[context_file(path.name)] = rsi_context(path.name, path.max_correction_mm)
    return files


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the program (`krl.write`'s files, with RSI), its RSI context and its Ethernet configuration beside
    `out`."""
    return [write_text(Path(out).with_name(name), text, protect=protect)
            for name, text in program_files(path).items()]
