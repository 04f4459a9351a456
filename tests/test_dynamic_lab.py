"""The dynamic lab plant (twin.lab.dynamic): physics-made runs that the quasi-static twin replays."""

from __future__ import annotations

import ast
import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import twin
from twin.analysis.identify.cartesian import THESIS_TABLE_4_2_LOADS_N
from twin.analysis.replay import replay
from twin.base.signals import interp_rows
from twin.cli import main
from twin.errors import InputError
from twin.lab.dynamic.knobs import KNOBS, Knobs, parse_set_args
from twin.lab.dynamic.run import dynamic_load_test, run_dynamic_lab
from twin.lab.dynamic.sweep import breaking_feed, feed_sweep, sweep_table
from twin.process.description import Process
from twin.process.fe.load import default_force_history
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.runs.read import read_run
from twin.runs.write import write_run
from twin.sim.spec import TwinSpec

# the thesis groove's first three passes (same step-down and stroke reduction, 1 mm each): ~6 s of forming
SHORT = GrooveSpec(passes=3, depth_m=0.003, bottom_length_m=0.068)
DYNAMIC_DIR = Path(twin.__file__).resolve().parent / "lab" / "dynamic"
FORBIDDEN = ("twin.lab.effects", "twin.lab.measure", "twin.lab.virtual", "twin.sim", "twin.analysis")


def _short_run(tmp_path: Path, name: str, knobs: Knobs, seed: int = 11):
    path = groove_path(SHORT)
    run, truth, log = run_dynamic_lab(path.t_s, path.p_sheet_m, scenario="nominal", knobs=knobs, seed=seed)
    directory = write_run(tmp_path / name, run, truth=truth)
    return read_run(directory), log


def _reversal_times(run) -> np.ndarray:
    x = run.commanded.values[:, 0]
    return run.commanded.t_s[np.flatnonzero(np.diff(np.sign(np.diff(x))) != 0) + 1]


def _deflection_jumps_mm(run) -> np.ndarray:
    """Measured deviation (tracker - commanded) 0.1-0.3 s after each reversal minus 0.1-0.3 s before [mm]."""
    t = run.tracker.t_s
    dev = run.tracker.values - interp_rows(t, run.commanded.t_s, run.commanded.values)
    jumps = []
    for tr in _reversal_times(run):
        before = dev[(t > tr - 0.3) & (t < tr - 0.1)].mean(axis=0)
        after = dev[(t > tr + 0.1) & (t < tr + 0.3)].mean(axis=0)
        jumps.append(1e3 * np.linalg.norm(after - before))
    return np.array(jumps)


@pytest.fixture(scope="module")
def neutral_short(tmp_path_factory):
    run, log = _short_run(tmp_path_factory.mktemp("dyn"), "neutral", Knobs(neutral=True))
    return run, log, replay(run).metrics


def test_neutral_short_run_on_the_independent_plant_is_not_the_twin(neutral_short):
    """The plant's own sheet and gains: the twin no longer replays it within the noise (it did when the plant
    pressed against the twin's own field: 0.045 mm on these 3 passes; now 0.78 mm, docs/dynamic-plant.md)."""
    _, _, metrics = neutral_short
    sigma_mm = Knobs(neutral=True)["tracker_noise_mm"]
    assert metrics["position_rms_mm"] > 2.0 * math.sqrt(3.0) * sigma_mm  # 2x the noise's own 3-D rms
    assert metrics["force_rms_n"] > 0.02 * metrics["force_peak_measured_n"]
    # the robot really deflected: 0.68 mm measured (the membrane sheet builds up with depth: < 500 N in the first
    # 3 mm; the dependent plant's FE-history forces gave > 1 mm here)
    assert metrics["deflection_max_mm"] > 0.5


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="measured on the dependent plant; on the independent plant's 3-pass groove "
                   "(forces < 300 N) joint 3's gear torque does not reverse: to be re-derived on the full groove")
def test_dead_band_on_joint3_switches_flank_at_reversals_and_grows_the_replay_gap(tmp_path, neutral_short):
    neutral_run, _, neutral_metrics = neutral_short
    run, log = _short_run(tmp_path, "backlash", Knobs({"backlash_j3_mrad": 0.5}, neutral=True))
    half = 0.25e-3
    play = log.q_play[:, 2]
    assert play.max() == pytest.approx(half) and play.min() == pytest.approx(-half)  # both flanks touched
    # the gear torque of joint 3 reverses with the process force: the teeth cross the gap at the reversals
    crossings = log.t_s[np.flatnonzero(np.diff(np.sign(play)) != 0)]
    for t_rev in _reversal_times(run):
        assert np.min(np.abs(crossings - t_rev)) < 0.3
    jump_gain = _deflection_jumps_mm(run) - _deflection_jumps_mm(neutral_run)
    assert np.all(jump_gain > 0.2)  # b = 0.5 mrad on a ~0.9 m lever: ~0.4 mm more at each reversal
    assert replay(run).metrics["position_rms_mm"] >= 3.0 * neutral_metrics["position_rms_mm"]


def test_dead_band_on_joint2_stays_closed_on_the_gravity_flank(tmp_path, neutral_short):
    # gravity holds joint 2's gear at ~2.3 kN·m; the groove's process torque never reverses it here
    _, neutral_log, _ = neutral_short
    _, log = _short_run(tmp_path, "j2", Knobs({"backlash_j2_mrad": 0.2}, neutral=True))
    assert np.all(np.abs(log.q_play[:, 1]) == pytest.approx(0.1e-3))
    assert np.max(np.abs(log.p_tip_sheet_m - neutral_log.p_tip_sheet_m)) < 1e-6


@pytest.mark.xfail(strict=True, raises=AssertionError, reason="its 1.3x FE history no longer reaches the independent plant, and the "
                   "force-model gap hides the dead band's: to be re-derived with a stronger declared sheet")
def test_dead_band_on_joint2_opens_once_the_sheet_outweighs_gravity_on_joint2():
    """With 1.3x the FE forces (a thicker or harder sheet) the sheet's torque on joint 2 reaches gravity's."""
    history = default_force_history()
    history = replace(history, f_sheet_n=1.3 * history.f_sheet_n)
    path = groove_path()
    gaps, plays = [], []
    for band in (0.0, 0.3):
        run, _, log = run_dynamic_lab(
            path.t_s, path.p_sheet_m, scenario="nominal", knobs=Knobs({"backlash_j2_mrad": band}, neutral=True),
            seed=1, process=Process(history=history),
        )
        gaps.append(replay(run, TwinSpec(process=Process(history=history))).metrics["position_rms_mm"])
        plays.append(log.q_play[:, 1])
    half = 0.15e-3
    assert plays[1].max() == pytest.approx(half) and plays[1].min() == pytest.approx(-half)  # both flanks
    assert np.count_nonzero(np.diff(np.sign(plays[1])) != 0) >= 5  # 9 crossings measured
    assert gaps[1] >= 3.0 * gaps[0]  # 0.241 against 0.072 mm measured (3.4x; 0.2 mrad: 2.4x)


def test_dynamic_load_test_matches_the_static_deflection_of_the_plants_own_stiffness():
    """Without friction the plant's Method 1 deflection is the static one of ITS joint stiffness (the plant's own
    K_q, read from the plant here as only a test may), and differs from the twin's prior by more than the noise."""
    from twin.lab.dynamic.plant import build_plant

    knobs = Knobs({"tracker_noise_mm": 0.0, "link_friction_scale": 0.0}, neutral=True)
    loads, deflections = dynamic_load_test(THESIS_TABLE_4_2_LOADS_N, knobs=knobs, seed=3)
    k_plant = tuple(float(k) for k in build_plant(knobs).k_q)
    own = TwinSpec(joint_friction_nm=np.zeros(6), joint_stiffness_nm_per_rad=k_plant).build()
    expected = np.array([own.static_deflection(f) for f in loads])
    scale = np.max(np.linalg.norm(expected, axis=1))
    assert np.max(np.linalg.norm(deflections - expected, axis=1)) < 0.01 * scale
    prior = TwinSpec(joint_friction_nm=np.zeros(6)).build()
    off = np.array([prior.static_deflection(f) for f in loads])
    assert np.max(np.linalg.norm(deflections - off, axis=1)) > 0.03 * scale


def test_knobs_round_trip_into_truth_json_from_the_cli(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(
        [
            "lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "4", "--out", str(out),
            "--set", "backlash_j5_mrad=0.3", "--set", "ft_bias_n=-2.5",
        ]
    )  # fmt: skip
    assert code == 0
    truth = json.loads((out / "truth.json").read_text())
    assert set(truth["knobs"]) == set(KNOBS)
    assert truth["knobs"]["backlash_j5_mrad"] == 0.3 and truth["knobs"]["ft_bias_n"] == -2.5
    assert truth["knobs"]["tracker_latency_s"] == KNOBS["tracker_latency_s"].default
    assert truth["seed"] == 4 and truth["plant"] == "dynamic"
    run = read_run(out)
    assert run.meta["tracker_rate_hz"] == KNOBS["tracker_rate_hz"].default
    assert run.part_profile is not None
    assert 0.005 < -np.min(run.part_profile[1]) < 0.010  # formed, sprung back, shallower than the 10 mm plan
    captured = capsys.readouterr()
    assert "dynamic plant" in captured.out
    assert captured.err.count("s simulated") == 10  # a progress line every 10 %


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("backlash_j2_mrad", "expected NAME=VALUE"),
        ("bogus=1", "unknown knob 'bogus'"),
        ("tracker_noise_mm=abc", "expected a number"),
        ("timestep_s=0.01", "expected a finite value in"),
        ("ft_bias_n=nan", "expected a finite value in"),
    ],
)
def test_bad_set_is_refused_with_the_name_and_what_is_valid(item, message):
    with pytest.raises(InputError, match=message):
        parse_set_args([item])


def test_bad_set_on_the_cli_fails_before_simulating(tmp_path, capsys):
    out = tmp_path / "never"
    assert main(["lab", "--plant", "dynamic", "--scenario", "nominal", "--seed", "1", "--out", str(out),
                 "--set", "servo_damping_ratio=-1"]) != 0  # fmt: skip
    assert "servo_damping_ratio" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(InputError, match="given twice"):
        parse_set_args(["ft_bias_n=1", "ft_bias_n=2"])


def test_dynamic_plant_code_does_not_import_the_twin_or_the_effect_library():
    offenders = []
    for path in sorted(DYNAMIC_DIR.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            for name in names:
                if any(name == bad or name.startswith(bad + ".") for bad in FORBIDDEN):
                    offenders.append(f"{path.name}:{node.lineno} imports {name}")
    assert not offenders, offenders
    assert len(list(DYNAMIC_DIR.glob("*.py"))) >= 6  # the check saw the package


def test_the_documented_knob_table_is_the_plants_knobs():
    """docs/dynamic-plant.md's knob table: one row per knob, with its default, neutral value, unit, range and text."""
    doc = (Path(__file__).resolve().parents[1] / "docs" / "dynamic-plant.md").read_text(encoding="utf-8")
    rows = {m[0]: m[1:] for m in re.findall(r"^\| `(\w+)` \| (\S+) \| (\S+) \| (\S+) \| \[(\S+), (\S+)\] \| (.+) \|$",
                                            doc, flags=re.MULTILINE)}
    assert set(rows) == set(KNOBS)
    for name, spec in KNOBS.items():
        default, neutral, unit, low, high, text = rows[name]
        assert (float(default), float(neutral), float(low), float(high)) == (
            spec.default, spec.neutral, spec.minimum, spec.maximum), name
        assert (unit, text) == (spec.unit, spec.doc), name


def _documented_independent_plant() -> dict[str, float]:
    """The numbers docs/dynamic-plant.md states as measured against the independent plant (its guarded block)."""
    doc = (Path(__file__).resolve().parents[1] / "docs" / "dynamic-plant.md").read_text(encoding="utf-8")
    block = doc.split("<!-- independent-plant:begin")[1].split("<!-- independent-plant:end")[0]
    return {m[0]: float(m[1]) for m in re.findall(r"`(\w+)` = ([\d.]+)", block)}


def test_full_groove_neutral_run_on_the_independent_plant_gives_the_documented_gap(tmp_path):
    """The whole thesis groove at 2 m/min, every knob neutral, seed 1, on the plant's own sheet and gains: the
    replay gap as it comes out, held to docs/dynamic-plant.md (no bound chosen; the twin's `table` force
    model is not the plant's membrane sheet, so the gap is far above the tracker noise)."""
    path = groove_path()
    run, truth, _ = run_dynamic_lab(
        path.t_s, path.p_sheet_m, scenario="nominal", knobs=Knobs(neutral=True), seed=1
    )
    run = read_run(write_run(tmp_path / "full", run, truth=truth))
    metrics = replay(run).metrics
    doc = _documented_independent_plant()
    assert metrics["position_rms_mm"] == pytest.approx(doc["position_rms_mm"], abs=0.0005)
    assert metrics["position_max_mm"] == pytest.approx(doc["position_max_mm"], abs=0.0005)
    assert metrics["force_rms_n"] == pytest.approx(doc["force_rms_n"], abs=0.05)
    assert metrics["force_peak_measured_n"] == pytest.approx(doc["force_peak_measured_n"], abs=0.5)
    assert truth["peak_force_n"] == pytest.approx(doc["plant_peak_force_n"], abs=0.5)
    # the plant is not the twin: its force differs from the twin's by far more than 2 % of the peak
    assert metrics["force_rms_n"] > 0.02 * metrics["force_peak_measured_n"]


def test_commanded_stream_carries_the_controller_stops_at_reversals(neutral_short):
    run, _, _ = neutral_short
    t, p = run.commanded.t_s, run.commanded.values
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(t)
    feed = 2.0 / 60.0
    assert speed.max() <= 1.001 * feed  # the programmed path is 2 m/min within 0.02 %
    rev = np.flatnonzero(np.diff(np.sign(np.diff(p[:, 0]))) != 0) + 1
    for k in rev:  # the segments next to a reversal are slow: the tool comes to rest there
        assert speed[k - 1] < 0.5 * feed and speed[k] < 0.5 * feed


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=AssertionError, reason="measured on the dependent plant; on the independent plant the twin is not "
                   "within the noise in the strokes at 2 m/min either (its force model is not the plant's sheet)")
def test_feed_sweep_finds_the_twin_breaking_at_high_feed():
    rows = feed_sweep(replay, feeds_m_per_min=(2.0, 20.0), spec=SHORT, seed=5)
    slow_row, fast_row = rows
    assert slow_row.position_away_mm <= slow_row.position_limit_mm  # quasi-static in the strokes at 2 m/min
    assert fast_row.position_away_mm > 5.0 * fast_row.position_limit_mm
    assert breaking_feed(rows) is not None and breaking_feed(rows) <= 20.0
    assert "| 20 |" in sweep_table(rows)


@pytest.mark.slow
def test_the_documented_feed_sweep_is_the_independent_plants():
    """docs/dynamic-plant.md's feed-sweep table, as `experiments/dynamic_feed_sweep.py` prints it (seed 7)."""
    table = sweep_table(feed_sweep(replay, seed=7))
    doc = (Path(__file__).resolve().parents[1] / "docs" / "dynamic-plant.md").read_text(encoding="utf-8")
    assert table.strip() in doc


@pytest.mark.slow
def test_discrepancy_on_the_independent_plant_says_unexplained(tmp_path, capsys):
    """`discrepancy` on the full neutral groove of the independent plant: what docs/dynamic-plant.md reports."""
    path = groove_path()
    run, truth, _ = run_dynamic_lab(path.t_s, path.p_sheet_m, scenario="nominal", knobs=Knobs(neutral=True), seed=1)
    directory = write_run(tmp_path / "full", run, truth=truth)
    capsys.readouterr()
    assert main(["discrepancy", str(directory), "--json", "-"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert found["effect"] == "unexplained" and found["explained_fraction"] == 0.0
    best = found["candidates"][0]
    assert best["name"] == "force_scale" and best["explained_fraction"] == pytest.approx(0.225, abs=0.005)
    assert best["parameters"]["scale_x_ratio"] == pytest.approx(0.29, abs=0.005)
    assert best["parameters"]["scale_z_ratio"] == pytest.approx(0.85, abs=0.005)
    words = " ".join(axis["words"] for axis in found["remainder"]["axes"])
    for phrase in ("a +/-276 N offset that flips with the travel direction", "a trend of 63.4 N/s",
                   "a 0.24 Hz oscillation of 0.591 mm", "a +/-0.379 mm offset that flips",
                   "0.913 mm rms along the groove"):
        assert phrase in words, words
