"""A lab run re-exported in a cell's raw form, imported back with docs/examples/mapping.toml, and replayed.

The raw form is what a real cell hands over: the tracker in its own rotated and shifted frame (4 reference
points measured in both frames), millisecond time stamps on its own clock, semicolons and decimal commas, a
UTF-8 BOM; the force sensor in its own axes, in kN, with the tool's weight in the readings, on a clock that
starts 1.5 s before the robot moves. The example mapping in docs/ describes exactly these files.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.analysis.replay import ReplayResult, replay
from twin.runs.format import Run
from twin.runs.gravity import sensor_reading
from twin.runs.importer import ImportResult, import_to_directory
from twin.runs.read import read_run
from twin.sim.quasi_static import Twin

EXAMPLE_MAPPING = Path(__file__).resolve().parents[1] / "docs" / "examples" / "mapping.toml"

# The cell of the example mapping: p_tracker = R_TRACKER_SHEET p_sheet + T_TRACKER_SHEET_MM
R_TRACKER_SHEET = np.array(
    [
        [np.cos(0.61), -np.sin(0.61), 0.0],
        [np.sin(0.61), np.cos(0.61), 0.0],
        [0.0, 0.0, 1.0],
    ]
) @ np.array([[1.0, 0.0, 0.0], [0.0, np.cos(0.14), -np.sin(0.14)], [0.0, np.sin(0.14), np.cos(0.14)]])
T_TRACKER_SHEET_MM = np.array([1250.0, -430.0, 812.0])
REFERENCE_SHEET_MM = np.array(
    [[-100.0, -80.0, 0.0], [100.0, -80.0, 0.0], [100.0, 80.0, 0.0], [0.0, 0.0, 40.0]]
)
REFERENCE_NOISE_MM = 0.01
TRACKER_OFFSET_S = 73.456  # the tracker clock's reading when the commanded path starts
SENSOR_OFFSET_S = 12.345  # the sensor clock's reading when the commanded path starts
SENSOR_LEAD_IN_S = 1.5  # the sensor records this long before the robot moves
TRACKER_LEAD_IN_S = 1.0
R_SHEET_SENSOR = np.array(
    [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]
)  # sensor z along the tool, down
TOOL_MASS_KG = 3.2
GRAVITY = np.array([0.0, 0.0, -9.80665])


def reference_points_tracker_mm(seed: int = 7) -> np.ndarray:
    """The 4 reference points as the tracker measured them (its frame, 0.01 mm noise)."""
    rng = np.random.default_rng(seed)
    exact = REFERENCE_SHEET_MM @ R_TRACKER_SHEET.T + T_TRACKER_SHEET_MM
    return exact + rng.normal(0.0, REFERENCE_NOISE_MM, exact.shape)


def _decimal_comma(values: np.ndarray, digits: int) -> list[str]:
    return [f"{v:.{digits}f}".replace(".", ",") for v in values]


def write_raw_cell(run: Run, folder: Path, *, seed: int = 11) -> Path:
    """Write a run as a cell's raw exports (the files docs/examples/mapping.toml names)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    cmd_mm = run.commanded.values * 1e3
    lines = ["t [s],X [mm],Y [mm],Z [mm]"]
    lines += [
        f"{t:.6f},{x:.5f},{y:.5f},{z:.5f}" for t, (x, y, z) in zip(run.commanded.t_s, cmd_mm, strict=True)
    ]
    (folder / "robot_path.csv").write_text("\n".join(lines) + "\n")

    dt = run.tracker.median_interval_s
    lead = np.arange(-round(TRACKER_LEAD_IN_S / dt), 0) * dt
    p_lead = run.commanded.values[0] + rng.normal(0.0, 2e-5, (lead.size, 3))
    t_tr = np.concatenate([lead, run.tracker.t_s]) + TRACKER_OFFSET_S
    p_tr_mm = np.concatenate([p_lead, run.tracker.values]) * 1e3 @ R_TRACKER_SHEET.T + T_TRACKER_SHEET_MM
    lines = ["Krypton K600 export", "Marker TCP1", "Time [ms];Marker X [mm];Marker Y [mm];Marker Z [mm]"]
    for t, p in zip(_decimal_comma(t_tr * 1e3, 3), p_tr_mm, strict=True):
        lines.append(";".join([t, *_decimal_comma(p, 4)]))
    (folder / "tracker_export.txt").write_text("\ufeff" + "\n".join(lines) + "\n", encoding="utf-8")

    assert run.forces is not None
    dt = run.forces.median_interval_s
    lead = np.arange(-round(SENSOR_LEAD_IN_S / dt), 0) * dt
    f_lead = rng.normal(0.0, 5.0, (lead.size, 3))
    f_contact = np.concatenate([f_lead, run.forces.values])
    f_sensor = sensor_reading(f_contact, R_SHEET_SENSOR, TOOL_MASS_KG, GRAVITY)
    t_fs = np.concatenate([lead, run.forces.t_s]) + SENSOR_OFFSET_S
    lines = [
        ";".join([t, *_decimal_comma(f * 1e-3, 6)])
        for t, f in zip(_decimal_comma(t_fs * 1e3, 3), f_sensor, strict=True)
    ]
    (folder / "ft_sensor.csv").write_text("\n".join(lines) + "\n")

    assert run.part_profile is not None
    x_m, z_m = run.part_profile
    lines = ["x,z"] + [f"{x * 1e3:.4f},{z * 1e3:.4f}" for x, z in zip(x_m, z_m, strict=True)]
    (folder / "profile_scan.csv").write_text("\n".join(lines) + "\n")
    shutil.copy(EXAMPLE_MAPPING, folder / "mapping.toml")
    return folder / "mapping.toml"


FORCE_ONSET_CLOCK = '[forces.clock]\nmethod = "force_onset"\nmax_offset_s = 60\n\n'


@pytest.fixture(scope="module")
def imported(clean_run: Run, tmp_path_factory: pytest.TempPathFactory) -> tuple[ImportResult, Path]:
    """The clean lab run, exported raw, imported back with the example mapping (explicit clock offsets)."""
    folder = tmp_path_factory.mktemp("cell")
    mapping = write_raw_cell(clean_run, folder / "exports")
    result = import_to_directory(mapping, folder / "run")
    return result, folder


@pytest.fixture(scope="module")
def imported_onset(clean_run: Run, tmp_path_factory: pytest.TempPathFactory) -> ImportResult:
    """The same raw exports, the force sensor's clock found from the force onset instead."""
    folder = tmp_path_factory.mktemp("cell_onset")
    mapping = write_raw_cell(clean_run, folder / "exports")
    text = mapping.read_text()
    start, end = text.index("[forces.clock]"), text.index("[profile]")
    mapping.write_text(text[:start] + FORCE_ONSET_CLOCK + text[end:])
    return import_to_directory(mapping, folder / "run")


@pytest.fixture(scope="module")
def imported_replay(imported: tuple[ImportResult, Path], twin_nominal: Twin) -> ReplayResult:
    """The imported run replayed on the nominal twin."""
    return replay(read_run(imported[0].run.directory or ""), twin=twin_nominal)


def test_imported_run_replays_to_the_original_gap(
    imported_replay: ReplayResult, clean_replay: ReplayResult
) -> None:
    original, back = clean_replay.metrics, imported_replay.metrics
    assert back["position_rms_mm"] == pytest.approx(original["position_rms_mm"], rel=0.10)
    assert back["force_rms_n"] == pytest.approx(original["force_rms_n"], rel=0.10)
    assert back["deflection_max_mm"] == pytest.approx(original["deflection_max_mm"], rel=0.10)


def test_force_onset_finds_the_sensor_clock_and_the_position_gap_holds(
    imported_onset: ImportResult, clean_replay: ReplayResult, twin_nominal: Twin
) -> None:
    clock = imported_onset.report["clocks"]["forces"]
    assert clock["method"] == "force_onset" and clock["refined_on"] == "reversals"
    assert 0.0 < clock["sigma_s"] < 0.002
    # the statistical sigma and the fit's error are docs/import-export.md's (checked below)
    assert clock["offset_s"] == pytest.approx(SENSOR_OFFSET_S, abs=0.004)
    back = replay(read_run(imported_onset.run.directory or ""), twin=twin_nominal).metrics
    assert back["position_rms_mm"] == pytest.approx(clean_replay.metrics["position_rms_mm"], rel=0.10)
    # the force gap is very sensitive to the sensor clock (forces flip at each reversal)
    print(f"\nforce_onset clock: offset error {1e3 * (clock['offset_s'] - SENSOR_OFFSET_S):+.1f} ms, force gap "
          f"{back['force_rms_n']:.1f} N (explicit offset {clean_replay.metrics['force_rms_n']:.1f} N)")
    assert back["force_rms_n"] < 2.0 * clean_replay.metrics["force_rms_n"]
    # docs/import-export.md's "Measured": σ and how late, then the force gap, explicit offset -> force_onset
    sigma_ms, late_ms = quoted("import-export.md", "the sensor offset comes out with σ ≈", 2)
    sigma_ms.check(1e3 * clock["sigma_s"])
    late_ms.check(1e3 * (clock["offset_s"] - SENSOR_OFFSET_S))
    explicit, onset = quoted("import-export.md", "the force gap of the replay goes from", 2)
    explicit.check(clean_replay.metrics["force_rms_n"])
    onset.check(back["force_rms_n"])


def test_import_recovers_the_streams_in_the_sheet_frame(
    imported: tuple[ImportResult, Path], clean_run: Run
) -> None:
    run = read_run(imported[0].run.directory or "")
    np.testing.assert_allclose(run.commanded.values, clean_run.commanded.values, atol=1e-7)
    # tracker: same samples (explicit offset), registered back within the fit residual and the print precision
    assert len(run.tracker.t_s) == len(clean_run.tracker.t_s)
    np.testing.assert_allclose(run.tracker.t_s, clean_run.tracker.t_s, atol=2e-6)
    np.testing.assert_allclose(run.tracker.values, clean_run.tracker.values, atol=0.03e-3)
    # forces: tool weight and sensor axes removed (6 decimals in kN: 1 mN), same samples
    assert run.forces is not None and clean_run.forces is not None
    np.testing.assert_allclose(run.forces.t_s, clean_run.forces.t_s, atol=2e-6)
    np.testing.assert_allclose(run.forces.values, clean_run.forces.values, atol=2e-3)
    assert run.part_profile is not None and run.meta["scenario"] == "cell-example"


def test_import_reports_registration_and_clock_with_uncertainty(imported: tuple[ImportResult, Path]) -> None:
    report = imported[0].report
    reg = report["registration"]
    assert reg["points"] == 4
    assert 0.0 < reg["residual_rms_mm"] < 3 * REFERENCE_NOISE_MM
    quoted("import-export.md", "fit residual is about", 1)[0].check(reg["residual_rms_mm"])
    T = np.array(reg["T_sheet_tracker"])
    np.testing.assert_allclose(T[:3, :3], R_TRACKER_SHEET.T, atol=1e-4)
    assert report["clocks"]["tracker"]["offset_s"] == TRACKER_OFFSET_S
    assert report["clocks"]["forces"] == {
        "method": "offset",
        "offset_s": SENSOR_OFFSET_S,
        "sigma_s": 0.0,
        "refined_on": "",
    }


def test_import_never_modifies_its_inputs(
    imported: tuple[ImportResult, Path], clean_run: Run, tmp_path: Path
) -> None:
    fresh = write_raw_cell(clean_run, tmp_path / "exports")
    before = {p.name: p.read_bytes() for p in fresh.parent.iterdir()}
    for name, data in before.items():
        assert (imported[1] / "exports" / name).read_bytes() == data, name
