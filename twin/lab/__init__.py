"""Lab: where measured runs come from when there is no cell — plants richer than the twin, with a hidden truth.

Modules: `virtual` (the quasi-static lab: the twin of a spec whose effects are hidden, with a tracker, a force
sensor and a profile scan with noise), `cnc` (the thesis's rigid-machine test) and `dynamic/` (a stepped MuJoCo
plant whose effects come from physics). Every lab writes `truth.json`, which no reader opens.

Takes a commanded path, a scenario and the lab's cell; gives run directories in the run format.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "LabSettings": "twin.lab.virtual",
    "run_lab": "twin.lab.virtual",
    "load_test": "twin.lab.virtual",
    "nominal_commanded": "twin.lab.virtual",
    "CncSettings": "twin.lab.cnc",
    "run_cnc": "twin.lab.cnc",
    "Knobs": "twin.lab.dynamic.knobs",
    "run_dynamic_lab": "twin.lab.dynamic.run",
    "dynamic_load_test": "twin.lab.dynamic.run",
    "retime_with_stops": "twin.lab.dynamic.trajectory",
})
