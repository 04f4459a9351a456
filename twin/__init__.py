"""tx200-twin: a MuJoCo digital twin of a compliant Staubli TX200 doing incremental sheet forming.

Data flows one way: path -> force field -> twin -> lab (or a real cell) -> identify -> compensate -> check
-> discrepancy. The public API is re-exported here.
"""

from twin.bench import analytic_replay, run_benchmarks
from twin.check import CheckResult, check_run, diagnose_gain
from twin.compensate import (
    Compensation,
    compensate_formula,
    compensate_twin,
    compliance_from_stiffness,
    gain_of,
)
from twin.discrepancy import DiscrepancyResult, find_discrepancy, result_summary
from twin.effects import EFFECTS, Effects, parse_effect_args, read_model_file, write_model_file
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
from twin.field import SheetForceField
from twin.forces import ForceHistory, default_force_history, load_force_history
from twin.identify import (
    KqFit,
    KrFit,
    compensation_gain,
    fit_compliance,
    fit_diagonal_kq,
    fit_kr_from_run,
    fit_kr_load_cases,
    load_cases_csv,
)
from twin.identify_kq import KqRolloutFit, kq_from_run, kq_from_stiffness, write_joint_stiffness
from twin.identify_run import Method2Result, method2
from twin.kinematics import HOME_Q_RAD, TOOL_LENGTH_M, Kinematics, load_model
from twin.lab import LabSettings, load_test, nominal_commanded, run_lab
from twin.path import GrooveSpec, ToolPath, groove_path, label_passes, write_path_csv
from twin.pinocchio_model import PinKinematics
from twin.plant import RobotEffects, build_model
from twin.replay import ReplayResult, replay, replay_metrics
from twin.residuals import ResidualModel, estimate_noise
from twin.runs import Run, Stream, read_commanded_csv, read_run, write_run
from twin.sim import SimResult, Twin

__all__ = [
    "EFFECTS",
    "HOME_Q_RAD",
    "TOOL_LENGTH_M",
    "CheckResult",
    "Compensation",
    "CompensationError",
    "DataFileError",
    "DiscrepancyResult",
    "Effects",
    "ForceHistory",
    "GrooveSpec",
    "IdentificationError",
    "InputError",
    "Kinematics",
    "KqFit",
    "KqRolloutFit",
    "KrFit",
    "LabSettings",
    "Method2Result",
    "ModelError",
    "PinKinematics",
    "ReplayResult",
    "ResidualModel",
    "RobotEffects",
    "Run",
    "RunFormatError",
    "SheetForceField",
    "SimResult",
    "SingularityError",
    "Stream",
    "SymmetryError",
    "ToolPath",
    "Twin",
    "TwinError",
    "UnitsError",
    "UnreachableError",
    "analytic_replay",
    "build_model",
    "check_run",
    "compensate_formula",
    "compensate_twin",
    "compensation_gain",
    "compliance_from_stiffness",
    "default_force_history",
    "diagnose_gain",
    "estimate_noise",
    "find_discrepancy",
    "fit_compliance",
    "fit_diagonal_kq",
    "fit_kr_from_run",
    "fit_kr_load_cases",
    "gain_of",
    "groove_path",
    "kq_from_run",
    "kq_from_stiffness",
    "label_passes",
    "load_cases_csv",
    "load_force_history",
    "load_model",
    "load_test",
    "method2",
    "nominal_commanded",
    "parse_effect_args",
    "read_commanded_csv",
    "read_model_file",
    "read_run",
    "replay",
    "replay_metrics",
    "result_summary",
    "run_benchmarks",
    "run_lab",
    "write_joint_stiffness",
    "write_model_file",
    "write_path_csv",
    "write_run",
]
