"""tx200-twin: a MuJoCo digital twin of a compliant Staubli TX200 doing incremental sheet forming.

Data flows one way: path -> force field -> twin -> lab (or a real cell) -> identify -> compensate -> check
-> discrepancy. The public API is re-exported here.
"""

from twin.analysis.check import CheckResult, check_run, diagnose_gain
from twin.analysis.compensate import (
    Compensation,
    compensate_formula,
    compensate_twin,
    compensation_gain,
    compliance_from_stiffness,
    gain_of,
)
from twin.analysis.discrepancy.residuals import ResidualModel, estimate_noise
from twin.analysis.discrepancy.search import DiscrepancyResult, find_discrepancy
from twin.analysis.discrepancy.summary import result_summary
from twin.analysis.identify.cartesian import (
    KrFit,
    fit_compliance,
    fit_kr_from_run,
    fit_kr_load_cases,
    load_cases_csv,
)
from twin.analysis.identify.joint import KqFit, fit_diagonal_kq
from twin.analysis.identify.method2 import Method2Result, method2
from twin.analysis.identify.rollouts import (
    KqRolloutFit,
    kq_from_run,
    kq_from_stiffness,
    write_joint_stiffness,
)
from twin.analysis.replay import ReplayResult, replay, replay_metrics
from twin.analysis.surface_check import SurfaceDeviation, read_target_mesh, surface_deviation
from twin.apps.bench import analytic_replay, run_benchmarks
from twin.apps.export import export_path
from twin.apps.sweep import run_sweep
from twin.errors import (
    CompensationError,
    DataFileError,
    IdentificationError,
    InputError,
    ModelError,
    RunFormatError,
    SingularityError,
    SymmetryError,
    TwinError,
    UnitsError,
    UnreachableError,
)
from twin.lab.dynamic.knobs import Knobs as DynamicKnobs
from twin.lab.dynamic.run import dynamic_load_test, run_dynamic_lab
from twin.lab.dynamic.trajectory import retime_with_stops
from twin.lab.effects import EFFECTS, Effects, parse_effect_args, read_model_file, write_model_file
from twin.lab.virtual import LabSettings, load_test, nominal_commanded, run_lab
from twin.process.field import SheetForceField
from twin.process.forces import ForceHistory, default_force_history, load_force_history
from twin.process.gcode import parse_gcode, read_gcode, write_gcode
from twin.process.heightmap import HeightMap
from twin.process.isf_calibration import IsfFit, calibrate_isf, isf_field_factory
from twin.process.isf_force import IsfForceField, IsfForceParams
from twin.process.part_bottom import with_floating_bottom
from twin.process.part_surface import formed_surface, heightmap_mesh, surface_points, target_part_surface
from twin.process.path import GrooveSpec, ToolPath, groove_path, label_passes, write_path_csv
from twin.process.placement import Placement, ReachReport, check_reach
from twin.process.shapes import PartSpec, part_path
from twin.process.tool_friction import SlidingFriction
from twin.robot.kinematics import HOME_Q_RAD, TOOL_LENGTH_M, Kinematics, load_model
from twin.robot.model import RobotEffects, build_model
from twin.robot.pinocchio_model import PinKinematics
from twin.runs.format import Run, Stream, run_placement
from twin.runs.importer import ImportResult, import_run, import_to_directory
from twin.runs.mapping import ImportMapping, load_mapping
from twin.runs.read import read_commanded_csv, read_run
from twin.runs.toml_keys import ClockError, MappingError, RegistrationError
from twin.runs.write import write_run
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult

__all__ = [
    "EFFECTS",
    "HOME_Q_RAD",
    "TOOL_LENGTH_M",
    "CheckResult",
    "ClockError",
    "Compensation",
    "CompensationError",
    "DataFileError",
    "DiscrepancyResult",
    "DynamicKnobs",
    "Effects",
    "ForceHistory",
    "GrooveSpec",
    "HeightMap",
    "IdentificationError",
    "ImportMapping",
    "ImportResult",
    "InputError",
    "IsfFit",
    "IsfForceField",
    "IsfForceParams",
    "Kinematics",
    "KqFit",
    "KqRolloutFit",
    "KrFit",
    "LabSettings",
    "MappingError",
    "Method2Result",
    "ModelError",
    "PartSpec",
    "PinKinematics",
    "Placement",
    "ReachReport",
    "RegistrationError",
    "ReplayResult",
    "ResidualModel",
    "RobotEffects",
    "Run",
    "RunFormatError",
    "SheetForceField",
    "SimResult",
    "SingularityError",
    "SlidingFriction",
    "Stream",
    "SurfaceDeviation",
    "SymmetryError",
    "ToolPath",
    "Twin",
    "TwinError",
    "UnitsError",
    "UnreachableError",
    "analytic_replay",
    "build_model",
    "calibrate_isf",
    "check_reach",
    "check_run",
    "compensate_formula",
    "compensate_twin",
    "compensation_gain",
    "compliance_from_stiffness",
    "default_force_history",
    "diagnose_gain",
    "dynamic_load_test",
    "estimate_noise",
    "export_path",
    "find_discrepancy",
    "fit_compliance",
    "fit_diagonal_kq",
    "fit_kr_from_run",
    "fit_kr_load_cases",
    "formed_surface",
    "gain_of",
    "groove_path",
    "heightmap_mesh",
    "import_run",
    "import_to_directory",
    "isf_field_factory",
    "kq_from_run",
    "kq_from_stiffness",
    "label_passes",
    "load_cases_csv",
    "load_force_history",
    "load_mapping",
    "load_model",
    "load_test",
    "method2",
    "nominal_commanded",
    "parse_effect_args",
    "parse_gcode",
    "part_path",
    "read_commanded_csv",
    "read_gcode",
    "read_model_file",
    "read_run",
    "read_target_mesh",
    "replay",
    "replay_metrics",
    "result_summary",
    "retime_with_stops",
    "run_benchmarks",
    "run_dynamic_lab",
    "run_lab",
    "run_placement",
    "run_sweep",
    "surface_deviation",
    "surface_points",
    "target_part_surface",
    "with_floating_bottom",
    "write_gcode",
    "write_joint_stiffness",
    "write_model_file",
    "write_path_csv",
    "write_run",
]
