"""One `TwinSpec`: everything that makes a twin of the user's cell, frozen and validated, and `.build()`.

A spec holds the robot (`twin.robot.description`), the process (sheet, tool, force model and its FE history,
`twin.process.description`), the sheet's placement in the robot base, the effects the twin knows
(`twin.sim.effects`), overrides of the joint springs K_q and the joint friction (None: the robot model's
own), the servo's transient compliance where one was learned and the tool on the flange where one was declared
(`twin.robot.tool.ToolSpec`; None: the robot model's own). Every stage that simulates takes a spec (or a twin built from one); the model file is its saved form
(`twin.sim.model_file`). Defaults are the thesis's cell: the TX200, the groove's table force field, the cell's
sheet origin.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.registry import force_model
from twin.process.toolpath.placement import Placement
from twin.robot.description import load_robot
from twin.robot.facts import RobotDescription
from twin.robot.tool import ToolSpec
from twin.sim.dynamic_servo import ServoModel
from twin.sim.effects import Effects
from twin.sim.servo import ServoTransient

if TYPE_CHECKING:
    from twin.sim.quasi_static import Twin


@dataclass(frozen=True)
class TwinSpec:
    """The twin of one cell (module docstring).

    Attributes:
        robot: The robot, or its name / description file (read with `load_robot`).
        process: Sheet, tool, force model and FE history.
        placement: The sheet frame in the robot base.
        effects: Effects the twin carries.
        joint_stiffness_nm_per_rad: K_q per arm joint [N·m/rad]; None: the robot model's.
        joint_friction_nm: Coulomb friction per arm joint [N·m]; None: the robot model's.
        servo: The servo's transient compliance (`twin.sim.servo`), learned from a cell; None: none.
        tool: The tool on the flange (`twin.robot.tool.ToolSpec`: length, mass, centre of gravity), simulated in
            place of the robot model's; None: the robot model's own tool.
        dynamic_servo: The joint servo of the dynamic mode (`twin.sim.dynamic.ServoModel`), learned from a run
            (`learn --dynamic`); None: none learned.
    """

    robot: RobotDescription = field(default_factory=load_robot)
    process: Process = field(default_factory=Process)
    placement: Placement = field(default_factory=Placement)
    effects: Effects = field(default_factory=Effects)
    joint_stiffness_nm_per_rad: tuple[float, ...] | None = None
    joint_friction_nm: tuple[float, ...] | None = None
    servo: ServoTransient | None = None
    tool: ToolSpec | None = None
    dynamic_servo: ServoModel | None = None

    def __post_init__(self) -> None:
        robot = load_robot(self.robot) if isinstance(self.robot, str | Path) else self.robot
        checks = (("process", Process), ("placement", Placement), ("effects", Effects))
        if not isinstance(robot, RobotDescription):
            raise InputError(f"TwinSpec.robot = {self.robot!r}: expected a RobotDescription, a name or a path")
        for name, kind in checks:
            if not isinstance(getattr(self, name), kind):
                raise InputError(f"TwinSpec.{name} = {getattr(self, name)!r}: expected a {kind.__name__}")
        force_model(self.process.force_model)  # registered (the error lists the models)
        play = self.effects.gear_play_rad
        if play and len(play) != robot.dof:
            raise InputError(f"gear play {[1e3 * b for b in play]} mrad gives {len(play)} joints; robot {robot.name!r} "
                             f"has {robot.dof} arm joints: give one value for each")
        if self.servo is not None and (not isinstance(self.servo, ServoTransient)
                                       or len(self.servo.compliance_rad_per_nm) != robot.dof):
            raise InputError(f"TwinSpec.servo = {self.servo!r}: expected a ServoTransient with {robot.dof} joints")
        if self.dynamic_servo is not None and not isinstance(self.dynamic_servo, ServoModel):
            raise InputError(f"TwinSpec.dynamic_servo = {self.dynamic_servo!r}: expected a ServoModel or None")
        if self.tool is not None and not isinstance(self.tool, ToolSpec):
            raise InputError(f"TwinSpec.tool = {self.tool!r}: expected a ToolSpec (ToolSpec.make) or None")
        object.__setattr__(self, "robot", robot)
        for name, what, unit, positive in (
            ("joint_stiffness_nm_per_rad", "joint stiffness", "N·m/rad", True),
            ("joint_friction_nm", "joint friction", "N·m", False),
        ):
            value = getattr(self, name)
            if value is not None:
                arr = robot.joint_vector(value, what, unit, positive=positive, nonnegative=not positive)
                object.__setattr__(self, name, tuple(float(v) for v in arr))

    def replace(self, **changes: Any) -> TwinSpec:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    @property
    def tool_length_m(self) -> float:
        """Flange to tool tip [m]: the declared tool's, else the robot model's."""
        return self.robot.tool_length_m if self.tool is None else self.tool.length_m

    @property
    def joint_stiffness(self) -> np.ndarray | None:
        """The K_q override as an array [N·m/rad], or None."""
        return None if self.joint_stiffness_nm_per_rad is None else np.array(self.joint_stiffness_nm_per_rad)

    @property
    def joint_friction(self) -> np.ndarray | None:
        """The joint-friction override as an array [N·m], or None."""
        return None if self.joint_friction_nm is None else np.array(self.joint_friction_nm)

    def build(self) -> Twin:
        """The twin of this spec."""
        from twin.sim.quasi_static import Twin  # the twin's module imports this one

        return Twin(self)
