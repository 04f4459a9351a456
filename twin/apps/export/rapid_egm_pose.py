"""ABB RAPID with EGM position guidance: the PC streams the whole path, every axis, every 4 ms, with the twin's
correction added; the program, its two controller configurations and the guidance table that
`tx200-twin online --serve egm --guidance NAME_egm_pose.csv` streams.

Why position guidance is `export --online`'s default for ABB: EGM path correction (`rapid_egm`) takes y and z of
its path frame only, every 48 ms at best; measured on the twin's plant (docs/online.md, "Path correction or
position guidance") the dropped along-path part gives back 67 % of the groove's correction (0.30 mm with every
axis at 4 ms, 1.24 mm with path correction). Guidance (`EGMActPose`/`EGMRunPose`, "\\SampleRate ... multiples of
4 milliseconds", every axis) keeps it; the price is that the PC, not the program, owns the path while EGM runs.
`--egm-mode path` (or `--format rapid-egm`) keeps path correction.

The program (`twin.apps.export.rapid`'s tool `tIsf`, work object `wSheet` and home; no controller slot is
written):

- `MoveAbsJ jHome`, then `MoveJ pApproach,...,fine` (EGMRunPose "has to" start "at a fine point", after a move);
- `EGMReset egmID; EGMGetId egmID;`, `EGMSetupUC ROB_1,egmID,"poseGuide","UCdevice"\\Pose\\CommTimeout:=1;`,
  an `EGMGetState(egmID) <> EGM_STATE_CONNECTED` check that ends the program at the approach point;
- `EGMActPose egmID\\Tool:=tIsf\\WObj:=wSheet,pose0,EGM_FRAME_WOBJ,pose0,EGM_FRAME_WOBJ\\x:=egmLin ...\\rz:=egmRot
  \\SampleRate:=4\\MaxSpeedDeviation:=1000;`: the correction frame and the sensor frame are the work object, so
  the PC's pose is the tool tip's in the sheet frame, as the path's robtargets are; `egm_minmax` limits
  `CONVERGENCE_MM` / `CONVERGENCE_DEG` (the manual's EGMActPose example); `\\MaxSpeedDeviation` as
  abb_motion_program_exec's example (the manual's default, 1 deg/s, would hold the path back);
- `EGMRunPose egmID,EGM_STOP_HOLD\\x\\y\\z\\Rx\\Ry\\Rz\\CondTime:=2\\RampInTime:=0.05;` (the manual's UdpUc
  example's values): it returns when the robot has been within the limits of the PC's pose for `COND_TIME_S`, which
  happens once the PC holds the path's last point; then `EGMStop egmID,EGM_STOP_HOLD;`;
- a check of where guidance ended (`Distance(CPos(\\Tool:=tIsf\\WObj:=wSheet),pEnd.trans) > nEndTol`, the
  correction's limit, `export --max-correction-mm`, plus 1 mm): away
  from `pEnd` (the path's last point) the program says so and lifts `nLift` straight up first; then the retract `MoveL pRetract` and `MoveAbsJ jHome`;
- the same ERROR handler as `rapid_egm` (ERR_UDPUC_COMM: "In synchronous mode ... always a recoverable error"):
  stop, `EGMReset`, lift `nLift` mm along the sheet's z out of the sheet, `EXIT`.

The path is not in the module: `NAME_egm_pose.csv` (columns `GUIDANCE_COLUMNS`) holds the approach point and the
path's points in the sheet frame [mm], the tool's orientation (the robtargets' quaternion, w x y z) and the time
each is reached at the programmed feeds (`vPath` of the other exports: length over feed, from the approach). The
server starts that clock at the robot's first valid message and reads it from the messages' stamps.

`NAME_egm_sio.cfg` is `rapid_egm`'s UDP device; `NAME_egm_moc.cfg` the profile `poseGuide` at level 1
("Filtering", the controller's default; level 0 "raw" needs a low-pass the twin does not claim).

Followed (public sources; syntax checked against them, no text copied):
- ABB application manual 3HAC073318 rev. K (copy in FLo-ABB/ABB-EGM-Python `doc/`): EGMSetupUC `\\Pose`,
  `\\CommTimeout`; EGMActPose's arguments, `\\x`..`\\rz` convergence (defaults +-1 mm, +-0.5 deg; example
  [-0.1,0.1]), `\\SampleRate` "4, 8, 12, 16, etc.", `\\MaxSpeedDeviation` default 1.0; EGMRunPose `Mode`, switches,
  `\\CondTime` ("default 1 s"), `\\RampInTime`, its limitations (fine start point) and ERR_UDPUC_COMM; the
  UdpUc example (section 5.4.2: `EGMGetState`, `\\CondTime:=2 \\RampInTime:=0.05`); level 0/1/2 (section 4.1.3);
- rpiRobotics/abb_motion_program_exec `robot/HOME/motion_program_exec_egm.mod` (`EGMSetupUC ... "pose","UCdevice"
  \\Pose\\CommTimeout:=`, `EGMActPose ...\\Tool:=\\WObj:=...,\\X:=...\\MaxSpeedDeviation:=`, `EGMRunPose
  egmID1,EGM_STOP_HOLD,...\\x\\y\\z\\Rx\\Ry\\Rz\\CondTime:=\\RampInTime:=`, `EGMStop`), `robot/config_params_egm/
  MOC.cfg` (the "pose" profile) and `docs/egm.md` (EGM_FRAME_WOBJ frames with an identity pose, 1000 for both
  deviations);
- FLo-ABB/ABB-EGM-Python `examples/simple/guidance/example_pose_guidance.py` (`CONST pose pose0:=[[0,0,0],[1,0,0,0]]`,
  `CONST egm_minmax ...:=[-1E-9,+1E-9]`, `EGMActPose ... pose0,EGM_FRAME_WOBJ,pose0,EGM_FRAME_WOBJ`, a fine point
  before guidance);
- RoboDK's ABB driver module as found in public code (`RDK_MonitorMove`: `Distance(CPos(\\Tool:=...,\\WObj:=...),
  target.trans)`; its repository could not be named from the search index) for the end check's functions.
Not checked without a controller: that the robot's tracking lag at the path's feeds stays outside the convergence
limits (else EGMRunPose ends early: the end check above catches it, the part is then unfinished), how the
controller shapes the path's corners (the PC streams them at the programmed feed, without the `fine` stops of the
other exports), that `EGMStop` after a finished EGMRunPose is harmless, and the profile's defaults.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

import twin.apps.export.rapid as rapid
import twin.apps.export.rapid_egm as path_corr
from twin.apps.export.program import ProgramPath, fmt, quaternion_wxyz
from twin.base.csvio import write_text
from twin.errors import InputError

PROFILE = "poseGuide"
#: `EGMActPose`'s sample rate [ms]: "multiples of 4 milliseconds"; 4, the fastest.
SAMPLE_RATE_MS = 4
#: The convergence limits, +- [mm] and +- [deg] (the manual's EGMActPose example's linear limit).
CONVERGENCE_MM = 0.1
CONVERGENCE_DEG = 0.1
#: How long the robot must stay within them before `EGMRunPose` returns [s] (the manual's UdpUc example).
COND_TIME_S = 2
RAMP_IN_S = 0.05
#: `\\MaxSpeedDeviation` [deg/s] (abb_motion_program_exec's example; the manual's default is 1).
MAX_SPEED_DEVIATION_DEG_S = 1000
#: External Motion Interface Data level: 1, "Filtering" (the controller's default).
GUIDANCE_LEVEL = 1
#: Where guidance may end away from the path's last point before the program says so and lifts first, beyond the
#: correction's limit [mm]: the PC holds the last point plus the correction, at most the compensator's
#: `max_correction_mm` (the program's `ProgramPath.max_correction_mm`), 1 mm beyond it.
END_MARGIN_MM = 1.0
#: The guidance table's columns: time at the programmed feeds [s], point [mm] and orientation (w x y z), sheet frame.
GUIDANCE_COLUMNS = ("t_s", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz")
#: `--egm-mode` -> export format; the default (module docstring).
MODES = {"pose": "rapid-egm-pose", "path": "rapid-egm"}
DEFAULT_MODE = "pose"
NOTE = ("EGM position guidance: the PC streams the path (every axis, every 4 ms) with the correction; serve it "
        "with `tx200-twin online --serve egm --guidance {table}`")

EGM_ID = path_corr.EGM_ID
EGM_ON = [
    f"    EGMReset {EGM_ID};",
    f"    EGMGetId {EGM_ID};",
    f'    EGMSetupUC ROB_1,{EGM_ID},"{PROFILE}","{path_corr.DEVICE}"\\Pose\\CommTimeout:={path_corr.COMM_TIMEOUT_S};',
    *path_corr.EGM_ON[3:8],  # the EGMGetState check: stop at the approach point when the set-up failed
    f"    EGMActPose {EGM_ID}\\Tool:=tIsf\\WObj:=wSheet,pose0,EGM_FRAME_WOBJ,pose0,EGM_FRAME_WOBJ"
    "\\x:=egmLin\\y:=egmLin\\z:=egmLin\\rx:=egmRot\\ry:=egmRot\\rz:=egmRot"
    f"\\SampleRate:={SAMPLE_RATE_MS}\\MaxSpeedDeviation:={MAX_SPEED_DEVIATION_DEG_S};",
    f"    EGMRunPose {EGM_ID},EGM_STOP_HOLD\\x\\y\\z\\Rx\\Ry\\Rz\\CondTime:={COND_TIME_S}\\RampInTime:={RAMP_IN_S};",
    f"    EGMStop {EGM_ID},EGM_STOP_HOLD;",
    "    IF Distance(CPos(\\Tool:=tIsf\\WObj:=wSheet),pEnd.trans) > nEndTol THEN",
    '      TPWrite "EGM guidance ended away from the path end: tool lifted out of the sheet";',
    "      MoveL Offs(CRobT(\\Tool:=tIsf\\WObj:=wSheet),0,0,nLift),vRetract,fine,tIsf\\WObj:=wSheet;",
    "    ENDIF",
]


def egm_format(fmt_name: str, mode: str | None, chosen: bool) -> str:
    """The export format for `--egm-mode` (`MODES`): `fmt_name` as resolved (`chosen`: typed as `--format`).

    Raises:
        InputError: An unknown mode, a mode for a format that is not ABB EGM, or one that contradicts `--format`.
    """
    if mode is not None and mode not in MODES:
        raise InputError(f"--egm-mode {mode!r}: expected one of {', '.join(MODES)}")
    if fmt_name not in MODES.values():
        if mode is not None:
            raise InputError(f"--egm-mode {mode} with format {fmt_name}: --egm-mode chooses ABB's EGM program "
                             f"({' or '.join(MODES.values())}); expected --online for an ABB robot")
        return fmt_name
    if chosen:
        if mode is not None and MODES[mode] != fmt_name:
            raise InputError(f"--egm-mode {mode} contradicts --format {fmt_name}; expected one of them")
        return fmt_name
    return MODES[mode or DEFAULT_MODE]


def moc_config() -> str:
    """The External Motion Interface Data profile `poseGuide` (level 1; no filter or gain set)."""
    return path_corr.MOC.format(profile=PROFILE, level=GUIDANCE_LEVEL)


def guidance_table(path: ProgramPath) -> tuple[np.ndarray, np.ndarray]:
    """The approach point and the path's points (retract left out), shape (n, 3) [mm], and the time each is reached
    from the approach at the programmed feeds [s]: the move into point k takes its length over `feed_mm_s[k]`."""
    points = path.points_mm[:-1]
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1) / path.feed_mm_s[1:-1]
    return points, np.concatenate([[0.0], np.cumsum(steps)])


def table_text(path: ProgramPath) -> str:
    """`NAME_egm_pose.csv`: a comment line, `GUIDANCE_COLUMNS`, one row per point."""
    points, t = guidance_table(path)
    q = ",".join(fmt(v, rapid.QUATERNION_DECIMALS) for v in quaternion_wxyz(path.cell.R_sheet_tool))
    rows = [f"{fmt(ti, 6)},{','.join(fmt(v, 4) for v in p)},{q}" for ti, p in zip(t, points, strict=True)]
    return "\n".join([f"# {path.name}: EGM position guidance, sheet frame (tx200-twin online --serve egm "
                      "--guidance)", ",".join(GUIDANCE_COLUMNS), *rows]) + "\n"


def _main(path: ProgramPath) -> str:
    """The module: header, tool, work object, the EGM data, and `isf_NAME` with guidance between approach and
    retract."""
    table = f"{path.name}_egm_pose.csv"
    end = rapid.robtargets(path)[-2]
    lines = [
        f"MODULE {path.name}", *rapid.about(path), *rapid.how_to_call(path),
        f"  ! EGM position guidance (tx200-twin online --serve egm --guidance {table}, UDP port "
        f"{path_corr.DEFAULT_PORT}): device {path_corr.DEVICE} in {path.name}_egm_sio.cfg, profile {PROFILE} in "
        f"{path.name}_egm_moc.cfg",
        f"  ! the PC streams the path ({len(path.points_mm) - 2} points, {table}) and the correction on every axis "
        f"every {SAMPLE_RATE_MS} ms; no answer for {path_corr.COMM_TIMEOUT_S} s: ERR_UDPUC_COMM, the ERROR handler "
        "stops, lifts the tool nLift mm out of the sheet and ends",
        *rapid.declarations(path), f"  VAR egmident {EGM_ID};",
        "  CONST pose pose0:=[[0,0,0],[1,0,0,0]];",
        f"  CONST egm_minmax egmLin:=[{-CONVERGENCE_MM:g},{CONVERGENCE_MM:g}];",
        f"  CONST egm_minmax egmRot:=[{-CONVERGENCE_DEG:g},{CONVERGENCE_DEG:g}];",
        *path_corr.end_data(path), f"  CONST robtarget pEnd:={end};",
        f"  CONST num nEndTol:={path.max_correction_mm + END_MARGIN_MM:g};", "",
        f"  PROC {rapid.entry(path.name)}()", "    ConfJ \\On;", "    ConfL \\Off;", rapid.home_move(),
        f"    MoveJ pApproach,{rapid.APPROACH_SPEED},fine,tIsf\\WObj:=wSheet;",
        *EGM_ON,
        "    MoveL pRetract,vRetract,fine,tIsf\\WObj:=wSheet;",
        rapid.home_move(), *path_corr.ERROR_HANDLER, "  ENDPROC", "ENDMODULE",
    ]
    return "\n".join(lines) + "\n"


def program_files(path: ProgramPath) -> dict[str, str]:
    """The module `NAME.mod` with EGM position guidance, its two configurations, the guidance table and `NAME.pgf`.

    Raises:
        InputError: A path without its approach and retract (`motion.with_moves`), or a feed not > 0.
    """
    if not path.approach or len(path.points_mm) < 3:
        raise InputError(f"program {path.name!r} ({len(path.points_mm)} points, approach={path.approach}): "
                         "rapid-egm-pose expects a program with its approach and retract around at least one path "
                         "point (export_path adds them)")
    if not np.all(path.feed_mm_s[1:-1] > 0):
        raise InputError(f"program {path.name!r}: a feed <= 0 mm/s; guidance needs every path move's feed > 0")
    files = {f"{path.name}.mod": _main(path), f"{path.name}_egm_sio.cfg": path_corr.sio_config(),
             f"{path.name}_egm_moc.cfg": moc_config(), f"{path.name}_egm_pose.csv": table_text(path)}
    return rapid.with_program_file(path, files)


def write(path: ProgramPath, out: Path, protect: Sequence[Path] = ()) -> list[Path]:
    """Write `NAME.mod`, `NAME.pgf`, the two configurations and the guidance table in `out`'s folder, atomically
    (never over an input)."""
    return [write_text(Path(out).with_name(name), text, protect=protect) for name, text in program_files(path).items()]
