"""Robot: the TX200 as MuJoCo sees it — MJCF loading and MjSpec building with robot-side effects (`model`),
kinematics (MuJoCo FK/Jacobian/IK, the thesis's DH chain, the Pinocchio cross-check) and the joint springs K_q
(`stiffness`).

Takes the MJCF in `models/`; gives compiled models, poses, Jacobians and IK solutions. Knows nothing of the sheet.
"""
