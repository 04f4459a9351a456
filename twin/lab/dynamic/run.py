"""Drive a scenario on the dynamic plant and make a measured run (`tx200-twin-run/1`) and its truth.

Scenarios as in the quasi-static lab: `nominal` (the groove U_ID) and `compensated` (a commanded path from
a file) give runs; `loadtest` gives thesis Method 1 load cases at `home`, each held on the dynamic plant until
it settles and read by the tracker loaded and unloaded. `truth.json` records every knob, the seed, the plant's
absolute K_q (its own table times the knobs' scales) with the table's name and source, the dead bands, the servo
gains' inputs and a few physical numbers of the run (which no reader opens).
"""

from __future__ import annotations

from typing import Any, TextIO

import numpy as np

from twin.base.signals import interp_rows
from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.online import CycleCorrector
from twin.lab.dynamic.plant import Plant, build_plant, controller_model
from twin.lab.dynamic.sensors import ft_reading, part_scan, profile_scan, tracker_reading
from twin.lab.dynamic.simulate import DynamicLog, simulate
from twin.lab.dynamic.trajectory import retime_with_stops
from twin.process.description import Process
from twin.process.process_file import process_record
from twin.process.toolpath.placement import Placement
from twin.robot.description import robot_record
from twin.robot.facts import RobotDescription
from twin.robot.kinematics import Kinematics
from twin.robot.tool import ToolSpec
from twin.runs.format import Run, Stream, run_meta

LOAD_HOLD_S = 1.5  # each load case (ramped over 0.5 s) is held until this time, then read [s]


def run_dynamic_lab(
    t_s: np.ndarray,
    p_cmd_sheet_m: np.ndarray,
    *,
    scenario: str,
    knobs: Knobs,
    seed: int,
    process: Process | None = None,
    progress: TextIO | None = None,
    placement: Placement | None = None,
    robot: str | RobotDescription | None = None,
    declared: Process | None = None,
    corrector: CycleCorrector | None = None,
    tool: ToolSpec | None = None,
) -> tuple[Run, dict[str, Any], DynamicLog]:
    """Run the commanded path on the dynamic plant and measure it.

    Args:
        t_s: Commanded sample times [s], from 0; the trajectory generator re-plans them to stop at sharp
            corners (`trajectory.retime_with_stops`), and the run's commanded stream carries its times.
        p_cmd_sheet_m: Commanded tool tip, sheet frame [m], shape (n, 3).
        scenario: Label stored in meta.json.
        knobs: Plant, controller and sensor knobs.
        seed: Seed of the sensor noise.
        process: The lab's sheet, tool and force model (and its FE history); default the thesis's.
        progress: Stream for progress lines (None: quiet).
        placement: Where the sheet lies in the cell (recorded in meta.json); None: the cell's, yaw 0.
        robot: The robot (its model folder builds the plant); None: the default robot.
        declared: The process the run's meta.json records, as a cell's user declared it (a sheet other than the
            one formed, which truth.json then records); None: the process formed with.
        corrector: An online corrector the controller calls each cycle (`simulate.simulate`); its F/T samples'
            noise is seeded by [seed, 1]. None: none.
        tool: The cell's tool (`plant.build_plant`); None: the robot model's own.

    Returns:
        The run (not yet written), the truth record for `truth.json`, and the physical log.
    """
    plant = build_plant(knobs, robot, tool)
    process = process or Process()
    # the controller's trajectory generator stops at sharp corners: its timing is the run's commanded stream
    t_s = retime_with_stops(t_s, p_cmd_sheet_m, knobs["trajectory_accel_mps2"])
    log = simulate(t_s, p_cmd_sheet_m, knobs, process=process, plant=plant, progress=progress, placement=placement,
                   corrector=corrector, online_seed=int(np.random.SeedSequence([seed, 1]).generate_state(1)[0]))
    rng = np.random.default_rng(seed)
    t_tracker, tracker = tracker_reading(log, knobs, rng)
    t_ft, forces = ft_reading(log, knobs, rng, plant.tool_mass_kg)
    profile = profile_scan(log, knobs, rng)
    scan = part_scan(log, knobs, rng)
    meta = run_meta(
        scenario=scenario,
        source="tx200-twin dynamic lab (MuJoCo mj_step plant)",
        tracker_rate_hz=knobs["tracker_rate_hz"],
        sensor_rate_hz=knobs["ft_rate_hz"],
        seed=seed,
        tool_length_m=plant.robot.tool_length_m if tool is None else tool.length_m,
        placement=placement,
        robot=robot_record(plant.robot),
        force_model=process.force_model,
        process=declared or process,
    )
    run = Run(
        directory=None,
        meta=meta,
        commanded=Stream(np.asarray(t_s, dtype=float), np.asarray(p_cmd_sheet_m, dtype=float)),
        tracker=Stream(t_tracker, tracker),
        forces=Stream(t_ft, forces),
        part_profile=profile,
        part_scan=scan,
    )
    truth = truth_record(plant, knobs, seed, log, t_s, p_cmd_sheet_m)
    if declared is not None and declared != process:
        truth["process_formed"] = {**process_record(process), "force_fit": dict(process.force_fit)}
    return run, truth, log


def truth_record(
    plant: Plant, knobs: Knobs, seed: int, log: DynamicLog, t_s: np.ndarray, p_cmd_sheet_m: np.ndarray
) -> dict[str, Any]:
    """What `truth.json` holds for a dynamic run."""
    p_cmd = interp_rows(log.t_s, np.asarray(t_s, dtype=float), np.asarray(p_cmd_sheet_m, dtype=float))
    return {
        "plant": "dynamic",
        "knobs": knobs.as_dict(),
        "knobs_changed_from_neutral": knobs.changed(),
        "seed": seed,
        "joint_stiffness_nm_per_rad": plant.k_q.tolist(),
        "joint_stiffness_table": plant.stiffness_table,
        "joint_stiffness_source": plant.stiffness_source,
        "backlash_rad": plant.backlash_rad.tolist(),
        "timestep_s": float(plant.model.opt.timestep),
        "max_deviation_mm": 1e3 * float(np.max(np.linalg.norm(log.p_tip_sheet_m - p_cmd, axis=1))),
        "peak_force_n": float(np.max(np.linalg.norm(log.f_sheet_n, axis=1))),
        "max_motor_error_mrad": 1e3 * float(np.max(np.abs(log.q_motor_error))),
        "simulation_wall_s": log.wall_s,
    }


def dynamic_load_test(
    loads_n: np.ndarray, *, knobs: Knobs, seed: int, robot: str | RobotDescription | None = None,
    tool: ToolSpec | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Thesis Method 1 on the dynamic plant: each load held at `home`, the tip read loaded and unloaded.

    Args:
        loads_n: Loads on the tool tip, base frame [N], shape (m, 3).
        knobs: Plant, controller and tracker knobs (the tracker noise and registration apply).
        seed: Seed of the tracker noise.
        robot: The robot; None: the default robot.
        tool: The cell's tool (`plant.build_plant`); None: the robot model's own.

    Returns:
        The loads [N] and the measured deflections [m], shape (m, 3) each.
    """
    loads = np.asarray(loads_n, dtype=float)
    plant = build_plant(knobs, robot, tool)
    kin = Kinematics(controller_model(plant), robot=plant.robot)
    p_home, _ = kin.fk(kin.q_home)
    p_sheet = p_home - plant.p_base_sheet_origin
    t_hold = np.array([0.0, LOAD_HOLD_S])
    p_hold = np.vstack([p_sheet, p_sheet])
    rng = np.random.default_rng(seed)
    noise = 1e-3 * knobs["tracker_noise_mm"]

    def settled_tip(force: np.ndarray) -> np.ndarray:
        log = simulate(t_hold, p_hold, knobs, plant=plant, tip_force_n=force)
        return log.p_tip_sheet_m[-1]

    unloaded = settled_tip(np.zeros(3))
    deflections = np.array([settled_tip(f) - unloaded for f in loads])
    return loads, deflections + rng.normal(0.0, noise, deflections.shape) - rng.normal(
        0.0, noise, deflections.shape
    )
