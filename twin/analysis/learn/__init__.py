"""Learning the cell: a twin of a cell it did not build, from that cell's nominal runs.

Modules: `robot` (joint stiffness, friction, the servo's transient and the tracker's offset: from the measured
forces and tool positions; `tracker`: which of the tracker's own errors it fits beside them), `sheet` (the `learned`
force model's weights: from the F/T stream), `springback` (two springback constants: from the runs' part profiles),
`instruments` (the tracker's rotation and shift and the F/T bias, carried as the instruments' calibration), `cell`
(`learn`: all of them, the learned spec and the replay gap before, after and on a run left out), `servo_fit` (the
dynamic twin's servo and stop timing, fitted to a run's tracker; `dynamic_replay`), `split` (a run's replay gap
split into the robot's part and the sheet's part, the twin's robot driven by the measured forces), `signatures`
(what was learned, in words).
"""

from twin.analysis.learn.cell import Gap, LearnResult, learn, learned_spec
from twin.analysis.learn.robot import RobotFit, fit_robot
from twin.analysis.learn.sheet import SheetFit, fit_sheet
from twin.analysis.learn.tracker import TrackerErrors

__all__ = ["Gap", "LearnResult", "RobotFit", "SheetFit", "TrackerErrors", "fit_robot", "fit_sheet", "learn",
           "learned_spec"]
