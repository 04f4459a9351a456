"""Step the dynamic plant along a commanded path against the sheet, and log the physical truth.

Each servo tick (one `mj_step`): the controller writes its set-point, integral and feed-forward into the
position servos; the sheet's force at the real tool tip (the process's force model,
`twin.process.force.registry`, fitted to the FE history, advanced along the real tool path) is applied at the tip
through `xfrc_applied` on the tool body (moment carried to its centre of mass); for a model whose in-plane force
flips with the commanded direction, that part follows the real travel of the tip, reversing linearly over
`friction_reversal_mm` of travel after a reversal (friction and ploughing need the tool to move into the new
direction); MuJoCo steps; the field commits the tip position. The log holds the
tool tip, the sheet force and MuJoCo's flange F/T sensor at every tick, for the sensor chain to sample.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import NamedTuple, TextIO

import mujoco
import numpy as np

from twin.errors import InputError
from twin.lab.dynamic.controller import (
    apply_gains,
    design_gains,
    gravity_torques,
    rest_state,
    servo_setpoints,
    setpoint_acceleration,
)
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.online import CycleCorrector, OnlineCycle, OnlineFt, OnlineLog
from twin.lab.dynamic.plant import Plant, build_plant, controller_model
from twin.lab.dynamic.sheet_laws import SheetLaw, make_sheet
from twin.process.description import Process
from twin.process.part.bottom import with_floating_bottom
from twin.process.part.surface import FORMED_BELOW_M
from twin.process.toolpath.groove import label_passes
from twin.process.toolpath.placement import Placement
from twin.robot.kinematics import Kinematics

PASS_DEADBAND_M = (
    2e-3  # back-travel that declares a reversal of the commanded path [m] (a stroke is >= 61 mm)
)
LOAD_RAMP_S = 0.5  # a load test's force rises linearly over this time, as a hand-applied load does [s]
SETTLE_S = 0.3  # the arm rests on the first set-point this long before t = 0 [s]


@dataclass(frozen=True)
class DynamicLog:
    """The physical truth of a dynamic run, at every servo tick.

    Attributes:
        t_s: Tick times [s], shape (m,).
        p_tip_sheet_m: Real tool tip, sheet frame [m], shape (m, 3).
        f_sheet_n: Force of the sheet on the tool, sheet frame [N], shape (m, 3).
        f_ft_local_n: The robot's MuJoCo F/T force sensor (sensor body on tool, F/T site frame) [N], shape (m, 3).
        R_world_ft: Orientation of the F/T site [-], shape (m, 3, 3).
        q_link: Link angles [rad], shape (m, dof).
        q_motor_error: Motor set-point minus motor angle [rad], shape (m, dof).
        formed_x_m: Grid of the sheet's formed profile [m], shape (g,).
        formed_z_m: Loaded, formed groove bottom at the end of the run [m], shape (g,).
        unloaded_z_m: The same section after unclamping (the plant's springback) [m], shape (g,).
        q_play: Where the teeth sit in the dead band, q_gear - dz(q_gear) [rad], shape (m, dof): +/- b/2 on a
            flank, in between while floating (0 for joints without a dead band).
        wall_s: Wall time of the stepping [s].
        formed_surface: (x_m, y_m, z_m grid) of the part after unclamping where the declared process is scanned
            in 3-D (any force model but the groove's `table`: the thesis's cell scanned only a profile), else
            None.
        R_world_sheet: Orientation of the sheet frame in the world (the placement's yaw) [-], shape (3, 3).
        online: What an online corrector did each cycle, or None.
    """

    t_s: np.ndarray
    p_tip_sheet_m: np.ndarray
    f_sheet_n: np.ndarray
    f_ft_local_n: np.ndarray
    R_world_ft: np.ndarray
    q_link: np.ndarray
    q_motor_error: np.ndarray
    q_play: np.ndarray
    formed_x_m: np.ndarray
    formed_z_m: np.ndarray
    unloaded_z_m: np.ndarray
    wall_s: float
    formed_surface: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    R_world_sheet: np.ndarray = field(default_factory=lambda: np.eye(3))
    online: OnlineLog | None = None


def simulate(
    t_cmd_s: np.ndarray,
    p_cmd_sheet_m: np.ndarray,
    knobs: Knobs,
    *,
    process: Process | None = None,
    plant: Plant | None = None,
    progress: TextIO | None = None,
    tip_force_n: np.ndarray | None = None,
    placement: Placement | None = None,
    corrector: CycleCorrector | None = None,
    online_seed: int = 0,
) -> DynamicLog:
    """Run the commanded tool-tip path on the dynamic plant.

    Args:
        t_cmd_s: Commanded times [s], shape (n,), from 0, increasing.
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], shape (n, 3).
        knobs: Plant and controller knobs.
        process: The sheet and tool the plant's own sheet model forms (`twin.lab.dynamic.sheet`); default the
            thesis's. Its force model and FE history are the twin's and are not used here.
        plant: A plant built for `knobs` (built when None, for the default robot).
        progress: Stream for a progress line every 10 % (None: quiet).
        tip_force_n: A force on the tool tip, world frame [N], instead of the sheet (load tests); it rises
            linearly over `LOAD_RAMP_S` from t = 0.
        placement: Where the sheet lies in the cell (origin, yaw); None: the cell's `sheet_origin`, yaw 0.
        corrector: A corrector the controller calls every `cycle_s` with the F/T sensor's newest sample (the
            plant's own sensor chain, `OnlineFt`) and the motor angles; its Cartesian correction moves the joint
            set-points through the controller's rigid model, held until the next cycle. None: no correction.
        online_seed: Seed of the online F/T samples' noise.

    Returns:
        The log at every servo tick.
    """
    t_cmd = np.asarray(t_cmd_s, dtype=float)
    p_cmd = np.asarray(p_cmd_sheet_m, dtype=float)
    if p_cmd.ndim != 2 or p_cmd.shape != (len(t_cmd), 3) or len(t_cmd) < 2 or np.any(np.diff(t_cmd) <= 0):
        raise InputError(f"expected increasing t (n,) and p (n, 3), n >= 2; got {t_cmd.shape}, {p_cmd.shape}")
    plant = plant or build_plant(knobs)
    plan = _plan(plant, knobs, t_cmd, p_cmd, placement or Placement())
    process = process or Process()
    sheet = make_sheet(knobs, process)
    scanned = process.force_model != "table"
    online = None
    if corrector is not None:
        ft = OnlineFt(knobs, np.random.default_rng(online_seed), plant.tool_mass_kg, plan.R_ws,
                      plant.model.opt.timestep)
        online = (corrector, ft)
    return _step(plant, plan, sheet, scanned, _settled(plant, plan), tip_force_n, progress, online)


class _Plan(NamedTuple):
    """What the controller and the sheet need at every servo tick, computed before stepping."""

    t_tick: np.ndarray  # tick times [s]
    q_sp: np.ndarray  # motor set-points [rad], (ticks, dof)
    ctrl_ff: np.ndarray  # servo ctrl without the integral [rad], (ticks, dof)
    ki_over_kp: np.ndarray  # integral gain over kp [1/s], (dof,)
    passes: list[int]  # commanded pass at each tick
    dirs: list[int]  # commanded direction at each tick
    origin: np.ndarray  # sheet origin in the world [m]
    R_ws: np.ndarray  # the sheet's axes in the world
    rest_qpos: np.ndarray  # the unloaded arm at rest on the first set-point
    rest_ctrl: np.ndarray  # its servo ctrl (no velocity feed-forward) [rad]
    kin: Kinematics  # the controller's rigid model (an online correction's joint offsets)


def _plan(plant: Plant, knobs: Knobs, t_cmd: np.ndarray, p_cmd: np.ndarray, place: Placement) -> _Plan:
    """IK of the command, gravity, servo gains (written into the plant) and set-points at every tick."""
    rigid = controller_model(plant)
    kin = Kinematics(rigid, robot=plant.robot)
    origin = place.origin_in(kin)  # the scene's sheet site by default, as the plant's
    R_ws = place.R_base_sheet  # the sheet's axes in the world
    q_ik = kin.ik_path(origin + p_cmd @ R_ws.T)
    g_ik = gravity_torques(rigid, q_ik, plant.robot)
    gains = design_gains(plant, rigid, q_ik[0], knobs)
    apply_gains(plant, gains)
    dt = plant.model.opt.timestep
    n_tick = int(np.floor(t_cmd[-1] / dt + 1e-9)) + 1
    t_tick = dt * np.arange(n_tick)
    q_sp, dq_sp, g_ff = servo_setpoints(t_cmd, q_ik, g_ik, plant, knobs, t_tick)
    tau_ff = g_ff + gains.inertia * setpoint_acceleration(dq_sp, t_tick, knobs["trajectory_period_s"])
    pass_cmd, dir_cmd = label_passes(p_cmd[:, 0], deadband_m=PASS_DEADBAND_M)
    idx = np.minimum(np.searchsorted(t_cmd, t_tick, side="left"), len(t_cmd) - 1)
    return _Plan(
        t_tick, q_sp, q_sp + (gains.kv * dq_sp + tau_ff) / gains.kp, gains.ki / gains.kp,
        [int(v) for v in pass_cmd[idx]], [int(v) for v in dir_cmd[idx]], origin, R_ws,
        rest_state(plant, q_ik[0], g_ik[0]), q_sp[0] + g_ff[0] / gains.kp, kin,
    )


def _settled(plant: Plant, plan: _Plan) -> mujoco.MjData:
    """The plant's data after resting `SETTLE_S` on the first set-point."""
    m, d = plant.model, mujoco.MjData(plant.model)
    d.qpos[:] = plan.rest_qpos
    d.ctrl[:] = plan.rest_ctrl
    band = plant.dead_band_joints
    band_qpos, band_dof = plant.link_qpos[band], plant.link_dof[band]
    for _ in range(int(SETTLE_S / m.opt.timestep)):
        d.qfrc_applied[band_dof] = plant.gear_torques(d.qpos[band_qpos], band)
        mujoco.mj_step(m, d)
    return d


class _Logs(NamedTuple):
    """The per-tick logs of `_step` (module docstring of `DynamicLog`)."""

    p: np.ndarray
    f: np.ndarray
    ft: np.ndarray
    R: np.ndarray
    q: np.ndarray
    e: np.ndarray
    b: np.ndarray

    @classmethod
    def empty(cls, n_tick: int, dof: int) -> _Logs:
        three, joints = (n_tick, 3), (n_tick, dof)
        return cls(np.zeros(three), np.zeros(three), np.zeros(three), np.zeros((n_tick, 9)), np.zeros(joints),
                   np.zeros(joints), np.zeros(joints))


def _step(
    plant: Plant, plan: _Plan, sheet: SheetLaw, scanned: bool, d: mujoco.MjData, tip_force_n: np.ndarray | None,
    progress: TextIO | None,
    online: tuple[CycleCorrector, OnlineFt] | None = None,
) -> DynamicLog:
    """Step the plant through every tick against the sheet (or the load), and log what happened."""
    m, (t_tick, _, _, _, _, dirs, origin, R_ws, _, _, _) = plant.model, plan
    dt = m.opt.timestep
    band = plant.dead_band_joints
    band_qpos, band_dof, half_band = plant.link_qpos[band], plant.link_dof[band], plant.backlash_rad[band] / 2.0
    tip, xipos, R_ft = d.site_xpos[plant.tcp_site], d.xipos[plant.tool_body], d.site_xmat[plant.ft_site]
    wrench, ft = d.xfrc_applied[plant.tool_body], d.sensordata[plant.ft_sensor_adr : plant.ft_sensor_adr + 3]
    motor_qpos, link_qpos = plant.motor_qpos, plant.link_qpos
    n_tick = len(t_tick)
    log, integral = _Logs.empty(n_tick, plant.dof), np.zeros(plant.dof)
    sheet.start((tip - origin) @ R_ws, dirs[0])
    step_report = max(1, n_tick // 10)
    cycle = OnlineCycle(online, plan.kin, plan.q_sp, R_ws, dt, n_tick) if online is not None else None
    dq = np.zeros(plant.dof)
    start = time.perf_counter()
    for k in range(n_tick):
        mujoco.mj_step1(m, d)  # positions and velocities: the tip is current
        if cycle is not None and k % cycle.every == 0:
            dq = cycle.run(k, t_tick[k], d.qpos[motor_qpos], log.ft, log.R)
        err = plan.q_sp[k] + dq - d.qpos[motor_qpos]
        integral += err * dt
        d.ctrl[:] = plan.ctrl_ff[k] + dq + plan.ki_over_kp * integral
        p = (tip - origin) @ R_ws  # sheet frame
        if tip_force_n is None:
            f = sheet.force(p)
            f_world = R_ws @ f
        else:
            f_world = f = tip_force_n * min(1.0, t_tick[k] / LOAD_RAMP_S)
        l0, l1, l2 = (tip - xipos).tolist()
        a0, a1, a2 = f_world.tolist()
        wrench[:] = (a0, a1, a2, l1 * a2 - l2 * a1, l2 * a0 - l0 * a2, l0 * a1 - l1 * a0)
        log.p[k], log.f[k], log.e[k] = p, f, err
        log.q[k] = d.qpos[motor_qpos] + d.qpos[link_qpos]
        if band.size:
            q_gear = d.qpos[band_qpos]
            d.qfrc_applied[band_dof] = plant.gear_torques(q_gear, band)
            log.b[k, band] = np.clip(q_gear, -half_band, half_band)
        mujoco.mj_step2(m, d)  # forces, the F/T sensor at the state logged above, integration
        log.ft[k], log.R[k] = ft, R_ft
        if tip_force_n is None:
            sheet.advance(p)
        if not np.isfinite(d.qpos[0]):
            raise InputError(f"the dynamic plant diverged at t = {t_tick[k]:.4f} s (timestep {dt} s)")
        if progress is not None and (k + 1) % step_report == 0:
            print(f"  dynamic plant: {t_tick[k]:6.2f} / {t_tick[-1]:.2f} s simulated, "
                  f"{time.perf_counter() - start:5.1f} s wall", file=progress)
    wall = time.perf_counter() - start
    x_m, z_loaded = sheet.section()
    _, z_unloaded = sheet.unloaded_section()
    surface = None
    if scanned:  # the unsupported bottom inside the last contour hangs from the wall, down with it
        bottom = with_floating_bottom(sheet.x_m, sheet.y_m, sheet.unloaded_surface(), log.p, FORMED_BELOW_M)
        surface = (sheet.x_m.copy(), sheet.y_m.copy(), bottom)
    return DynamicLog(
        t_s=t_tick, p_tip_sheet_m=log.p, f_sheet_n=log.f, f_ft_local_n=log.ft, R_world_ft=log.R.reshape(n_tick, 3, 3),
        q_link=log.q, q_motor_error=log.e, q_play=log.b, formed_x_m=x_m, formed_z_m=z_loaded,
        unloaded_z_m=z_unloaded, wall_s=wall, formed_surface=surface, R_world_sheet=R_ws,
        online=None if cycle is None else cycle.log(),
    )


def default_progress() -> TextIO:
    """Where progress lines go by default (stderr)."""
    return sys.stderr
