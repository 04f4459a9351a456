"""ABB RAPID with EGM path correction: the `rapid` program with the twin's online correction switched on in the
path's moves, and the two controller configurations that connect it to `tx200-twin online --serve egm`.

Externally Guided Motion (EGM, RobotWare option 3124-1) in its path-correction mode: the program's linear moves
are `EGMMoveL`, and while they run the controller streams its state over UDP to the PC and adds the offset the PC
answers with (in EGM's path coordinates, which the server turns its base-frame correction into). The program is
`twin.apps.export.rapid`'s data, tool and home, moved like this:

- `MoveAbsJ jHome` (HOME, as `rapid`'s first and last move), then `MoveJ` to the approach point `pApproach`, a
  normal joint move: no correction before the tool is over the path;
- `EGMReset egmID; EGMGetId egmID;` (a fresh identity, whatever an aborted run left),
  `EGMSetupUC ROB_1,egmID,"pathCorr","UCdevice"\\PathCorr\\APTR;` (the UDP device and the motion profile below;
  `\\APTR`: the correction applies at the tool tip, where the twin computes it) and
  `EGMActMove egmID,tIsf.tframe\\SampleRate:=4;` (the sensor frame is the tool frame; 4 ms, the twin's cycle);
- the path's points `pPath{1..nPath}` (the path CSV's data rows 1..n, in order) as `EGMMoveL egmID,...,z0,...`
  with speeds `vPath{n}`, the last one `fine`: the corrected path ends at rest;
- `EGMStop egmID,EGM_STOP_HOLD;` then the retract `MoveL pRetract,vRetract,fine,...`, uncorrected, and
  `MoveAbsJ jHome`. The corrected moves keep their `z0` zone (not `rapid`'s `zPath` and `fine` corners).

No `egm_minmax` is declared: convergence limits belong to the guidance modes (`EGMActJoint`/`EGMActPose` with
`EGMRunJoint`/`EGMRunPose`); a path correction ends with its moves. A program over the RAPID limit
(`twin.apps.export.parts`, counted over the path's points) keeps `VAR egmident egmID` (global), the tool, the
work object, the approach and the retract in its main module `NAME.mod`, whose `main` sets EGM up and activates it
after the approach, calls `NAME_1;`, `NAME_2;`, ... and stops it before the retract; each part `NAME_k.mod` holds
its own `LOCAL` points and only `EGMMoveL`s (the last part's last one `fine`).

`NAME_egm_sio.cfg` (Communication > Transmission Protocol) is the UDP unicast device `UCdevice` (type `UDPUC`) with
the PC's address (a placeholder to set) and `DEFAULT_PORT`; `NAME_egm_moc.cfg` (Motion > External Motion Interface
Data) is the profile `pathCorr`: level 2 (path correction) and a `FILTER_BANDWIDTH_HZ` low-pass on the
corrections, above the twin's own 10 Hz force filter (`twin.sim.online.OnlineSettings.filter_hz`) so that it
smooths the 4 ms steps without adding more than a few ms of lag. Load both with "add, replace duplicates" to keep
the rest of the controller's configuration.

Followed (public sources; syntax checked against them, no text copied):
- rpiRobotics/abb_motion_program_exec `robot/HOME/motion_program_exec_egm.mod` (`EGMSetupUC ... "UCdevice"
  \\PathCorr\\APTR`, `EGMActMove ...\\SampleRate:=`, `EGMStop ...,EGM_STOP_HOLD`), `robot/config_params_egm/
  MOC.cfg` (the `EXT_MOTION_DATA` profiles, `-ext_motion_level 2` for path correction,
  `-ext_motion_filter_bandwidth`) and `docs/egm.md` (the `UCdevice` under Communication > Transmission Protocol;
  corrections in path coordinates, `EGMMoveL`/`EGMMoveC` only);
- FLo-ABB/ABB-EGM-Python `examples/simple/example_path_correction.py` (the RAPID in its header: `EGMReset`,
  `EGMGetId`, `EGMSetupUC ...\\PathCorr\\APTR`, `EGMActMove tool.tframe`, `EGMMoveL`, then `EGMStop` after the last
  move; the profile's level "Path");
- 11charon/PROFINETRobotControl `SIO.cfg` (the `SIO:CFG_1.0` header and the `COM_TRP` section's layout).
The public path-correction examples activate with `\\SampleRate:=` 24 to 120 ms and abb_motion_program_exec notes
that the controller takes path corrections slower than it streams; `SAMPLE_RATE_MS` is the twin's cycle, and the
server must not assume the controller answers every 4 ms.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import twin.apps.export.rapid as rapid
from twin.apps.export.parts import parts
from twin.apps.export.program import ProgramPath
from twin.base.csvio import write_text
from twin.errors import InputError

#: Where `tx200-twin online --serve egm` listens by default [UDP port].
DEFAULT_PORT = 6510
#: The EGM identity the program declares and every EGM instruction uses.
EGM_ID = "egmID"
#: The UDP unicast device (`NAME_egm_sio.cfg`) and the motion profile (`NAME_egm_moc.cfg`) `EGMSetupUC` names.
DEVICE = "UCdevice"
PROFILE = "pathCorr"
#: `EGMActMove`'s sample rate: the twin's cycle (`twin.sim.online.OnlineSettings.cycle_s`) [ms].
SAMPLE_RATE_MS = 4
#: External Motion Interface Data level of a path correction (abb_motion_program_exec's `path_corr`).
PATH_CORRECTION_LEVEL = 2
#: Low-pass on the corrections in the controller [Hz] (module docstring).
FILTER_BANDWIDTH_HZ = 20
#: The PC's address in the UDP device: a placeholder, to be set to the PC that runs `online --serve egm`.
PC_ADDRESS = "192.168.125.2"

EGM_ON = [
    f"    EGMReset {EGM_ID};",
    f"    EGMGetId {EGM_ID};",
    f'    EGMSetupUC ROB_1,{EGM_ID},"{PROFILE}","{DEVICE}"\\PathCorr\\APTR;',
    f"    EGMActMove {EGM_ID},tIsf.tframe\\SampleRate:={SAMPLE_RATE_MS};",
]
EGM_OFF = [f"    EGMStop {EGM_ID},EGM_STOP_HOLD;"]
SIO = """SIO:CFG_1.0:6:1::
#
COM_TRP:

      -Name "{device}" -Type "UDPUC" -RemoteAdress "{host}"\\
      -RemotePortNumber {port}
"""
MOC = """MOC:CFG_1.0:6:0::
#
EXT_MOTION_DATA:

      -name "{profile}" -ext_motion_level {level} -do_not_restart_after_motors_off \\
      -ext_motion_filter_bandwidth {bandwidth}
"""


def sio_config(host: str = PC_ADDRESS, port: int = DEFAULT_PORT) -> str:
    """The UDP unicast device `UCdevice`: the controller streams to `host`:`port` and takes the answers."""
    return SIO.format(device=DEVICE, host=host, port=port)


def moc_config() -> str:
    """The External Motion Interface Data profile `pathCorr` (path correction, filtered; module docstring)."""
    return MOC.format(profile=PROFILE, level=PATH_CORRECTION_LEVEL, bandwidth=FILTER_BANDWIDTH_HZ)


def _contact(path: ProgramPath) -> ProgramPath:
    """The path's own points, approach and retract left out: what EGM corrects."""
    configs = path.configurations[1:-1]
    return replace(path, points_mm=path.points_mm[1:-1], feed_mm_s=path.feed_mm_s[1:-1], configurations=configs,
                   cell=replace(path.cell, configuration=configs[0] if configs else None), joint_start=False)


def _ends(path: ProgramPath) -> list[str]:
    """The approach and retract points and the retract's speed (main module data)."""
    ends = replace(path, points_mm=path.points_mm[[0, -1]], feed_mm_s=path.feed_mm_s[[0, -1]],
                   configurations=path.configurations[:1] + path.configurations[-1:])
    approach, retract = rapid.robtargets(ends)
    return [f"  CONST robtarget pApproach:={approach};", f"  CONST robtarget pRetract:={retract};",
            f"  CONST speeddata vRetract:={rapid.speeddata(float(path.feed_mm_s[-1]))};"]


def _corrected(last: bool) -> list[str]:
    """The corrected moves through `pPath{1..nPath}`; the program's last one ends `fine`."""
    return [
        "    FOR i FROM 1 TO nPath - 1 DO",
        f"      EGMMoveL {EGM_ID},pPath{{i}},vPath{{i}},z0,tIsf\\WObj:=wSheet;",
        "    ENDFOR",
        f"    EGMMoveL {EGM_ID},pPath{{nPath}},vPath{{nPath}},{'fine' if last else 'z0'},tIsf\\WObj:=wSheet;",
    ]


def _main(path: ProgramPath, body: list[str], data: list[str], note: list[str]) -> str:
    """The main module: header, tool, work object, the EGM identity, data, and `main` with EGM around `body`."""
    lines = [
        f"MODULE {path.name}", *rapid.about(path), *note,
        f"  ! EGM path correction in the path's moves (tx200-twin online --serve egm, UDP port {DEFAULT_PORT}): "
        f"device {DEVICE} in {path.name}_egm_sio.cfg, profile {PROFILE} in {path.name}_egm_moc.cfg",
        *rapid.declarations(path), f"  VAR egmident {EGM_ID};", *_ends(path), *data, "",
        "  PROC main()", "    ConfJ \\On;", "    ConfL \\Off;", rapid.home_move(),
        f"    MoveJ pApproach,{rapid.APPROACH_SPEED},fine,tIsf\\WObj:=wSheet;",
        *EGM_ON, *body, *EGM_OFF,
        "    MoveL pRetract,vRetract,fine,tIsf\\WObj:=wSheet;",
        rapid.home_move(), "  ENDPROC", "ENDMODULE",
    ]
    return "\n".join(lines) + "\n"


def program_files(path: ProgramPath) -> dict[str, str]:
    """The module `NAME.mod` (and a split program's parts) with EGM path correction, and its two configurations.

    Raises:
        InputError: A path without its approach and retract (`motion.with_moves`): EGM is switched on between them.
    """
    if not path.approach or len(path.points_mm) < 3:
        raise InputError(f"program {path.name!r} ({len(path.points_mm)} points, approach={path.approach}): "
                         "rapid-egm expects a program with its approach and retract around at least one path "
                         "point (export_path adds them)")
    contact = _contact(path)
    pieces = parts(contact, "rapid")
    if len(pieces) == 1:
        files = {f"{path.name}.mod": _main(path, _corrected(True), rapid.path_data(contact, ""), [])}
    else:
        calls = [f"    {piece.name};" for piece in pieces]
        files = {f"{path.name}.mod": _main(path, calls, [], [f"  ! {len(pieces)} parts, in order"])}
        for k, piece in enumerate(pieces):
            body = [*rapid.path_data(piece, "LOCAL "), "", f"  PROC {piece.name}()",
                    *_corrected(k == len(pieces) - 1), "  ENDPROC"]
            files[f"{piece.name}.mod"] = "\n".join([f"MODULE {piece.name}", *body, "ENDMODULE"]) + "\n"
    files[f"{path.name}_egm_sio.cfg"] = sio_config()
    files[f"{path.name}_egm_moc.cfg"] = moc_config()
    return files


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the module (to `out`), any parts and the two configurations beside it, atomically (never over an
    input)."""
    return [
        write_text(Path(out) if name == f"{path.name}.mod" else Path(out).with_name(name), text, protect=protect)
        for name, text in program_files(path).items()
    ]
