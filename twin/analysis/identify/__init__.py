"""Identification: the robot's Cartesian stiffness K_R by the thesis's Method 1 (load cases) and Method 2
(a run) (`cartesian`, `method2`), and the joint stiffness K_q from K_R (Jacobian route, `joint`) or from runs
(rollouts over twin replays, `rollouts`); the sheet's forces from a run's F/T stream (`forces`) and the part's
springback from its scan (`springback`).

Takes load cases or runs; gives K_R, C_R = K_R^-1 and K_q with their uncertainties.
"""
