"""KUKA KRL with RSI: the `krl` program with the twin's online correction switched on around the path, and the RSI
Ethernet configuration that connects the controller to `tx200-twin online --serve rsi`.

The program is `twin.apps.export.krl`'s, with the RSI calls of the ros-industrial `kuka_rsi_hw_interface`
programs around its path: after the joint move to the approach point (`PTP P_PATH[1]`), `RSI_CREATE` of the context
`ISF_RSI` and `RSI_ON(#ABSOLUTE)` (each correction replaces the last, as the server sends them); after the retract,
the path's last move, `RSI_OFF()`, before the joint move HOME; a failing call halts. The moves HOME are never
corrected. A split program switches RSI on in its first part, after the approach, and off at the end of its last
part, after the retract (each part that calls RSI declares `ret`). That RSI corrects the path's spline motions
(`SPLINE` blocks, `SLIN`) as it does `LIN`s is assumed, from KUKA's RSI manuals as recalled: check it with the
controller's RSI version before a first run.
`NAME_rsi_ethernet.xml` is the ETHERNET object's configuration (the layout of that repository's
`ros_rsi_ethernet.xml`): the controller sends its actual pose, axes, late-packet count and the F/T sensor's
forces (the object's inputs 1-3, `<FT Fx Fy Fz>`, N, sheet frame) and receives `RKorr` X Y Z A B C (outputs 1-6,
held on a lost packet). The RSI diagram `ISF_RSI.rsix` itself is drawn in KUKA's RSI Visual: the ETHERNET object
with this file, its outputs 1-6 into a POSCORR object (base frame, absolute, with the limits the cell allows),
the sensor's three force channels into its inputs 1-3.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import twin.apps.export.krl as krl
from twin.apps.export.program import ProgramPath
from twin.base.csvio import write_text

CONTEXT = "ISF_RSI"
#: Where `tx200-twin online --serve rsi` listens by default.
DEFAULT_PORT = 49152
RSI_ON = ["ret=RSI_CREATE(\"" + CONTEXT + "\",CONTID,TRUE)", "IF (ret<>RSIOK) THEN", "  HALT", "ENDIF",
          "ret=RSI_ON(#ABSOLUTE)", "IF (ret<>RSIOK) THEN", "  HALT", "ENDIF"]
RSI_OFF = ["ret=RSI_OFF()", "IF (ret<>RSIOK) THEN", "  HALT", "ENDIF"]
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
    """The `krl` files with RSI switched on around the path (module docstring), and the Ethernet configuration."""
    files = krl.program_files(path)
    sources = [name for name in files if name.endswith(".src")]
    approach = "PTP P_PATH[1]"
    on = next(name for name in sources if approach in files[name].splitlines())
    off = sources[-1]  # the whole program, or the last part: the one with the retract
    lines = {name: files[name].splitlines() for name in dict.fromkeys((on, off))}
    at = lines[on].index(approach) + 1
    lines[on][at:at] = RSI_ON
    last = lines[off]
    end = len(last) - 1 - last[::-1].index("END")
    at = end - 1 if last[end - 1] == f"PTP {krl.HOME}" else end  # after the retract, before the move HOME
    last[at:at] = RSI_OFF
    for name, text in lines.items():
        declare = next(i for i, line in enumerate(text) if line.startswith("DEF ")) + 1
        text[declare:declare] = ["DECL INT ret"] + (["DECL INT CONTID"] if name == on else [])
        files[name] = "\n".join(text) + "\n"
    files[f"{path.name}_rsi_ethernet.xml"] = ethernet_config()
    return files


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the program (`krl.write`'s files, with RSI) and its Ethernet configuration beside `out`."""
    return [write_text(Path(out).with_name(name), text, protect=protect)
            for name, text in program_files(path).items()]
