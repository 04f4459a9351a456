"""The dynamic lab plant: a MuJoCo `mj_step` plant whose effects come from physics, not from the twin's list.

Modules, in data-flow order: `knobs` (documented defaults and `--set` parsing) -> `plant` (MjSpec build: motor
side, gear spring with a dead band, friction, armature) -> `controller` (CS8C-class PID with feed-forward) ->
`sheet` (the plant's own sheet: membrane force on its formed surface, springback) -> `simulate` (the stepping
loop against that sheet) -> `sensors` (tracker and F/T chain on their own
clocks) -> `online` (a corrector the controller calls each cycle, with the F/T
sensor as it sees it during the run) -> `run` (scenarios into the run format) and `sweep` (feed sweep against a replay passed in); `tx200-twin lab
--plant dynamic` is `twin.apps.tasks.lab_dynamic`. Nothing here imports the twin (`twin.sim`), `twin.analysis` or
the quasi-static lab's `effects`, `measure`, `virtual`. See docs/dynamic-plant.md.
"""
