"""`check` not fooled by the tracker's registration error (#47): `check --model CELL.json` takes off the
registration the learned cell carries (`learn` fits it against the twin's replay of the cell's runs), `check
--free-moves` one that `twin.analysis.tracker_frame` fits on the run's free moves.

The "true tip" of a dynamic-plant run is measured here only: the same command, seed and knobs run again with the
registration knobs at 0 (the plant's physics and its noise draws are the same; only the tracker's frame
differs). Thresholds chosen before the runs: the registration recovered within 0.03 mm of shift and 0.3 mrad of
each fixed rotation component; residuals and gains judged with it taken off within 0.03 mm and 0.03 of the true
tip's.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from twin.analysis.check import check_run
from twin.analysis.tracker_frame import TrackerRegistration, fit_on_free_moves, take_off
from twin.cli import main
from twin.runs.format import Run, Stream
from twin.runs.read import read_run

NO_REGISTRATION = ["--set", "tracker_reg_mm=0", "--set", "tracker_reg_mrad=0"]


def _lab(out: Path, *extra: str) -> Path:
    assert main(["lab", "--plant", "dynamic", "--overwrite", "--out", str(out), *extra]) == 0
    return out


@pytest.fixture(scope="module")
def groove(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The dynamic plant's groove, nominal and compensated by the (untaught) twin, each with the default tracker
    registration and with none."""
    base = tmp_path_factory.mktemp("registration")
    ideal, command = base / "groove.csv", base / "cmd.csv"
    assert main(["path", "--out", str(ideal)]) == 0
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--out", str(command)]) == 0
    runs = {"ideal": ideal}
    for name, scenario in (("nominal", ["--scenario", "nominal", "--seed", "1"]),
                           ("compensated", ["--scenario", "compensated", "--commanded", str(command), "--seed", "2"])):
        runs[name] = _lab(base / name, *scenario)
        runs[f"{name}_true"] = _lab(base / f"{name}_true", *scenario, *NO_REGISTRATION)
    return runs


def test_a_registration_written_onto_the_tracker_is_recovered_and_taken_off(groove: dict[str, Path]) -> None:
    """The test's own registration (not the plant's axes) written onto a run with none: the free moves of the
    groove's first two passes fix the shift and the rotation about y and z (about x the groove, 1 mm deep,
    gives no lever), and taking it off restores the tracker."""
    clean = read_run(groove["nominal_true"])
    rotation, shift = np.array([0.0, 0.8e-3, -0.6e-3]), np.array([-0.15e-3, 0.25e-3, 0.1e-3])
    edited = Run(clean.directory, clean.meta, clean.commanded,
                 Stream(clean.tracker.t_s, clean.tracker.values @ Rotation.from_rotvec(rotation).as_matrix().T + shift), clean.forces)
    fitted = fit_on_free_moves(edited)
    assert fitted is not None and "free moves" in fitted.source
    print(f"fitted rotation {1e3 * fitted.rotation_rad} mrad, shift {1e3 * fitted.shift_m} mm, "
          f"rms {1e3 * (fitted.rms_m or 0.0):.3f} mm, {fitted.source}")
    assert np.all(np.abs(fitted.shift_m - shift) < 0.03e-3)
    assert np.all(np.abs(fitted.rotation_rad[1:] - rotation[1:]) < 0.3e-3)
    restored = take_off(edited, fitted).tracker.values - clean.tracker.values
    assert float(np.sqrt(np.mean(np.sum(restored**2, axis=1)))) < 0.03e-3
    exact = take_off(edited, TrackerRegistration(rotation, shift, "the test"))
    np.testing.assert_allclose(exact.tracker.values, clean.tracker.values, atol=1e-9)


def test_the_quasi_static_groove_has_no_free_moves_and_check_says_so(clean_run: Run, clean_run_dir: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """The quasi-static lab loads the tool from its second sample: nothing to fit, and `check` says so."""
    assert fit_on_free_moves(clean_run) is None
    assert main(["check", str(clean_run_dir), "--free-moves", "--json", "-"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["tracker_registration"] is None and "none taken off" in record["tracker_registration_note"]


def test_check_with_the_registration_taken_off_judges_as_the_true_tip(
        groove: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    """The nominal run's free moves fix the registration (the compensated run's, all forward, do not: `check`
    says so); taken off both runs, their residuals and the compensation's gain are the true tip's."""
    from twin.apps.tasks.inputs import ideal_path

    ideal = ideal_path(groove["ideal"])
    registration = fit_on_free_moves(read_run(groove["nominal"]))
    assert registration is not None
    assert main(["check", str(groove["nominal"]), "--ideal", str(groove["ideal"]), "--free-moves"]) == 0
    assert "tracker registration taken off (fitted on the run's free moves" in capsys.readouterr().out
    judged = {}
    for name in ("nominal", "compensated"):
        off = check_run(read_run(groove[name]), ideal.t_s, ideal.p_sheet_m, registration=registration)
        true = check_run(read_run(groove[f"{name}_true"]), ideal.t_s, ideal.p_sheet_m)
        kept = check_run(read_run(groove[name]), ideal.t_s, ideal.p_sheet_m)
        judged[name] = {k: r.summary()["residual_rms_mm"] for k, r in (("off", off), ("true", true), ("kept", kept))}
        assert off.summary()["tracker_registration"]["shift_mm"] == pytest.approx(1e3 * registration.shift_m)
        assert abs(judged[name]["off"] - judged[name]["true"]) < 0.03
        if name == "compensated":
            assert abs(off.gain - true.gain) < 0.03
    print(judged)
    assert (judged["compensated"]["off"] < judged["nominal"]["off"]) == (
        judged["compensated"]["true"] < judged["nominal"]["true"])


@pytest.mark.slow
def test_a_kr210_cone_is_judged_as_its_true_tip(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A KR210 cone, 10 mm deep, nominal and compensated by the untaught twin: its first turns are free moves all
    round, which fix the shift (not the rotation: on a circle about the origin a lag looks like one). Judged
    with the registration taken off, the compensation's improvement and gain are the true tip's; as the tracker
    reads, they are not (measured: 1.007 -> 0.498 mm, gain 1.24; true 0.882 -> 0.602 mm, gain 1.39)."""
    ideal, command = tmp_path / "cone.csv", tmp_path / "cmd.csv"
    assert main(["path", "--shape", "cone", "--depth-mm", "10", "--robot", "kr210", "--out", str(ideal)]) == 0
    assert main(["compensate", "--method", "twin", "--robot", "kr210", "--ideal", str(ideal), "--out",
                 str(command)]) == 0
    rms: dict[str, float] = {}
    gain: dict[str, float] = {}
    for name, scenario in (("nominal", ["--scenario", "nominal", "--commanded", str(ideal), "--seed", "1"]),
                           ("compensated", ["--scenario", "compensated", "--commanded", str(command), "--seed", "2"])):
        for kind, extra, flags in (("off", [], ["--free-moves"]), ("kept", [], []), ("true", NO_REGISTRATION, [])):
            run = tmp_path / f"{name}_{'true' if kind == 'true' else 'run'}"
            if not run.exists():
                _lab(run, "--robot", "kr210", *scenario, *extra)
            capsys.readouterr()
            main(["check", str(run), "--ideal", str(ideal), *flags, "--json", "-"])
            record = json.loads(capsys.readouterr().out)
            rms[f"{name}_{kind}"], gain[f"{name}_{kind}"] = record["residual_rms_mm"], record["gain"]
            assert (record["tracker_registration"] is not None) == (kind == "off")
    print(rms, gain)
    ratio = {k: rms[f"compensated_{k}"] / rms[f"nominal_{k}"] for k in ("off", "kept", "true")}
    assert abs(ratio["off"] - ratio["true"]) < 0.05
    assert abs(gain["compensated_off"] - gain["compensated_true"]) < 0.03
    assert abs(rms["nominal_off"] - rms["nominal_true"]) < 0.03


def test_check_takes_off_the_registration_the_learned_cell_carries(
        groove: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`learn` on the nominal run carries the plant's registration (0.2 mm / 1 mrad by default); `check --model`
    takes it off: the nominal and the compensated runs are judged within 0.03 mm of their true tips, where the
    tracker as it reads is further off."""
    cell = tmp_path / "cell.json"
    assert main(["learn", str(groove["nominal"]), "--write-model", str(cell)]) == 0
    out: dict[str, dict[str, float]] = {}
    for name in ("nominal", "compensated"):
        for kind, run, flags in (("model", groove[name], ["--model", str(cell)]), ("kept", groove[name], []),
                                 ("true", groove[f"{name}_true"], [])):
            capsys.readouterr()
            main(["check", str(run), "--ideal", str(groove["ideal"]), *flags, "--json", "-"])
            record = json.loads(capsys.readouterr().out)
            out.setdefault(name, {})[kind] = record["residual_rms_mm"]
            assert (record["tracker_registration"] is not None) == (kind == "model"), record
    print(out)
    for name, rms in out.items():
        assert abs(rms["model"] - rms["true"]) < 0.03, (name, rms)
        assert abs(rms["model"] - rms["true"]) < abs(rms["kept"] - rms["true"]), (name, rms)
