"""Sim: the twin — the compliant robot (robot stage) pressed against the sheet's force model (process stage).

Modules: `spec` (`TwinSpec`: robot, process, placement, effects, joint springs and friction; `.build()`),
`model_file` (the spec saved as a versioned JSON model file), `effects` (the effect vocabulary, each effect
declared once), `instruments` (the F/T sensor's and the tracker's calibration the effects carry), `gear_play` (a
gear's play under the forming load: the flank each joint's torque sets), `giving_frame` (a clamping frame that
gives under the axial force, in series with the sheet), `quasi_static` (`Twin`: the per-sample equilibrium along a commanded path), `dynamic` (`DynamicTwin`: the same arm stepped in time under a generic servo, for corners and reversals), `dynamic_servo` (`ServoModel`: that servo's four numbers, as a model file carries them), `equilibrium` (the
Newton and joint-friction solve), `python_loop` and `compiled/` (the per-sample loop in Python and in numba),
`servo` (the servo's transient compliance a cell's runs teach), `online` (the online compensator: each
controller cycle an F/T sample in, the twin's -C(q) F out, filtered, limited, watched; its settings in `online_settings`), `result` (`SimResult`), `ft_sensor` (the flange force sensor) and `measure` (what a tracker, a force sensor and a
profile scan see of a simulation, with the effects).

Takes a spec and a commanded path; gives the tool's equilibrium path, the sheet force, the joint states and what
the sensors read.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "TwinSpec": "twin.sim.spec",
    "Twin": "twin.sim.quasi_static",
    "SimResult": "twin.sim.result",
    "Effects": "twin.sim.effects",
    "ServoTransient": "twin.sim.servo",
    "EffectSpec": "twin.sim.effects",
    "EFFECTS": "twin.sim.effects",
    "parse_effect_args": "twin.sim.effects",
    "read_model_file": "twin.sim.model_file",
    "write_model_file": "twin.sim.model_file",
    "predict_tracker": "twin.sim.measure",
    "predict_forces": "twin.sim.measure",
    "predict_part_profile": "twin.sim.measure",
})
