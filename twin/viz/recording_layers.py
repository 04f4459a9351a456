"""The layers of one replayed run in a rerun recording: robot, paths, deflection, forces, groove, plots.

Everything 3-D is in the robot base (world) frame in metres: sheet-frame points placed by the sheet's origin
`p_base_sheet_origin` and yaw (`R_base_sheet`).
Per recording (entity prefix `<name>/` when several runs share a file):

- `world/robot/<body>/<geom>`: the visual geoms (group != 3, no planes) of every body as static meshes in the
  body frame; `world/robot/<body>` carries the body pose from `mj_kinematics` at the replay's equilibrium
  qpos on the `sim_time` timeline, decimated to `POSE_RATE_HZ` (static for bodies welded to the world).
- `world/paths/{ideal,commanded,measured,simulated}`: line strips of the tool tip.
- `world/tool_tip/{measured,simulated}`: the tip as a moving point.
- `world/deflection_x20/{simulated,measured}`: deflection arrows magnified `DEFLECTION_MAGNIFICATION` times,
  coloured by size (simulated: loaded - unloaded at the unloaded tip; measured: tracker - commanded).
- `world/force_1mm_per_20N/{simulated,measured}`: force of the sheet on the tool at the tool tip.
- `world/groove/{formed_loaded,part_profile}`: the formed groove centre line at the end of the run.
- `plots/{deflection_{x,y,z}_mm,force_{x,y,z}_n}/{measured,predicted,...}`: scalar series, every axis.
- `README`: a markdown note with the scales and the replay metrics.

The recording around them (file, blueprint, several runs): `twin.viz.recording`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import matplotlib
import mujoco
import numpy as np
import rerun as rr

from twin.base.signals import interp_rows
from twin.errors import InputError
from twin.viz.recording_robot import TIMELINE, log_body_poses, log_robot_geometry

if TYPE_CHECKING:
    from twin.analysis.replay import ReplayResult
    from twin.runs.format import Run
    from twin.sim.result import SimResult

DEFLECTION_MAGNIFICATION = 20.0  # deflection arrows are drawn 20 times their size
FORCE_ARROW_M_PER_N = 1e-3 / 20.0  # force arrows: 1 mm per 20 N
POSE_RATE_HZ = 10.0  # robot poses, arrows and moving points are logged at about this rate

M_TO_MM = 1e3
LINE_RADIUS = rr.Radius.ui_points(1.5)
COLORS = {
    "ideal": (230, 230, 230),
    "commanded": (255, 150, 30),
    "measured": (40, 140, 255),
    "simulated": (60, 200, 90),
    "predicted": (60, 200, 90),
    "simulated_sheet": (200, 80, 200),
}


def checked_points(name: str, values: object, n: int | None = None) -> np.ndarray:
    """`values` as a finite float array of shape (n, 3) (any n when `n` is None); InputError naming `name`."""
    array = np.asarray(values, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3 or (n is not None and array.shape[0] != n):
        want = f"({n if n is not None else 'n'}, 3)"
        raise InputError(f"{name} has shape {array.shape}, expected {want}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} holds NaN or inf; expected finite values")
    return array


def decimate(t_s: np.ndarray, rate_hz: float = POSE_RATE_HZ) -> np.ndarray:
    """Indices of the first sample in each 1/rate_hz bin of time, plus the last sample.

    Args:
        t_s: Increasing sample times [s], shape (n,).
        rate_hz: Target rate [Hz], > 0.

    Returns:
        Sorted sample indices, shape (m,), m <= n.
    """
    if rate_hz <= 0:
        raise InputError(f"rate_hz = {rate_hz!r}, expected > 0")
    t = np.asarray(t_s, dtype=float)
    if t.size == 0:
        return np.zeros(0, dtype=int)
    bins = np.floor((t - t[0]) * rate_hz + 1e-9).astype(int)
    idx = np.flatnonzero(np.diff(bins, prepend=bins[0] - 1) != 0)
    return np.unique(np.append(idx, t.size - 1))


def _colors_by_size(size: np.ndarray) -> np.ndarray:
    top = float(np.max(size)) if size.size and np.max(size) > 0 else 1.0
    return (matplotlib.colormaps["plasma"](size / top) * 255).astype(np.uint8)


def _arrows(
    rec: rr.RecordingStream,
    entity: str,
    t_s: np.ndarray,
    origins: np.ndarray,
    vectors: np.ndarray,
    colors: np.ndarray | None = None,
) -> None:
    if colors is None:
        colors = _colors_by_size(np.linalg.norm(vectors, axis=1))
    rec.send_columns(
        entity,
        indexes=[rr.TimeColumn(TIMELINE, duration=t_s)],
        columns=rr.Arrows3D.columns(origins=origins, vectors=vectors, colors=colors),
    )


def _series(
    rec: rr.RecordingStream,
    entity: str,
    t_s: np.ndarray,
    values: np.ndarray,
    label: str,
    color: tuple[int, int, int],
) -> None:
    rec.log(entity, rr.SeriesLines(colors=[color], names=[label], widths=[1.5]), static=True)
    rec.send_columns(
        entity, indexes=[rr.TimeColumn(TIMELINE, duration=t_s)], columns=rr.Scalars.columns(scalars=values)
    )


def _readme(run: Run, replay: ReplayResult, origin: np.ndarray) -> str:
    lines = [
        f"# {run.scenario or 'run'}: replay on the twin",
        "",
        "All 3-D entities are in the robot base frame [m]; the sheet frame origin is at "
        f"({', '.join(f'{v:.4f}' for v in origin)}) m.",
        f"- `deflection_x20`: deflection arrows magnified {DEFLECTION_MAGNIFICATION:g}x, coloured by size.",
        f"- `force_1mm_per_20N`: force of the sheet on the tool, "
        f"{FORCE_ARROW_M_PER_N * 1e3 * 20:g} mm per 20 N.",
        "- `plots/*`: deflection (tool tip minus commanded) [mm] and forces [N], measured vs predicted.",
        "",
        "| metric | value |",
        "|---|---|",
        *(f"| {key} | {value:.4g} |" for key, value in sorted(replay.metrics.items())),
    ]
    return "\n".join(lines)


class _SheetInBase(NamedTuple):
    """Pose of the sheet frame in the robot base frame: p_base = R_base_sheet · p_sheet + origin."""

    R_base_sheet: np.ndarray  # (3, 3)
    p_base_sheet_origin_m: np.ndarray  # (3,) [m]

    def points(self, p_sheet_m: np.ndarray) -> np.ndarray:
        """Sheet-frame points [m], shape (n, 3), in the base frame [m]."""
        return p_sheet_m @ self.R_base_sheet.T + self.p_base_sheet_origin_m


class _ReplayStreams(NamedTuple):
    """The checked samples the layers draw, sheet frame [s, m, N], and the samples of the moving layers."""

    t_sim_s: np.ndarray  # twin sample times, (n,)
    p_sim_sheet_m: np.ndarray  # loaded tool tip on the twin, (n, 3)
    p_unloaded_sheet_m: np.ndarray  # unloaded tool tip on the twin, (n, 3)
    f_sim_sheet_n: np.ndarray  # force of the sheet on the tool on the twin, (n, 3)
    t_trk_s: np.ndarray  # tracker sample times, (m,)
    p_trk_sheet_m: np.ndarray  # measured tool tip, (m, 3)
    p_pred_sheet_m: np.ndarray  # predicted tool tip at the tracker times, (m, 3)
    p_cmd_at_trk_sheet_m: np.ndarray  # commanded tool tip at the tracker times, (m, 3)
    i_sim: np.ndarray  # twin samples drawn, about POSE_RATE_HZ
    i_trk: np.ndarray  # tracker samples drawn, about POSE_RATE_HZ


def _checked_streams(run: Run, replay: ReplayResult) -> _ReplayStreams:
    """The replay's samples, checked against its own length and the run's tracker (InputError naming one)."""
    sim = replay.sim
    t_sim_s = np.asarray(sim.t_s, dtype=float)
    t_trk_s = run.tracker.t_s
    return _ReplayStreams(
        t_sim_s,
        checked_points("sim.p_sheet_m", sim.p_sheet_m, len(t_sim_s)),
        checked_points("sim.p_unloaded_sheet_m", sim.p_unloaded_sheet_m, len(t_sim_s)),
        checked_points("sim.f_sheet_n", sim.f_sheet_n, len(t_sim_s)),
        t_trk_s,
        run.tracker.values,
        checked_points("replay.tracker_pred_m", replay.tracker_pred_m, len(t_trk_s)),
        interp_rows(t_trk_s, run.commanded.t_s, run.commanded.values),
        decimate(t_sim_s),
        decimate(t_trk_s),
    )


def _log_scene(
    rec: rr.RecordingStream, prefix: str, run: Run, replay: ReplayResult, model: mujoco.MjModel,
    p_base_sheet_origin_m: np.ndarray, streams: _ReplayStreams,
) -> None:
    """Log the view axes, the README note, the robot's geometry and its body poses at the drawn samples."""
    rec.log(f"{prefix}world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    readme = _readme(run, replay, p_base_sheet_origin_m)
    rec.log(f"{prefix}README", rr.TextDocument(readme, media_type=rr.MediaType.MARKDOWN), static=True)
    log_robot_geometry(rec, model, prefix)
    i_sim = streams.i_sim
    log_body_poses(rec, model, streams.t_sim_s[i_sim], np.asarray(replay.sim.qpos)[i_sim], prefix)


def _log_paths(
    rec: rr.RecordingStream, world: str, p_cmd_sheet_m: np.ndarray, streams: _ReplayStreams,
    ideal_sheet_m: np.ndarray | None, sheet: _SheetInBase,
) -> None:
    """Log the ideal (when given), commanded, measured and simulated tool-tip paths as static strips [m]."""
    strips = {
        "commanded": p_cmd_sheet_m, "measured": streams.p_trk_sheet_m, "simulated": streams.p_sim_sheet_m
    }
    if ideal_sheet_m is not None:
        strips = {"ideal": checked_points("ideal_sheet_m", ideal_sheet_m), **strips}
    for name, points in strips.items():
        strip = rr.LineStrips3D([sheet.points(points)], radii=LINE_RADIUS, colors=[COLORS[name]])
        rec.log(f"{world}/paths/{name}", strip, static=True)


def _log_tool_tips(rec: rr.RecordingStream, world: str, streams: _ReplayStreams, sheet: _SheetInBase) -> None:
    """Log the measured and simulated tool tip as moving points at the drawn samples [m, s]."""
    i_sim, i_trk = streams.i_sim, streams.i_trk
    for name, t_pts, pts in (
        ("measured", streams.t_trk_s[i_trk], streams.p_trk_sheet_m[i_trk]),
        ("simulated", streams.t_sim_s[i_sim], streams.p_sim_sheet_m[i_sim]),
    ):
        rec.send_columns(
            f"{world}/tool_tip/{name}",
            indexes=[rr.TimeColumn(TIMELINE, duration=t_pts)],
            columns=rr.Points3D.columns(
                positions=sheet.points(pts),
                colors=np.tile(COLORS[name], (len(pts), 1)),
                radii=np.full(len(pts), 0.002),
            ),
        )


def _log_arrows(
    rec: rr.RecordingStream, world: str, run: Run, streams: _ReplayStreams, sheet: _SheetInBase
) -> None:
    """Log the magnified deflection arrows and the force arrows at the tool tip, drawn samples [m, N, s]."""
    s = streams
    arrows = f"{world}/deflection_x{DEFLECTION_MAGNIFICATION:g}"
    forces = f"{world}/force_1mm_per_20N"
    d_sim = DEFLECTION_MAGNIFICATION * (s.p_sim_sheet_m - s.p_unloaded_sheet_m)
    d_trk = DEFLECTION_MAGNIFICATION * (s.p_trk_sheet_m - s.p_cmd_at_trk_sheet_m)
    arrow_sets = [  # entity, times, tails [m], vectors [m], fixed colour (None: coloured by size)
        (f"{arrows}/simulated", s.i_sim, s.t_sim_s, s.p_unloaded_sheet_m, d_sim, None),
        (f"{arrows}/measured", s.i_trk, s.t_trk_s, s.p_cmd_at_trk_sheet_m, d_trk, None),
        (f"{forces}/simulated", s.i_sim, s.t_sim_s, s.p_sim_sheet_m, FORCE_ARROW_M_PER_N * s.f_sim_sheet_n,
         COLORS["simulated"]),
    ]
    if run.forces is not None:
        tip = interp_rows(run.forces.t_s, s.t_trk_s, s.p_trk_sheet_m)
        i_f = decimate(run.forces.t_s)
        f_meas = FORCE_ARROW_M_PER_N * run.forces.values
        arrow_sets.append((f"{forces}/measured", i_f, run.forces.t_s, tip, f_meas, COLORS["measured"]))
    for entity, keep, t_s, tails, vecs, color in arrow_sets:
        colors = None if color is None else np.tile(color, (len(keep), 1))
        _arrows(rec, entity, t_s[keep], sheet.points(tails[keep]), vecs[keep] @ sheet.R_base_sheet.T, colors)


def _log_groove(
    rec: rr.RecordingStream, world: str, run: Run, sim: SimResult, t_end_s: float, sheet: _SheetInBase
) -> None:
    """Log the formed groove's centre line (and the run's part profile) at the end of the run [m, s]."""
    formed_x = np.asarray(sim.formed_x_m, dtype=float)
    formed = np.column_stack([formed_x, np.zeros_like(formed_x), np.asarray(sim.formed_z_m, dtype=float)])
    profiles = {"formed_loaded": formed}
    if run.part_profile is not None:
        x_m, z_m = (np.asarray(a, dtype=float) for a in run.part_profile)
        profiles["part_profile"] = np.column_stack([x_m, np.zeros_like(x_m), z_m])
    for name, profile in profiles.items():
        if len(profile) >= 2:
            rec.send_columns(
                f"{world}/groove/{name}",
                indexes=[rr.TimeColumn(TIMELINE, duration=[t_end_s])],
                columns=rr.LineStrips3D.columns(strips=[sheet.points(profile)]),
            )


def _log_plots(
    rec: rr.RecordingStream, plots: str, run: Run, forces_pred_n: np.ndarray | None, streams: _ReplayStreams
) -> None:
    """Log the x, y and z series of deflection [mm] and force [N], measured against predicted, on `sim_time`."""
    s = streams
    d_meas_mm = M_TO_MM * (s.p_trk_sheet_m - s.p_cmd_at_trk_sheet_m)
    d_pred_mm = M_TO_MM * (s.p_pred_sheet_m - s.p_cmd_at_trk_sheet_m)
    series = [  # entity under plots/, times [s], values (n, 3), label, colour
        ("deflection_{}_mm/measured", s.t_trk_s, d_meas_mm, "measured", COLORS["measured"]),
        ("deflection_{}_mm/predicted", s.t_trk_s, d_pred_mm, "predicted", COLORS["predicted"]),
        ("force_{}_n/simulated_sheet", s.t_sim_s, s.f_sim_sheet_n, "sheet force (twin)",
         COLORS["simulated_sheet"]),
    ]
    if run.forces is not None:
        t_f = run.forces.t_s
        series.append(("force_{}_n/measured", t_f, run.forces.values, "measured", COLORS["measured"]))
        if forces_pred_n is not None:
            f_pred = checked_points("replay.forces_pred_n", forces_pred_n, len(t_f))
            series.append(("force_{}_n/predicted", t_f, f_pred, "predicted", COLORS["predicted"]))
    for k, axis in enumerate("xyz"):
        for entity, t_s, values, label, color in series:
            _series(rec, f"{plots}/{entity.format(axis)}", t_s, values[:, k], label, color)


def log_replay(
    rec: rr.RecordingStream,
    prefix: str,
    run: Run,
    replay: ReplayResult,
    ideal_sheet_m: np.ndarray | None,
    model: mujoco.MjModel,
    origin: np.ndarray,
    R_base_sheet: np.ndarray | None = None,
) -> None:
    """Log every layer of one replayed run under `prefix` (see the module docstring) [m, N, s].

    Args:
        rec: The open recording.
        prefix: Entity prefix, `<name>/` or "".
        run: The measured run.
        replay: Its replay on the twin.
        ideal_sheet_m: Ideal tool-tip path, sheet frame [m], shape (k, 3), or None.
        model: The twin's compiled model (geometry and body poses).
        origin: Sheet origin in the base frame [m], shape (3,).
        R_base_sheet: Orientation of the sheet frame in the base (the placement's yaw); None: the base axes.
    """
    sheet = _SheetInBase(np.eye(3) if R_base_sheet is None else np.asarray(R_base_sheet, dtype=float), origin)
    streams = _checked_streams(run, replay)
    _log_scene(rec, prefix, run, replay, model, origin, streams)
    _log_paths(rec, f"{prefix}world", run.commanded.values, streams, ideal_sheet_m, sheet)
    _log_tool_tips(rec, f"{prefix}world", streams, sheet)
    _log_arrows(rec, f"{prefix}world", run, streams, sheet)
    _log_groove(rec, f"{prefix}world", run, replay.sim, float(streams.t_sim_s[-1]), sheet)
    _log_plots(rec, f"{prefix}plots", run, replay.forces_pred_n, streams)
