"""The dynamic plant's own robots: the gear stiffness K_q of the cell the twin is judged on, not the twin's prior.

The twin reads its joint stiffness prior from the robot's MJCF (each arm joint's position-actuator gain, the
`[[stiffness_prior]]` rows of `models/*/robot.toml`). A plant that took its K_q from the same file would hand the
twin the answer its identification is meant to find. So the plant keeps its own table of ABSOLUTE gear
stiffnesses per shipped robot (`PLANT_GEAR_STIFFNESS_NM_PER_RAD`), written here once and not computed from the
model at run time: a real robot of the class, which differs from its nominal joint by joint, some joints stiffer
and some softer. Knobs `gear_stiffness_j<i>_scale` (default 1) multiply it.

How far off, and the source of the spread (what was read, and what was not):

* Dumas, Caro, Garnier, Furet, "Joint stiffness identification of six-revolute industrial serial robots",
  Robotics and Computer-Integrated Manufacturing 27(4), 2011 (KUKA KR240-2), and Jubien, Abba, Gautier, "Joint
  stiffness identification of a heavy Kuka robot with a low-cost clamped end-effector procedure" (ICINCO 2014,
  KUKA KR500, joints 1-2 by two methods): found, only their abstracts read; their tables of identified values
  were NOT read here, so no number below is taken from them.
* What was read (the project's `shared/outside-references.md`, `models/*/robot.toml`): a KUKA KR500's joint stiffness
  from EMA, diag(2.3, 8.6, 2.8, 3.0, 0.2, 0.9)e6 N·m/rad (a public robot-milling model's constants, secondary,
  dynamic stiffness), against the TX200's values calibrated to the thesis's load test, (2.24, 1.91, 1.25, 0.50,
  0.24, 0.50)e6 N·m/rad. Two heavy 6R robots identified two ways differ per joint by factors 0.8 (joint 5) to
  6 (joint 4), in both directions: joint stiffness of this class is known to within tens of percent at best,
  and a nominal value is not a given robot's.
* The plant therefore sits 0.72-1.38x off the twin's prior on at least five of the six joints of each robot
  (both signs, a different pattern per robot), well inside that spread, and far enough (>= 10 %) that a
  learner which does not move off its prior is seen not to. `tests/test_plant.py` holds it off whatever the
  prior becomes.

A robot with no row here (a user's URDF/MJCF completed by `twin.robot.user_model`, or a description file other
than the shipped one): the plant's ASSUMPTION is the model's K_q times the fixed per-joint pattern
`UNLISTED_ROBOT_FACTORS` (repeated past six joints), stated in `truth.json` as the table used.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.robot.description import shipped_robots
from twin.robot.facts import RobotDescription

#: The plant's gear stiffness per shipped robot [N·m/rad], joints 1..6 (module docstring). Against the twin's
#: prior (the MJCF's actuator gains at the time of writing), the ratios are:
#: tx200 0.82, 1.22, 0.93, 1.38, 1.16, 0.74; kr210 1.25, 0.78, 1.06, 0.72, 1.35, 0.88;
#: irb6640 1.12, 0.84, 1.30, 0.95, 0.76, 1.24.
PLANT_GEAR_STIFFNESS_NM_PER_RAD: dict[str, tuple[float, ...]] = {
    "tx200": (1.84e6, 2.33e6, 1.16e6, 6.9e5, 2.81e5, 3.7e5),
    "kr210": (1.21e6, 2.82e6, 1.25e6, 9.1e5, 1.13e5, 3.33e5),
    "irb6640": (2.46e6, 1.60e6, 1.56e6, 4.75e5, 1.82e5, 6.2e5),
}

#: Source line `truth.json` records with a table of `PLANT_GEAR_STIFFNESS_NM_PER_RAD`.
TABLE_SOURCE = (
    "twin/lab/dynamic/plant_robots.py: the plant's own absolute K_q, 0.72-1.38x the twin's prior per joint "
    "(spread of heavy 6R identifications: KR500 EMA vs TX200 calibrated, factors 0.8-6 per joint)"
)

#: The plant's assumption for a robot with no table: the model's K_q times these factors, joint by joint [-].
UNLISTED_ROBOT_FACTORS: tuple[float, ...] = (0.82, 1.22, 0.9, 1.3, 0.78, 1.15)


@dataclass(frozen=True)
class PlantStiffness:
    """The plant's gear stiffness of one robot, before the knobs.

    Attributes:
        k_q: Gear stiffness K_q per arm joint [N·m/rad], shape (dof,).
        table: Name of the table used (`plant:<robot>`, or `assumed:model-x-factors`).
        source: Where it comes from, in words.
    """

    k_q: np.ndarray
    table: str
    source: str


def _is_shipped(robot: RobotDescription) -> bool:
    """Whether `robot` is the shipped robot of its name (its own description file, not a user's of that name)."""
    path = shipped_robots().get(robot.name)
    if path is None:
        return False
    try:
        return Path(path).resolve() == Path(robot.source).resolve()
    except OSError:
        return False


def plant_gear_stiffness(robot: RobotDescription, model_k_q: np.ndarray) -> PlantStiffness:
    """The plant's own K_q of `robot` (module docstring).

    Args:
        robot: The robot.
        model_k_q: K_q of the robot's model (its actuator gains, the twin's prior) [N·m/rad], shape (dof,); used
            only for a robot the plant has no table for.

    Returns:
        The plant's K_q and the name and source of its table.
    """
    table = PLANT_GEAR_STIFFNESS_NM_PER_RAD.get(robot.name)
    if table is not None and len(table) == robot.dof and _is_shipped(robot):
        return PlantStiffness(np.array(table, dtype=float), f"plant:{robot.name}", TABLE_SOURCE)
    factors = np.resize(np.array(UNLISTED_ROBOT_FACTORS), robot.dof)
    return PlantStiffness(
        np.asarray(model_k_q, dtype=float) * factors,
        "assumed:model-x-factors",
        "no plant table for this robot: the plant assumes the model's K_q times "
        f"{', '.join(f'{f:g}' for f in factors)} per joint (twin/lab/dynamic/plant_robots.py)",
    )
