"""The dynamic twin (`twin.sim.dynamic`) and its servo fit (`twin.analysis.learn.servo_fit`).

- Physics: with a rigid or a stiff servo, on a slow path (slow feed, gentle stops), the moving arm's tip is the
  quasi-static twin's within `SLOW_RMS_M` rms (the arm's inertia, a/ω² ~ 1 µm at these stops, and the friction
  constraint's slip are all that is left).
- Identification: a servo written here (each joint's motor following its reference through the closed loop
  (a s³ + (2ζ+1)ω s² + (2ζ+1)ω² s + ω³) / ((s + ω)(s² + 2ζω s + ω²)), delayed by d, simulated with
  `scipy.signal.lsim` on a rigid arm, its tip moved by J (θ − r)) makes a synthetic run; `fit_servo` finds β, ζ
  and d again within `FOUND` (the feed-forward share a trades against ζ on so short a run and is not checked).
- Neither module imports the plant (`twin.lab`).
"""

from __future__ import annotations

import ast
import itertools
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted
from scipy import signal

from twin.analysis.learn.servo_fit import corner_indices, dynamic_replay, fit_servo, near_corners, stop_lag
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.process.description import Process
from twin.runs.format import Run, Stream, run_meta
from twin.runs.write import write_run
from twin.sim.dynamic import DynamicTwin, ServoModel, references
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.spec import TwinSpec

REPO = Path(__file__).resolve().parents[1]
#: The slow path's tip gap, dynamic (stiff servo) to quasi-static [m]: a fifth of its deflection under the sheet or less.
SLOW_RMS_M = 20e-6
#: The servo the test writes, and how close the fit must come: relative on β and ζ, absolute on d [s].
TRUE = {"bandwidth_over_mode": 0.3, "damping_ratio": 0.9, "delay_s": 0.008}
FOUND = {"bandwidth_over_mode": 0.15, "damping_ratio": 0.25, "delay_s": 0.002}
#: How far the loop gives way to a rising load, beyond a rigid servo, at least: a share of the springs' deflection.
GIVE_WAY = 0.4


def square(side_m: float, z_m: float, feed_mps: float, accel_mps2: float, dt_s: float) -> tuple[np.ndarray, ...]:
    """A square contour with a stop at each corner (constant acceleration into and out of it): times, tips."""
    corners = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1], [1, 1]]) * side_m / 2
    times, tips, t = [], [], 0.0
    for a, b in itertools.pairwise(corners):
        length, ramp = float(np.linalg.norm(b - a)), feed_mps / accel_mps2
        cruise = (length - feed_mps * ramp) / feed_mps
        total = 2 * ramp + cruise
        ts = np.arange(0.0, total, dt_s)
        s = np.where(ts < ramp, 0.5 * accel_mps2 * ts**2,
                     np.where(ts < ramp + cruise, 0.5 * feed_mps * ramp + feed_mps * (ts - ramp),
                              length - 0.5 * accel_mps2 * np.clip(total - ts, 0, None) ** 2))
        times.append(t + ts)
        tips.append(a + np.outer(s / length, b - a))
        t += total
    xy = np.concatenate([*tips, corners[-1:]])
    return np.r_[np.concatenate(times), t], np.column_stack([xy, np.full(len(xy), z_m)])


@pytest.fixture(scope="module")
def isf_twin():  # type: ignore[no-untyped-def]
    return TwinSpec(process=Process(force_model="isf")).build()


@pytest.mark.parametrize("servo", [ServoModel(math.inf, 1.0, 0.0), ServoModel(1.5, 1.0, 0.0)],
                         ids=["rigid", "stiff"])
def test_a_stiff_servo_on_a_slow_path_lands_on_the_quasi_static_tip(isf_twin, servo: ServoModel) -> None:
    t, p = square(0.01, -5e-4, 0.005, 0.05, 0.01)
    sim = isf_twin.simulate(t, p)
    deflection = np.sqrt(np.mean(np.sum((sim.p_sheet_m - sim.p_unloaded_sheet_m) ** 2, axis=1)))
    assert deflection > 5 * SLOW_RMS_M  # the sheet loads the arm: the check is not of an unloaded arm
    moved = DynamicTwin(isf_twin, sim).simulate(servo)
    gap = np.linalg.norm(moved.p_sheet_m - sim.p_sheet_m, axis=1)
    assert np.sqrt(np.mean(gap**2)) < SLOW_RMS_M
    assert moved.p_cmd_sheet_m is sim.p_cmd_sheet_m and moved.qpos.shape == sim.qpos.shape


def test_the_loop_takes_the_sheets_load_through_its_integral() -> None:
    """A controller knows its arm's gravity, not the sheet's force. The command goes 0.7 mm into the sheet over
    0.2 s and the arm is driven by the force the quasi-static replay found there (`forces`, as a run's measured ones):
    the motors give way while the load rises, so the tip leaves a rigid servo's by more than `GIVE_WAY` of the
    springs' deflection (fed the quasi-static load forward, as the loop first was, by 0.25 of it), and the integral
    then brings it back onto the rigid servo's tip."""
    twin = TwinSpec(process=Process(force_model="isf"), joint_friction_nm=(0.0,) * 6).build()
    t = np.arange(0.0, 2.0, 0.004)
    sim = twin.simulate(t, np.column_stack([0 * t, 0 * t, np.interp(t, [0, 0.5, 0.7, 2], [2e-4, 2e-4, -5e-4, -5e-4])]))
    assert sim.f_sheet_n[t < 0.49, 2].max() < 1e-6 and sim.f_sheet_n[-1, 2] > 50.0
    arm = DynamicTwin(twin, sim, forces=(t, sim.f_sheet_n))
    rigid = arm.simulate(ServoModel(math.inf, 1.0, 0.0)).p_sheet_m
    gap = np.linalg.norm(arm.simulate(ServoModel(0.5, 0.8, 0.0)).p_sheet_m - rigid, axis=1)
    springs = float(np.linalg.norm(sim.p_sheet_m[-1] - sim.p_unloaded_sheet_m[-1]))
    assert springs > 1e-5
    assert gap.max() > GIVE_WAY * springs  # the motors gave way
    assert gap[-1] < 0.01 * springs  # and the integral took the load up


def _servo_written_here(twin, t: np.ndarray, sim, mode_rad_s: np.ndarray, joint_inertia: np.ndarray | None = None,
                        force=None) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """The tip of a rigid arm whose motors follow their references through the test's own servo (TRUE); with
    `force` (a function of time, sheet frame [N]) the springs also bend under it and each motor gives way to its
    load torque tau through the same loop, theta / tau = s / (J (s + w)(s^2 + 2 zeta w s + w^2)), until the integral
    takes it up (J: `joint_inertia`)."""
    beta, zeta, delay = TRUE["bandwidth_over_mode"], TRUE["damping_ratio"], TRUE["delay_s"]
    arm = twin.robot.addresses(twin.model).qpos
    ref = references(twin, sim)[:, arm]
    fine = np.arange(t[0], t[-1], 1e-3)
    q = np.column_stack([np.interp(fine, t, sim.q_ik[:, j]) for j in range(len(arm))])
    jac = np.einsum("ki,nkj->nij", twin.R_base_sheet, twin.kinematics.jacobians(q)[:, :3, :])  # sheet frame
    tau = np.zeros((len(fine), len(arm))) if force is None else np.einsum("nij,ni->nj", jac, force(fine))
    moved = np.empty((len(fine), len(arm)))
    for j, w in enumerate(beta * mode_rad_s):
        poles = np.polymul([1, w], [1, 2 * zeta * w, w**2])
        loop = ([(2 * zeta + 1) * w, (2 * zeta + 1) * w**2, w**3], poles)
        r = np.interp(fine - delay, t, ref[:, j])
        moved[:, j] = r[0] + signal.lsim(loop, r - r[0], fine)[1] - np.interp(fine, t, ref[:, j])
        if force is not None:
            assert joint_inertia is not None
            give = signal.lsim(([1.0, 0.0], joint_inertia[j] * poles), tau[:, j], fine)[1]
            moved[:, j] += give + tau[:, j] / twin.joint_stiffness[j]
    tip = np.column_stack([np.interp(fine, t, sim.p_sheet_m[:, j]) for j in range(3)])
    return fine, tip + np.einsum("nij,nj->ni", jac, moved)


def test_fit_servo_finds_a_servo_written_in_the_test_again(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    twin = TwinSpec(process=Process(force_model="isf"), joint_friction_nm=(0.0,) * 6).build()
    t, p = square(0.02, 1e-3, 0.0333, 0.5, 0.004)  # above the sheet: the servo alone moves the tip
    sim = twin.simulate(t, p)
    dynamic = DynamicTwin(twin, sim)
    fine, tip = _servo_written_here(twin, t, sim, dynamic.mode_rad_s)
    t_k = np.arange(0.0, t[-1], 0.02)
    tracker = np.column_stack([np.interp(t_k, fine, tip[:, j]) for j in range(3)])
    meta = run_meta(scenario="nominal", source="test: a servo written in the test", tracker_rate_hz=50.0,
                    sensor_rate_hz=30.0, seed=0, tool_length_m=twin.robot.tool_length_m, robot=twin.robot.name)
    run = Run(None, meta, Stream(t, p), Stream(t_k, tracker))
    assert len(corner_indices(p)) == 3 and near_corners(run, 2e-3).any()
    assert 0.0 <= stop_lag(run) <= 0.05
    # `replay --dynamic` fits the servo (`fit_servo`) on the run's folder, reported beside the quasi-static gap
    model = write_model_file(tmp_path / "m.json", TwinSpec(process=Process(force_model="isf"),
                                                           joint_friction_nm=(0.0,) * 6))
    t_f = np.arange(0.0, t[-1], 1.0 / 30.0)  # the F/T above the sheet reads nothing
    written = write_run(tmp_path / "run", replace(run, forces=Stream(t_f, np.zeros((len(t_f), 3)))))
    assert main(["replay", str(written), "--model", str(model), "--dynamic", "--json", "-"]) == 0
    report = json.loads(capsys.readouterr().out)
    fitted = report["dynamic_servo"]
    assert fitted.pop("fitted_on_this_run")
    for name, truth in TRUE.items():
        tol = FOUND[name] if name == "delay_s" else FOUND[name] * truth
        assert fitted[name] == pytest.approx(truth, abs=tol), f"{name}: found {fitted[name]:.4g}, wrote {truth}"
    servo = ServoModel(**fitted)
    rigid = dynamic_replay(run, dynamic, ServoModel(math.inf, 1.0, 0.0)).metrics["position_rms_mm"]
    assert report["quasi_static_position_rms_mm"] == pytest.approx(rigid, rel=0.5)
    assert report["position_rms_mm"] < 0.3 * rigid  # the fitted servo explains most of what a rigid one leaves
    replayed = dynamic_replay(run, dynamic, servo)
    assert replayed.metrics["position_rms_mm"] == pytest.approx(report["position_rms_mm"], rel=0.05)
    carried = write_model_file(tmp_path / "carried.json", replace(read_model_file(model), dynamic_servo=servo))
    assert read_model_file(carried).dynamic_servo == servo
    assert main(["replay", str(written), "--model", str(carried), "--dynamic", "--json", "-"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert not again["dynamic_servo"]["fitted_on_this_run"]
    assert again["position_rms_mm"] == pytest.approx(replayed.metrics["position_rms_mm"], rel=0.05)
    # `--forces measured` beside it: the robot's part with the arm moving, here under no force (above the sheet),
    # is the dynamic replay's own gap; the quasi-static robot's part misses the servo's lag
    assert main(["replay", str(written), "--model", str(carried), "--dynamic", "--forces", "measured",
                 "--json", "-"]) == 0
    split = json.loads(capsys.readouterr().out)
    assert split["robot_gap_moving_rms_mm"] == pytest.approx(again["position_rms_mm"], rel=0.05)
    assert split["robot_gap_rms_mm"] > 2 * split["robot_gap_moving_rms_mm"]


def test_fit_servo_driven_by_a_fast_streams_forces_finds_the_loop_that_gives_way_to_them() -> None:
    """Above the sheet, a force of the test's making pushes the tool (steps of Fz, a slow swing of Fx) and a 500 Hz
    F/T stream measures it: `fit_servo` drives the arm by it (the stream is fast enough, `MEASURED_FORCES_MIN_HZ`)
    and finds the loop written here again; driven by the twin's own sheet, which pushes nowhere above the sheet, the
    same fit cannot see the force and misses the tracker by more."""
    twin = TwinSpec(process=Process(force_model="isf"), joint_friction_nm=(0.0,) * 6).build()
    t, p = square(0.02, 1e-3, 0.0333, 0.5, 0.004)
    sim = twin.simulate(t, p)
    dynamic = DynamicTwin(twin, sim)

    def force(at: np.ndarray) -> np.ndarray:
        fz = 150.0 + 100.0 * np.sum([np.tanh((at - s) / 0.02) for s in (0.3, 0.9, 1.6, 2.2)], axis=0)
        return np.column_stack([60.0 * np.sin(2 * np.pi * 0.7 * at), 0 * at, fz])

    fine, tip = _servo_written_here(twin, t, sim, dynamic.mode_rad_s, dynamic.joint_inertia, force)
    t_k, t_f = np.arange(0.0, t[-1], 0.02), np.arange(0.0, t[-1], 0.002)
    tracker = np.column_stack([np.interp(t_k, fine, tip[:, j]) for j in range(3)])
    meta = run_meta(scenario="nominal", source="test: a loop that gives way, written in the test",
                    tracker_rate_hz=50.0, sensor_rate_hz=500.0, seed=0, tool_length_m=twin.robot.tool_length_m,
                    robot=twin.robot.name)
    run = Run(None, meta, Stream(t, p), Stream(t_k, tracker), Stream(t_f, force(t_f)))
    fit = fit_servo(run, twin, max_evaluations=30)
    assert fit.measured_forces and fit.servo.load_feedforward == 0.0
    for name, truth in TRUE.items():
        found = getattr(fit.servo, name)
        tol = FOUND[name] if name == "delay_s" else FOUND[name] * truth
        assert found == pytest.approx(truth, abs=tol), f"{name}: found {found:.4g}, wrote {truth}"
    assert fit.rms_mm < 0.3 * fit.rms_rigid_mm
    blind = fit_servo(run, twin, max_evaluations=10, measured_forces=False)
    assert not blind.measured_forces and blind.rms_mm > 2 * fit.rms_mm


def test_the_model_file_refuses_a_bad_dynamic_servo(tmp_path: Path) -> None:
    path = write_model_file(tmp_path / "m.json", TwinSpec(dynamic_servo=ServoModel(0.5, 1.2, 0.01, 0.3)))
    payload = json.loads(path.read_text())
    assert payload["dynamic_servo"] == {"bandwidth_over_mode": 0.5, "damping_ratio": 1.2, "delay_s": 0.01,
                                        "feedforward": 0.3, "load_feedforward": 0.0}
    # a file written before the load's share existed was fitted with the twin's load fed forward: read so
    legacy = {key: value for key, value in payload["dynamic_servo"].items() if key != "load_feedforward"}
    (tmp_path / "legacy.json").write_text(json.dumps({**payload, "dynamic_servo": legacy}))
    assert read_model_file(tmp_path / "legacy.json").dynamic_servo == ServoModel(0.5, 1.2, 0.01, 0.3, 1.0)
    for bad, words in (({"bandwidth_over_mode": 0.5}, "dynamic_servo = .*expected an object with the numbers"),
                       ({**payload["dynamic_servo"], "delay_s": "1"}, "expected an object with the numbers"),
                       ({**payload["dynamic_servo"], "damping_ratio": -1.0}, "ServoModel.damping_ratio = -1.0")):
        (tmp_path / "bad.json").write_text(json.dumps({**payload, "dynamic_servo": bad}))
        with pytest.raises(DataFileError, match=words) as err:
            read_model_file(tmp_path / "bad.json")
        assert "bad.json" in str(err.value)


def test_a_servo_out_of_its_range_is_refused() -> None:
    for bad in ({"bandwidth_over_mode": 0.0}, {"damping_ratio": math.nan}, {"delay_s": -0.01},
                {"feedforward": 1.5}, {"load_feedforward": -0.1}):
        with pytest.raises(InputError, match=next(iter(bad))):
            ServoModel(**bad)


@pytest.mark.parametrize("module", ["twin/sim/dynamic.py", "twin/analysis/learn/servo_fit.py"])
def test_the_dynamic_twin_imports_nothing_from_the_plant(module: str) -> None:
    tree = ast.parse((REPO / module).read_text(encoding="utf-8"))
    imported = [node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)]
    imported += [alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names]
    assert imported and not [name for name in imported if name == "twin.lab" or name.startswith("twin.lab.")]


def test_the_page_holds_its_generated_table_and_what_its_words_say_of_it() -> None:
    page = (REPO / "docs" / "dynamic-twin.md").read_text(encoding="utf-8")
    begin = page.index("<!-- dynamic-twin:begin (generated by experiments/dynamic_twin_study.py; do not edit) -->")
    block = page[begin:page.index("<!-- dynamic-twin:end -->")]
    rows = [line.split("|")[1:-1] for line in block.splitlines() if line.startswith("| TX200")]
    replays, fits = [r for r in rows if len(r) == 5], [r for r in rows if len(r) == 12]
    # "The plant's own servo": the page's numbers first, then what it says of them
    default, variant = fits
    quoted("dynamic-twin.md", "without inertial feed-forward (ζ", 1)[0].check(float(default[2]))
    beta, zeta = quoted("dynamic-twin.md", "to a lower β and ζ (", 2)
    beta.check(float(variant[1]))
    zeta.check(float(variant[2]))
    for q, r in zip(quoted("dynamic-twin.md", "load forward (b", 2), (default, variant), strict=True):
        q.check(float(r[5]))
    fit = quoted("dynamic-twin.md", "and a fit runs", 4)  # "Speed": the fits' replays and walls
    for k, column in enumerate((9, 10)):
        fit[2 * k].check(min(float(r[column]) for r in fits))
        fit[2 * k + 1].check(max(float(r[column]) for r in fits))
    assert len(replays) == 6 and {r[0].strip() for r in replays} == {r[0].strip() for r in fits}
    for r in replays:  # "the corner rows are larger than the whole-run rows for both twins alike"
        for cell in (r[2], r[3]):
            whole, corners = (float(v) for v in cell.split("/"))
            assert corners > whole
    # "Speed": a dynamic replay five to eight times the quasi-static one; a fit of 93 to 170 of them in 55 to 94 s
    walls = {(r[0].strip(), r[1].strip()): r[4].strip() for r in replays}
    for cell in {key[0] for key in walls}:
        ratio = (float(walls[(cell, "dynamic, servo fitted on run 1")])
                 / float(walls[(cell, "quasi-static (learned, its servo transient)")]))
        assert 5.0 <= ratio <= 8.0, (cell, ratio)
    assert all(90 <= int(r[9]) <= 170 and 50 <= float(r[10]) <= 100 for r in fits), fits
    # the default servo's fit over-damped, the variant's lower; no load fed forward
    assert all(float(r[5]) < 0.05 for r in fits), fits
    assert float(default[2]) > 1.0 and float(default[4]) < 0.1
    assert float(variant[1]) < float(default[1]) and float(variant[2]) < float(default[2])


def test_learn_dynamic_writes_no_servo_where_the_learned_arm_does_not_step(
    clean_run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Where the learned arm diverges (here the fit is made to say so), `learn --dynamic` writes the model without a
    dynamic servo and the report says why (exit 0: the quasi-static twin is learned)."""
    import twin.analysis.learn.servo_fit as servo_fit

    def diverges(*args: object, **kwargs: object) -> None:
        raise InputError("the dynamic twin diverged (its tip more than 50 mm from the quasi-static one)")

    monkeypatch.setattr(servo_fit, "fit_servo", diverges)
    out = tmp_path / "m.json"
    assert main(["learn", str(clean_run_dir), "--dynamic", "--write-model", str(out), "--json", "-"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert "diverged" in report["dynamic_servo"]
    assert "dynamic_servo" not in json.loads(out.read_text())


@pytest.mark.slow
def test_learn_dynamic_carries_the_servo_for_replay(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """On the dynamic plant's TX200 pyramid: `learn --dynamic` writes the servo, `replay --dynamic` of another
    seed uses it (predicted) and reports the quasi-static gap beside it."""
    path = tmp_path / "pyramid.csv"
    assert main(["path", "--shape", "pyramid", "--depth-mm", "3", "--robot", "tx200", "--out", str(path)]) == 0
    runs = []
    for seed in (1, 2):
        runs.append(tmp_path / f"run{seed}")
        assert main(["lab", "--plant", "dynamic", "--robot", "tx200", "--scenario", "nominal", "--seed", str(seed),
                     "--commanded", str(path), "--out", str(runs[-1])]) == 0
    model = tmp_path / "cell.json"
    assert main(["learn", str(runs[0]), "--dynamic", "--write-model", str(model)]) == 0
    servo = json.loads(model.read_text())["dynamic_servo"]
    capsys.readouterr()
    assert main(["replay", str(runs[1]), "--model", str(model), "--dynamic", "--json", "-"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert not report["dynamic_servo"]["fitted_on_this_run"]
    assert report["dynamic_servo"]["damping_ratio"] == pytest.approx(servo["damping_ratio"], rel=1e-9)
    assert report["position_rms_mm"] < 1.5 * report["quasi_static_position_rms_mm"]
