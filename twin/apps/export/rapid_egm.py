"""ABB RAPID with EGM path correction: the `rapid` program with the twin's online correction switched on in the
path's moves, and the two controller configurations that connect it to `tx200-twin online --serve egm`.

Externally Guided Motion (EGM, RobotWare option 3124-1) in its path-correction mode: the program's linear moves
are `EGMMoveL`, and while they run the controller streams its state over UDP to the PC and adds the offset the PC
answers with (in EGM's path coordinates, which the server turns its base-frame correction into). The program is
`twin.apps.export.rapid`'s data, tool and home, moved like this:

- `MoveAbsJ jHome` (HOME, as `rapid`'s first and last move), then `MoveJ` to the approach point `pApproach`, a
  normal joint move: no correction before the tool is over the path;
- `EGMReset egmID; EGMGetId egmID;` (a fresh identity, whatever an aborted run left),
  `EGMSetupUC ROB_1,egmID,"pathCorr","UCdevice"\\PathCorr\\APTR\\CommTimeout:=1;` (the UDP device and the motion
  profile below; `\\APTR`: the correction applies at the tool tip, where the twin computes it; no answer from the PC
  for `COMM_TIMEOUT_S` raises `ERR_UDPUC_COMM`), an `EGMGetState(egmID) <> EGM_STATE_CONNECTED` check that ends
  the program at the approach point (tool out of the sheet) when the set-up failed, and
  `EGMActMove egmID,tIsf.tframe\\SampleRate:=48;` (the sensor frame is the tool frame; path correction reads the
  sensor at multiples of 24 ms, "Valid values: 24, 48, 72", 48 as the manual's examples: the server streams every
  4 ms, the controller takes one correction in 12);
- the path's points `pPath{1..nPath}` (the path CSV's data rows 1..n, in order) as `EGMMoveL egmID,...` with speeds
  `vPath{n}`: `fine` at the offline program's corners (`motion.corners`: the plunge onto the path, the groove's
  reversals) and at the last point (a path correction starts and ends in a fine point), `z0` between;
- `EGMStop egmID,EGM_STOP_HOLD;` then the retract `MoveL pRetract,vRetract,fine,...`, uncorrected, and
  `MoveAbsJ jHome`;
- the entry procedure `isf_NAME`'s ERROR handler (`rapid.entry`): on `ERR_UDPUC_COMM` (the PC went silent during
  a corrected move, raised in it or in a part it calls) `StopMove; ClearPath; StartMove;`, `EGMReset`, a `MoveL`
  of `nLift` mm along the sheet's z
  (`Offs(CRobT(...),0,0,nLift)`: the retract's height above the deepest path point, so the tool leaves the sheet
  from wherever it stopped; the sheet frame's z points away from the sheet, as the retract above the path shows)
  and `EXIT`; any other error is raised on.

EGM path correction corrects only y and z of its path frame ("nor corrections in x (which is the path
direction/tangent)", 3HAC073318 rev. K): the twin's correction along the path is dropped, which the header and
the export's note say (`ALONG_PATH_NOTE`). Measured on the dynamic plant (docs/online.md, "Path correction or
position guidance"): the 48 ms rate costs little, the dropped along-path part most of the groove's correction, whose
deflection lies along its passes; position guidance (`EGMRunPose`, every axis each 4 ms, the PC streaming the whole
path) keeps it: `rapid_egm_pose`, `export --online`'s default for ABB (this one: `--egm-mode path`).

No `egm_minmax` is declared: convergence limits belong to the guidance modes (`EGMActJoint`/`EGMActPose` with
`EGMRunJoint`/`EGMRunPose`); a path correction ends with its moves. A program over the RAPID limit
(`twin.apps.export.parts`, counted over the path's points) keeps `VAR egmident egmID` (global), the tool, the
work object, the approach and the retract in its main module `NAME.mod`, whose `isf_NAME` sets EGM up and activates it
after the approach, calls `NAME_1;`, `NAME_2;`, ... and stops it before the retract; each part `NAME_k.mod` holds
its own `LOCAL` points and only `EGMMoveL`s (the last part's last one `fine`).

`NAME_egm_sio.cfg` (Communication > Transmission Protocol) is the UDP unicast device `UCdevice` (type `UDPUC`) with
the PC's address (a placeholder to set) and `DEFAULT_PORT`; `NAME_egm_moc.cfg` (Motion > External Motion Interface
Data) is the profile `pathCorr`: level 2 (path correction). No controller filter is set (the profile keeps the
controller's default); the only filtering the twin applies is its own force low-pass in the compensator
(`twin.sim.online.OnlineSettings.filter_hz`). Load both with "add, replace duplicates" to keep the rest of the
controller's configuration.

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
- ABB EGM application manual 3HAC073318 rev. K (copy in FLo-ABB/ABB-EGM-Python `doc/`): `\\SampleRate` multiples
  of 24 ms for path correction, y and z only, fine points at start and end, `\\CommTimeout`, `EGMGetState`.
Not checked without a controller: that `ERR_UDPUC_COMM` is what an `EGMMoveL` raises on this RobotWare when the
PC goes silent, that the handler's `MoveL` may run after `EGMReset` there, and the profile's defaults.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

import twin.apps.export.rapid as rapid
from twin.apps.export.motion import corners
from twin.apps.export.parts import parts
from twin.apps.export.program import ProgramPath, fmt
from twin.base.csvio import write_text
from twin.errors import InputError

#: Where `tx200-twin online --serve egm` listens by default [UDP port].
DEFAULT_PORT = 6510
#: The EGM identity the program declares and every EGM instruction uses.
EGM_ID = "egmID"
#: The UDP unicast device (`NAME_egm_sio.cfg`) and the motion profile (`NAME_egm_moc.cfg`) `EGMSetupUC` names.
DEVICE = "UCdevice"
PROFILE = "pathCorr"
#: `EGMActMove`'s sample rate [ms]: path correction reads the sensor at multiples of 24 ms (3HAC073318 rev. K,
#: EGMActMove: "Valid values: 24, 48, 72"); 48 as the manual's examples.
SAMPLE_RATE_MS = 48
#: `EGMSetupUC`'s `\\CommTimeout` [s]: no answer from the PC for this long raises `ERR_UDPUC_COMM`.
COMM_TIMEOUT_S = 1
#: External Motion Interface Data level of a path correction (abb_motion_program_exec's `path_corr`).
PATH_CORRECTION_LEVEL = 2
#: The PC's address in the UDP device: a placeholder, to be set to the PC that runs `online --serve egm`.
PC_ADDRESS = "192.168.125.2"
#: What EGM path correction drops of the twin's correction (the program's header, the export's note).
ALONG_PATH_NOTE = ("EGM path correction applies only y and z of the path frame: the along-path part (x, the "
                   "direction of motion) of the twin's correction is not corrected")

EGM_ON = [
    f"    EGMReset {EGM_ID};",
    f"    EGMGetId {EGM_ID};",
    f'    EGMSetupUC ROB_1,{EGM_ID},"{PROFILE}","{DEVICE}"\\PathCorr\\APTR\\CommTimeout:={COMM_TIMEOUT_S};',
    f"    IF EGMGetState({EGM_ID}) <> EGM_STATE_CONNECTED THEN",
    '      TPWrite "EGM not set up: stopped at the approach point, tool out of the sheet";',
    f"      EGMReset {EGM_ID};",
    "      EXIT;",
    "    ENDIF",
    f"    EGMActMove {EGM_ID},tIsf.tframe\\SampleRate:={SAMPLE_RATE_MS};",
]
#: The entry procedure's ERROR handler: the PC went silent (`ERR_UDPUC_COMM`) during a corrected move: stop, drop
#: the rest of the path, end the EGM session, lift the tool out of the sheet (uncorrected), then end.
ERROR_HANDLER = [
    "  ERROR",
    "    IF ERRNO = ERR_UDPUC_COMM THEN",
    "      StopMove;",
    "      ClearPath;",
    "      StartMove;",
    f"      EGMReset {EGM_ID};",
    "      MoveL Offs(CRobT(\\Tool:=tIsf\\WObj:=wSheet),0,0,nLift),vRetract,fine,tIsf\\WObj:=wSheet;",
    '      TPWrite "EGM link lost: path stopped, tool lifted out of the sheet";',
    "      EXIT;",
    "    ENDIF",
    "    RAISE;",
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

      -name "{profile}" -ext_motion_level {level} -do_not_restart_after_motors_off
"""


def sio_config(host: str = PC_ADDRESS, port: int = DEFAULT_PORT) -> str:
    """The UDP unicast device `UCdevice`: the controller streams to `host`:`port` and takes the answers."""
    return SIO.format(device=DEVICE, host=host, port=port)


def moc_config() -> str:
    """The External Motion Interface Data profile `pathCorr` (path correction; no filter set: module docstring)."""
    return MOC.format(profile=PROFILE, level=PATH_CORRECTION_LEVEL)


def _contact(path: ProgramPath) -> ProgramPath:
    """The path's own points, approach and retract left out: what EGM corrects."""
    configs = path.configurations[1:-1]
    return replace(path, points_mm=path.points_mm[1:-1], feed_mm_s=path.feed_mm_s[1:-1], configurations=configs,
                   cell=replace(path.cell, configuration=configs[0] if configs else None), joint_start=False)


def end_data(path: ProgramPath) -> list[str]:
    """The approach and retract points, the retract's speed and `nLift`, the lift out of the sheet after a lost link
    (main module data): the retract's height above the deepest corrected point [mm]."""
    ends = replace(path, points_mm=path.points_mm[[0, -1]], feed_mm_s=path.feed_mm_s[[0, -1]],
                   configurations=path.configurations[:1] + path.configurations[-1:])
    approach, retract = rapid.robtargets(ends)
    lift = float(path.points_mm[-1, 2] - np.min(path.points_mm[1:-1, 2]))
    return [f"  CONST robtarget pApproach:={approach};", f"  CONST robtarget pRetract:={retract};",
            f"  CONST speeddata vRetract:={rapid.speeddata(float(path.feed_mm_s[-1]))};",
            f"  CONST num nLift:={fmt(max(lift, 0.0), 4)};"]


def _corrected(stop: np.ndarray) -> list[str]:
    """The corrected moves through `pPath{1..nPath}`: `fine` where `stop` (the offline program's corners), `z0`
    between."""
    return rapid.moves(0, len(stop), stop, move=f"EGMMoveL {EGM_ID},", zone="z0")


def _main(path: ProgramPath, body: list[str], data: list[str], note: list[str]) -> str:
    """The main module: header, tool, work object, the EGM identity, data, and `isf_NAME` with EGM around `body`."""
    lines = [
        f"MODULE {path.name}", *rapid.about(path), *rapid.how_to_call(path), *note,
        f"  ! EGM path correction in the path's moves (tx200-twin online --serve egm, UDP port {DEFAULT_PORT}): "
        f"device {DEVICE} in {path.name}_egm_sio.cfg, profile {PROFILE} in {path.name}_egm_moc.cfg",
        f"  ! {ALONG_PATH_NOTE}",
        f"  ! sensor read every {SAMPLE_RATE_MS} ms; no answer for {COMM_TIMEOUT_S} s: ERR_UDPUC_COMM, the ERROR "
        "handler stops, lifts the tool nLift mm out of the sheet and ends",
        *rapid.declarations(path), f"  VAR egmident {EGM_ID};", *end_data(path), *data, "",
        f"  PROC {rapid.entry(path.name)}()", "    ConfJ \\On;", "    ConfL \\Off;", rapid.home_move(),
        f"    MoveJ pApproach,{rapid.APPROACH_SPEED},fine,tIsf\\WObj:=wSheet;",
        *EGM_ON, *body, *EGM_OFF,
        "    MoveL pRetract,vRetract,fine,tIsf\\WObj:=wSheet;",
        rapid.home_move(), *ERROR_HANDLER, "  ENDPROC", "ENDMODULE",
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
    stop = corners(path.points_mm)[1:-1]
    stop[-1] = True  # the corrected path ends at rest
    pieces = parts(contact, "rapid")
    if len(pieces) == 1:
        files = {f"{path.name}.mod": _main(path, _corrected(stop), rapid.path_data(contact, ""), [])}
    else:
        calls = [f"    {rapid.entry(piece.name)};" for piece in pieces]
        files = {f"{path.name}.mod": _main(path, calls, [], [f"  ! {len(pieces)} parts, in order"])}
        start = 0
        for piece in pieces:
            n = len(piece.points_mm)
            body = [*rapid.path_data(piece, "LOCAL "), "", f"  PROC {rapid.entry(piece.name)}()",
                    *_corrected(stop[start:start + n]), "  ENDPROC"]
            files[f"{piece.name}.mod"] = "\n".join([f"MODULE {piece.name}", *body, "ENDMODULE"]) + "\n"
            start += n
    files[f"{path.name}_egm_sio.cfg"] = sio_config()
    files[f"{path.name}_egm_moc.cfg"] = moc_config()
    return rapid.with_program_file(path, files)


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write the module `NAME.mod` (named as `rapid.write` names it), any parts, `NAME.pgf` and the two
    configurations in `out`'s folder, atomically (never over an input)."""
    return [write_text(Path(out).with_name(name), text, protect=protect) for name, text in program_files(path).items()]
