"""Robot: a robot as MuJoCo sees it, described as data.

Modules: `facts` (what the twin knows of a robot, `RobotDescription`: joints, tool, F/T site, home pose, DH table,
stiffness priors, vendor and language), `description` (which robot: the shipped and registered ones, `load_robot`),
`robot_file` (reading a description file beside its MJCF), `user_model`
(a user's own URDF or MJCF completed for the twin), `model` (the compiled MJCF with robot-side effects,
built with MjSpec), `kinematics` (MuJoCo FK, Jacobian, IK with the tool held vertical, Cartesian compliance),
`tool` (a declared tool on the flange, `ToolSpec`, put on the model in place of the MJCF's own),
`tool_bending` (the tool's own bending: a cantilever clamped at the flange, two spring hinges), `ft_mount` (the F/T
sensor's mounting on the flange and its axes in the sheet frame),
`chain_fk` (vectorised FK of the hinge chain), `ik_batch` (batched IK: many points at once, a warm start from
the last path's solution, the branch check), `dh` (the DH table's FK, the independent check), `pinocchio_model`
(the Pinocchio cross-check), `stiffness` (the joint springs K_q) and `controller` (what its controller takes from a
cell: the program's tool and base slots, the online correction's limits).

Takes a robot's model folder; gives compiled models, poses, Jacobians and IK solutions. Knows nothing of the sheet.
Nothing outside this stage names a joint, a joint count or a number of one robot.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "RobotDescription": "twin.robot.facts",
    "DhTable": "twin.robot.facts",
    "StiffnessPrior": "twin.robot.facts",
    "JointAddresses": "twin.robot.facts",
    "load_robot": "twin.robot.description",
    "shipped_robots": "twin.robot.description",
    "build_model": "twin.robot.model",
    "ToolSpec": "twin.robot.tool",
    "lost_motion_schedule": "twin.robot.model",
    "Kinematics": "twin.robot.kinematics",
    "load_model": "twin.robot.model",
    "dh_fk": "twin.robot.dh",
    "dh_jacobian": "twin.robot.dh",
    "det_jacobian_thesis": "twin.robot.dh",
    "PinKinematics": "twin.robot.pinocchio_model",
    "set_joint_stiffness": "twin.robot.stiffness",
    "joint_stiffness": "twin.robot.stiffness",
})
