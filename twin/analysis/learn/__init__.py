"""Learning the cell: a twin of a cell it did not build, from that cell's nominal runs.

Modules: `robot` (effective joint stiffness, friction, servo lag: from the measured forces and tool positions),
`sheet` (the `learned` force model's weights: from the F/T stream), `cell` (`learn`: both, the learned spec and
the replay gap before, after and on a run left out), `split` (a run's replay gap split into the robot's part and
the sheet's part, the twin's robot driven by the measured forces).
"""

from twin.analysis.learn.cell import Gap, LearnResult, learn, learned_spec
from twin.analysis.learn.robot import RobotFit, fit_robot
from twin.analysis.learn.sheet import SheetFit, fit_sheet

__all__ = ["Gap", "LearnResult", "RobotFit", "SheetFit", "fit_robot", "fit_sheet", "learn", "learned_spec"]
