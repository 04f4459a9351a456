"""A cone and a pyramid through the command line, as a new user would run them: path -> compensate ->
lab (both plants) -> check.

`--force-model auto` takes the height-map ISF model for a path that is not the FE history's groove, so the
table field's "pass_index = 11" error no longer stops `compensate --ideal cone.csv`; the dynamic plant takes the same
model (`lab --plant dynamic --force-model auto`). Measured numbers are above the test.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from doc_numbers import quoted

from twin.cli import main

INDEPENDENT = ("measured against the dependent plant (the twin's own isf model); the independent plant's membrane "
               "sheet (twin/lab/dynamic/sheet.py) is not the twin's model: {}")
PLANTS = {"quasi-static": [], "dynamic": ["--plant", "dynamic", "--neutral"]}
#: The parts of the table and compensation grids: the cone in make test, the pyramid (its own compensation and four
#: lab runs, ~12 s) in make test-slow.
PARTS = ["cone_runs", pytest.param("pyramid_runs", marks=pytest.mark.slow)]


def _part_runs(base: Path, shape: str) -> dict[str, Path]:
    """path -> twin compensation -> nominal and compensated lab runs on both plants, as a user types them."""
    ideal, cmd = base / f"{shape}.csv", base / f"{shape}_cmd.csv"
    stl = base / f"{shape}.stl"
    assert main(["path", "--shape", shape, "--depth-mm", "5", "--top-width-mm", "40", "--out", str(ideal),
                 "--stl-out", str(stl)]) == 0
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--tol-mm", "0.01", "--out", str(cmd),
                 "--json", str(base / f"{shape}_compensate.json")]) == 0
    runs = {"ideal": ideal, "base": base, "stl": stl}
    for plant, options in PLANTS.items():
        for name, commanded in (("nominal", ideal), ("compensated", cmd)):
            out = base / f"{shape}_{plant}_{name}"
            assert main(["lab", *options, "--scenario", name, "--commanded", str(commanded), "--seed", "1",
                         "--out", str(out)]) == 0
            runs[f"{plant}/{name}"] = out
    return runs


@pytest.fixture(scope="module")
def cone_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return _part_runs(tmp_path_factory.mktemp("cone"), "cone")


@pytest.fixture(scope="module")
def pyramid_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return _part_runs(tmp_path_factory.mktemp("pyramid"), "pyramid")


def check(run: Path, ideal: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, float]:
    capsys.readouterr()
    main(["check", str(run), "--ideal", str(ideal), "--json", "-"])
    payload: dict[str, float] = json.loads(capsys.readouterr().out)
    return payload


def checked(runs: dict[str, Path], plant: str, capsys: pytest.CaptureFixture[str]) -> tuple[dict, dict]:
    """`check` of the plant's compensated and nominal runs against the ideal path, each printed."""
    right = check(runs[f"{plant}/compensated"], runs["ideal"], capsys)
    nominal = check(runs[f"{plant}/nominal"], runs["ideal"], capsys)
    print(f"\n{plant}: compensated {right['residual_rms_mm']:.3f} mm rms, nominal {nominal['residual_rms_mm']:.3f} mm")
    return right, nominal


# measured (seed 1, 5 mm deep, 40 mm across): rms residual against the ideal path [mm], docs/any-part.md's table
@pytest.mark.parametrize("plant", ["quasi-static", "dynamic"])
@pytest.mark.parametrize("part", PARTS)
def test_the_any_part_table_is_what_the_runs_give(
    part: str, plant: str, request: pytest.FixtureRequest, capsys: pytest.CaptureFixture[str]
) -> None:
    """The page's numbers, guarded on their own: no target assert runs before them."""
    runs = request.getfixturevalue(part)
    shape = part.removesuffix("_runs")
    right, nominal = checked(runs, plant, capsys)
    doc = quoted("any-part.md", "| 45° cone |" if shape == "cone" else "| pyramid |", 4)
    column = 0 if plant == "quasi-static" else 2
    doc[column].check(nominal["residual_rms_mm"])
    doc[column + 1].check(right["residual_rms_mm"])


# the twin compensation reaches the 0.01 mm rms asked in 4 simulations for the cone, 8 for the pyramid, whose
# corners turn the radial force with the travel, where joint friction sticks and slips
@pytest.mark.parametrize("plant", ["quasi-static", pytest.param("dynamic", marks=pytest.mark.xfail(
    strict=True, raises=AssertionError,
    reason=INDEPENDENT.format("the twin-compensated part misses its path by more than the test allows (the run prints it)")))])
@pytest.mark.parametrize("part", PARTS)
def test_a_part_is_compensated_onto_its_path_on_both_plants(
    part: str, plant: str, request: pytest.FixtureRequest, capsys: pytest.CaptureFixture[str]
) -> None:
    runs = request.getfixturevalue(part)
    shape = part.removesuffix("_runs")
    compensation = json.loads((runs["base"] / f"{shape}_compensate.json").read_text())
    # the twin's prediction of the compensated run: within the 0.01 mm asked in rms
    assert compensation["converged"] and compensation["predicted_residual_rms_mm"] <= 0.01
    assert compensation["iterations"] <= (4 if shape == "cone" else 8)
    truth = json.loads((runs[f"{plant}/compensated"] / "truth.json").read_text())
    assert truth["force_model"] == "isf"
    right, nominal = checked(runs, plant, capsys)
    print(f"twin prediction {compensation['predicted_residual_rms_mm']:.4f} mm rms after "
          f"{compensation['iterations']} simulations, converged {compensation['converged']}")
    assert right["residual_rms_mm"] < 0.1
    assert nominal["residual_rms_mm"] > 8.0 * right["residual_rms_mm"]
    assert right["gain"] == pytest.approx(1.0, abs=0.05)


def test_the_cone_compensation_used_the_isf_model(cone_runs: dict[str, Path]) -> None:
    compensate = json.loads((cone_runs["base"] / "cone_compensate.json").read_text())
    assert compensate["force_model"] == "isf"


def test_the_groove_keeps_the_table_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compensate", "--method", "formula", "--stiffness", str(write_stiffness(tmp_path)),
                 "--out", str(tmp_path / "g.csv"), "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["force_model"] == "table"


def write_stiffness(folder: Path) -> Path:
    path = folder / "k.json"
    path.write_text(json.dumps({"k_r_n_per_mm": [[700.0, 0.0, -300.0], [0.0, 800.0, 0.0], [-300.0, 0.0, 1100.0]]}))
    return path


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=INDEPENDENT.format("the replay gap is above the noise"))
def test_a_dynamic_cone_run_replays_on_the_isf_twin_within_the_noise(
    cone_runs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    assert main(["replay", str(cone_runs["dynamic/nominal"]), "--json", "-"]) == 0
    metrics = json.loads(capsys.readouterr().out)
    # 0.040 mm measured against 2 sqrt(3) x the tracker's 0.02 mm = 0.069 mm; 9.6 N of a ~1.5 kN peak
    assert metrics["position_rms_mm"] < 2.0 * 3**0.5 * 0.02
    assert metrics["force_rms_n"] < 0.02 * metrics["force_peak_measured_n"]


@pytest.mark.slow  # a dynamic-plant run of its own (~19 s); the groove's force_scale is in make test (test_discrepancy.py)
@pytest.mark.xfail(strict=True, raises=AssertionError, reason=INDEPENDENT.format("the stronger sheet is not named force_scale (unexplained)"))
def test_discrepancy_names_a_force_scale_hidden_in_a_cone_run(
    cone_runs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    """A sheet 30 % stronger than declared (R_m 1.3 x 275 MPa) formed on the dynamic plant, not the lab's
    `force_scale` effect: the plant shares no code with the effect library the search fits."""
    from dataclasses import replace

    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.run import run_dynamic_lab
    from twin.process.description import Process
    from twin.runs.read import read_commanded_csv
    from twin.runs.write import write_run

    stronger = replace(Process(force_model="isf"), tensile_strength_mpa=1.3 * Process().tensile_strength_mpa)
    cone = read_commanded_csv(cone_runs["ideal"])
    # the run records the process the operator declared (the thesis's sheet), not the stronger coil it formed
    run, truth, _ = run_dynamic_lab(cone.t_s, cone.values, scenario="nominal", knobs=Knobs(neutral=True), seed=3,
                                    process=stronger, declared=Process())
    assert run.meta["process"]["tensile_strength_mpa"] == 275.0 and truth["process_formed"]["tensile_strength_mpa"] > 350
    directory = write_run(cone_runs["base"] / "cone_stronger_sheet", run, truth=truth)
    capsys.readouterr()
    assert main(["discrepancy", str(directory), "--json", "-"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert found["effect"] == "force_scale", found["remainder"]
    assert found["parameters"]["force_scale"]["force_scale_ratio"] == pytest.approx(1.3, rel=0.03)  # 1.303
    assert found["gap_after"]["position_rms_mm"] < 0.3 * found["gap_before"]["position_rms_mm"]  # 0.198 -> 0.039


# measured (seed 1): part scan against the target STL, bottom included, rms [mm]: docs/any-part.md ("Cone above")
# (the dynamic plant forms its own sheet: the twin's compensation misses it, and the doc says by how much)
@pytest.mark.parametrize("plant", list(PLANTS))
def test_the_formed_cone_matches_its_target_stl_after_compensation(
    plant: str, cone_runs: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    figure = cone_runs["base"] / f"deviation_{plant}.png"
    results = {}
    for name in ("nominal", "compensated"):
        capsys.readouterr()
        main(["check", str(cone_runs[f"{plant}/{name}"]), "--ideal", str(cone_runs["ideal"]),
              "--target-stl", str(cone_runs["stl"]), "--figure", str(figure), "--json", "-"])
        results[name] = json.loads(capsys.readouterr().out)
    print(f"\ncone surface {plant}: nominal {results['nominal']['surface_rms_mm']:.3f} mm rms, "
          f"compensated {results['compensated']['surface_rms_mm']:.3f} mm")
    doc = quoted("any-part.md", "Cone above, scan against its STL, rms [mm]:", 5)
    column = 0 if plant == "quasi-static" else 3
    doc[column].check(results["nominal"]["surface_rms_mm"])
    doc[column + 1].check(results["compensated"]["surface_rms_mm"])
    assert figure.stat().st_size > 10_000
    if plant == "dynamic":
        return
    assert results["compensated"]["surface_rms_mm"] < 0.05
    assert results["nominal"]["surface_mean_mm"] > 0.5  # the nominal part is too shallow
    assert results["nominal"]["surface_rms_mm"] > 10.0 * results["compensated"]["surface_rms_mm"]
    assert results["compensated"]["surface_points"] > 1000
    assert figure.stat().st_size > 10_000


def test_the_cad_check_needs_a_scan_and_a_figure_needs_a_target(
    cone_runs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from twin.runs.read import read_run
    from twin.runs.write import write_run

    capsys.readouterr()
    assert main(["check", str(cone_runs["quasi-static/nominal"]), "--ideal", str(cone_runs["ideal"]),
                 "--figure", str(tmp_path / "f.png")]) == 2
    assert "--target-stl" in capsys.readouterr().err
    run = read_run(cone_runs["quasi-static/nominal"])
    bare = write_run(tmp_path / "no_scan", type(run)(None, run.meta, run.commanded, run.tracker, run.forces,
                                                     run.part_profile))
    assert main(["check", str(bare), "--ideal", str(cone_runs["ideal"]), "--target-stl",
                 str(cone_runs["stl"])]) == 2
    assert "part_scan.csv" in capsys.readouterr().err
