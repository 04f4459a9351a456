"""tx200-twin: a MuJoCo digital twin of a robotized incremental-sheet-forming cell.

Data flows one way through the stages: base -> robot -> process -> sim -> runs -> lab -> analysis -> viz ->
apps -> cli (a module imports only its own stage and earlier ones). Each stage's `__init__` says what its
modules do and exports its public names (`__all__`); this package re-exports the names a user starts from, all
imported on first use:

    from twin import TwinSpec, Process, load_robot, run_lab, replay, compensate_twin
    spec = TwinSpec(robot=load_robot("tx200"), process=Process(force_model="isf"))
    twin = spec.build()
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    # the cell as data
    "TwinSpec": "twin.sim.spec",
    "Twin": "twin.sim.quasi_static",
    "SimResult": "twin.sim.result",
    "RobotDescription": "twin.robot.facts",
    "load_robot": "twin.robot.description",
    "Process": "twin.process.description",
    "Material": "twin.process.material.library",
    "material": "twin.process.material.file",
    "process_for": "twin.process.process_file",
    "read_process_file": "twin.process.process_file",
    "Placement": "twin.process.toolpath.placement",
    "Effects": "twin.sim.effects",
    "EFFECTS": "twin.sim.effects",
    "ForceField": "twin.process.force.base",
    "ForceModel": "twin.process.force.registry",
    "FORCE_MODELS": "twin.process.force.registry",
    "register_force_model": "twin.process.force.registry",
    "read_model_file": "twin.sim.model_file",
    "write_model_file": "twin.sim.model_file",
    # paths and forces
    "ToolPath": "twin.process.toolpath.groove",
    "groove_path": "twin.process.toolpath.groove",
    "PartSpec": "twin.process.toolpath.shapes",
    "part_path": "twin.process.toolpath.shapes",
    "ForceHistory": "twin.process.fe.load",
    "load_force_history": "twin.process.fe.load",
    # runs and labs
    "Run": "twin.runs.format",
    "read_run": "twin.runs.read",
    "write_run": "twin.runs.write",
    "import_run": "twin.runs.importer",
    "run_lab": "twin.lab.virtual",
    "load_test": "twin.lab.virtual",
    "run_dynamic_lab": "twin.lab.dynamic.run",
    # analysis
    "replay": "twin.analysis.replay",
    "learn": "twin.analysis.learn",
    "compensate_twin": "twin.analysis.compensate",
    "compensate_formula": "twin.analysis.compensate",
    "check_run": "twin.analysis.check",
    "find_discrepancy": "twin.analysis.discrepancy.search",
    "fit_kr_load_cases": "twin.analysis.identify.cartesian",
    "method2": "twin.analysis.identify.method2",
    "export_path": "twin.apps.export",
    # errors
    "TwinError": "twin.errors",
    "InputError": "twin.errors",
    "ModelError": "twin.errors",
    "DataFileError": "twin.errors",
    "UnitsError": "twin.errors",
    "RunFormatError": "twin.errors",
})
