"""Each shipped robot through the whole pipeline (`experiments/robot_tour.py`): a 45° cone, Ø 60 mm, 10 mm deep,
compensated by the twin and formed on both plants; Method 1 and Method 2 on lab runs; a sheet 30 % stronger than
declared, formed on the dynamic plant (not through the effect library) and its own sheet, put to `discrepancy`; a
program in the robot's language. Slow (about 35 s a robot): `make test-slow`.
The numbers of the note and docs/robots.md come from these runs."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from twin.robot.description import load_robot, shipped_robots

_SPEC = importlib.util.spec_from_file_location(
    "robot_tour", Path(__file__).resolve().parent.parent / "experiments" / "robot_tour.py")
assert _SPEC is not None and _SPEC.loader is not None
robot_tour = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(robot_tour)

LANGUAGE_FORMAT = {"VAL3": "val3", "KRL": "krl", "RAPID": "rapid"}


#: Found when the slow set was run whole (CHANGELOG): on the IRB 6640 `discrepancy` names the stronger sheet a force
#: sensor's gain (its run's measured force high against the twin's declared sheet; the plant's arm, whose stiffness is
#: its own, bends otherwise than the twin's prior, so the force scale that would bend the twin's arm with it explains
#: less). A robot-side mismatch read as the sensor's: open.
SENSOR_READ = pytest.mark.xfail(strict=True, raises=AssertionError,
                                reason="irb6640: discrepancy names force_sensor_gain for a stronger sheet")


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=SENSOR_READ) if n == "irb6640" else n
                                  for n in sorted(shipped_robots())])
def test_each_robot_goes_through_the_whole_pipeline(name: str, tmp_path: Path) -> None:
    summary = robot_tour.tour(name, tmp_path)
    print(f"\n{name}: {summary}")
    compensated = summary["quasi-static/compensated_rms_mm"]
    assert compensated < 0.1 and summary["quasi-static/nominal_rms_mm"] > 8 * compensated
    # the dynamic plant forms its own sheet (twin/lab/dynamic/sheet.py), not the twin's: the twin's compensation
    # helps there, but does not reach the noise (the test prints the numbers)
    assert summary["dynamic/compensated_rms_mm"] < summary["dynamic/nominal_rms_mm"]
    assert summary["method1_compliance_error"] < 0.2  # joint friction biases a load test from rest (thesis §4.1.3)
    assert summary["method2_rollout_kq_max_error"] < 0.02
    # the stronger sheet on that plant mixes with the plant's own force model: `discrepancy` says `unexplained` or a
    # force scale (the plant's sheet against the twin's model), never a robot-side or sensor family
    found = summary["discrepancy"]
    assert found["named"] in ("unexplained", "force_scale")
    if found["named"] == "force_scale":
        assert found["gap_after_mm"] < 0.5 * found["gap_before_mm"]
    assert summary["program"]["format"] == LANGUAGE_FORMAT[load_robot(name).language]
