"""Every extension point takes a part from the user's own code, with no file of the package changed: a toy of
each kind is written and registered here, in the test, and used through the API and the CLI (README "to add").

The toys are in forms the package does not have (a spring floor for a sheet, a tracker whose x scale is off, a
point list with its own header), so a pass shows the seam, not a shipped part reached another way.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.discrepancy.context import Context
from twin.analysis.discrepancy.families.base import FAMILIES, Delta, Family, register
from twin.analysis.discrepancy.search import find_discrepancy
from twin.analysis.replay import replay
from twin.apps.export import EXPORT_FORMATS, ExportFormat, export_path
from twin.apps.export.program import ProgramPath
from twin.apps.tasks.base import Report
from twin.apps.tasks.lab import LAB_PLANTS, LabPlant, LabRequest
from twin.cli import main
from twin.errors import InputError
from twin.lab.virtual import run_lab
from twin.process.description import Process
from twin.process.force.base import ForceField
from twin.process.force.registry import ForceModel, register_force_model, unregister_force_model
from twin.process.toolpath.groove import groove_path
from twin.robot.description import ROBOTS, load_robot, register_robot
from twin.runs.format import Run, Stream, run_meta
from twin.runs.read import read_run
from twin.runs.write import write_path_csv, write_run
from twin.sim.effects import EFFECTS, Effects, EffectSpec, register_effect
from twin.sim.spec import TwinSpec

MODELS = Path(__file__).resolve().parents[1] / "models"


# --- a robot ---------------------------------------------------------------------------------------------------

@pytest.fixture
def toy_robot(tmp_path: Path) -> Iterator[str]:
    text = (MODELS / "tx200.toml").read_text().replace('name = "tx200"', 'name = "toy-arm"')
    text = text.replace('mjcf = "tx200.xml"', f'mjcf = "{MODELS / "tx200.xml"}"')
    text = text.replace('scene = "cell/scene.xml"', f'scene = "{MODELS / "cell" / "scene.xml"}"')
    (tmp_path / "toy.toml").write_text(text)
    register_robot(tmp_path / "toy.toml")
    yield "toy-arm"
    ROBOTS.unregister("toy-arm")


def test_a_registered_robot_is_found_by_name_by_the_api_and_the_cli(toy_robot: str, capsys) -> None:
    assert load_robot(toy_robot).name == "toy-arm"
    assert main(["info", "--robot", toy_robot]) == 0
    assert str(MODELS / "cell" / "scene.xml") in capsys.readouterr().out


# --- a force model ---------------------------------------------------------------------------------------------

class SpringFloor(ForceField):
    """A sheet that pushes back like a spring floor at z = 0: F_z = k max(0, -z); nothing is formed."""

    K_N_PER_M = 4.0e5

    def __init__(self) -> None:
        self.radius, self.k_unload = 7.5e-3, 1e6

    def reset(self) -> None:
        pass

    def force(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        return np.array([0.0, 0.0, self.K_N_PER_M * max(0.0, -float(p_sheet_m[2]))])

    def force_and_stiffness(self, p_sheet_m, pass_index, direction):
        k = np.zeros((3, 3))
        k[2, 2] = -self.K_N_PER_M if p_sheet_m[2] < 0 else 0.0
        return self.force(p_sheet_m, pass_index, direction), k

    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None) -> None:
        pass

    @property
    def x_grid_m(self) -> np.ndarray:
        return np.linspace(-0.1, 0.1, 201)

    @property
    def formed_z_m(self) -> np.ndarray:
        return np.zeros(201)


@pytest.fixture
def spring_floor() -> Iterator[str]:
    register_force_model(ForceModel("toy-spring", "a spring floor at z = 0", lambda history, process: SpringFloor()))
    yield "toy-spring"
    unregister_force_model("toy-spring")


def test_a_registered_force_model_drives_the_twin_and_is_a_cli_choice(spring_floor: str, tmp_path: Path) -> None:
    ideal = groove_path()
    sim = TwinSpec(process=Process(force_model=spring_floor)).build().simulate(ideal.t_s, ideal.p_sheet_m)
    deepest = np.argmin(ideal.p_sheet_m[:, 2])
    # the floor's force at the tip the robot reached: the robot gives way, so less than k x the commanded depth
    fz = sim.f_sheet_n[deepest, 2]
    assert 0.0 < fz < SpringFloor.K_N_PER_M * -ideal.p_sheet_m[deepest, 2]
    assert fz == pytest.approx(SpringFloor.K_N_PER_M * max(0.0, -sim.p_sheet_m[deepest, 2]), rel=1e-6)
    write_path_csv(ideal, tmp_path / "groove.csv")
    assert main(["compensate", "--method", "twin", "--force-model", spring_floor, "--ideal",
                 str(tmp_path / "groove.csv"), "--out", str(tmp_path / "c.csv")]) == 0


# --- an effect, and the family that finds it --------------------------------------------------------------------

def _x_scale(t_s: np.ndarray, p_sheet_m: np.ndarray, value: float) -> np.ndarray:
    """The toy tracker reads x too long by `value` (a scale error of its x axis, about the sheet origin)."""
    return np.outer(p_sheet_m[:, 0], [value, 0.0, 0.0])


class TrackerXScale(Family):
    name = "toy_tracker_x_scale"
    parameters = ("scale_ratio",)
    neutral = (0.0,)
    bounds = ((-0.05,), (0.05,))
    scale = (1e-3,)
    description = "the tracker's x axis reads long by a ratio"
    effect = "toy_tracker_x_scale"
    acts_on = ("position",)

    def delta(self, ctx: Context, theta: np.ndarray) -> Delta:
        return Delta(position=np.outer(ctx.pred["position"][:, 0], [theta[0], 0.0, 0.0]))

    def to_effect(self, theta: np.ndarray, covariance: np.ndarray | None) -> float | None:
        return float(theta[0])


@pytest.fixture
def tracker_scale() -> Iterator[str]:
    register_effect(EffectSpec("toy_tracker_x_scale", "-", 0.0, (-0.05, 0.05), "tracker",
                               "tracker x reads long by a ratio", 1e-4, key_suffix="ratio", tracker=_x_scale))
    register(TrackerXScale)
    yield "toy_tracker_x_scale"
    FAMILIES.unregister("toy_tracker_x_scale")
    EFFECTS.unregister("toy_tracker_x_scale")


def test_a_registered_effect_is_found_named_and_closes_the_gap(tracker_scale: str) -> None:
    ideal = groove_path()
    run, _ = run_lab(ideal.t_s, ideal.p_sheet_m, scenario="nominal", seed=3)
    p = run.tracker.values.copy()
    p[:, 0] *= 1.0 + 4e-3  # hidden here, in the test: the tracker's x axis reads 0.4 % long
    run = replace(run, tracker=Stream(run.tracker.t_s, p))
    before = replay(run).metrics["position_rms_mm"]
    found = find_discrepancy(run)
    assert found.verdict == tracker_scale
    value = found.effects.get(tracker_scale)
    assert value == pytest.approx(4e-3, rel=0.1)
    after = replay(run, TwinSpec(effects=Effects({tracker_scale: value}))).metrics["position_rms_mm"]
    assert after < 0.5 * before  # down to the tracker noise (the lab run without the toy: about 0.035 mm)


# --- an export format ------------------------------------------------------------------------------------------

def _write_xyz(program: ProgramPath, out: Path, protect: Sequence[Path]) -> list[Path]:
    del protect
    rows = [f"{x:.3f} {y:.3f} {z:.3f}" for x, y, z in np.asarray(program.points_mm)]
    out.write_text("# toy xyz\n" + "\n".join(rows) + "\n")
    return [out]


@pytest.fixture
def xyz_format() -> Iterator[str]:
    EXPORT_FORMATS.register(ExportFormat("toy-xyz", _write_xyz))
    yield "toy-xyz"
    EXPORT_FORMATS.unregister("toy-xyz")


def test_a_registered_export_format_writes_through_the_api_and_the_cli(xyz_format: str, tmp_path: Path) -> None:
    ideal = groove_path()
    write_path_csv(ideal, tmp_path / "groove.csv")
    exported = export_path(tmp_path / "groove.csv", xyz_format, tmp_path / "a.xyz")
    lines = (tmp_path / "a.xyz").read_text().splitlines()
    assert lines[0] == "# toy xyz" and len(lines) > len(ideal.t_s) // 2
    assert exported.files == [tmp_path / "a.xyz"]
    assert main(["export", str(tmp_path / "groove.csv"), "--format", xyz_format, "--out", str(tmp_path / "b.xyz")]) == 0
    assert (tmp_path / "b.xyz").is_file()


# --- a lab plant ----------------------------------------------------------------------------------------------

def _check_rigid(request: LabRequest) -> None:
    if request.effects or request.knobs or request.scenario != "nominal":
        raise InputError("--plant toy-rigid runs a nominal scenario and hides nothing")


class RigidReport(Report):
    def __init__(self, out: Path) -> None:
        self.out = out

    def lines(self) -> list[str]:
        return [f"toy rigid lab -> {self.out}"]

    def record(self) -> dict[str, object]:
        return {"out": str(self.out)}


def _run_rigid(request: LabRequest, note) -> RigidReport:
    """A perfectly rigid robot whose tracker reads the command at 50 Hz, its F/T nothing: no deflection, no noise."""
    ideal = groove_path()
    t_s = np.arange(ideal.t_s[0], ideal.t_s[-1], 0.02)
    tip = np.column_stack([np.interp(t_s, ideal.t_s, ideal.p_sheet_m[:, k]) for k in range(3)])
    meta = run_meta(scenario="nominal", source="toy rigid lab", tracker_rate_hz=50.0, sensor_rate_hz=50.0,
                    seed=request.seed, tool_length_m=load_robot().tool_length_m)
    write_run(request.out, Run(None, meta, Stream(ideal.t_s, ideal.p_sheet_m), Stream(t_s, tip),
                               Stream(t_s, np.zeros_like(tip))))  # its F/T reads nothing
    return RigidReport(request.out)


@pytest.fixture
def rigid_lab() -> Iterator[str]:
    LAB_PLANTS.register(LabPlant("toy-rigid", "a rigid robot, no forces", _check_rigid, _run_rigid))
    yield "toy-rigid"
    LAB_PLANTS.unregister("toy-rigid")


def test_a_registered_lab_plant_writes_a_run_the_twin_replays(rigid_lab: str, tmp_path: Path) -> None:
    assert main(["lab", "--scenario", "nominal", "--plant", rigid_lab, "--seed", "1", "--out", str(tmp_path / "r")]) == 0
    gap = replay(read_run(tmp_path / "r")).metrics
    # the twin bends under its forces where the rigid toy did not: the gap is the twin's own deflection (mm)
    assert 0.5 < gap["position_max_mm"] < 5.0
    assert main(["lab", "--scenario", "cnc", "--plant", rigid_lab, "--seed", "1", "--out", str(tmp_path / "c")]) == 2


def test_a_name_is_registered_once() -> None:
    with pytest.raises(ValueError, match="already registered"):
        EFFECTS.register(EFFECTS["lost_motion"])
    with pytest.raises(ValueError, match="reserved"):
        register_force_model(ForceModel("auto", "", lambda h, p: SpringFloor()))
