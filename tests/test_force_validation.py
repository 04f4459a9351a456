"""The force model held to published measurements (twin/apps/force_validation.py, force_data.py): the generated
page docs/force-validation.md is the one a fresh run writes, the measurements file is read strictly, and the
build-up depth is the fit to the published depth curve."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from doc_numbers import page_differences

from twin.apps.force_data import read_measurements, shipped_measurements
from twin.apps.force_validation import TOLERANCE, fit_build_up, markdown, validate_forces
from twin.cli import main
from twin.errors import DataFileError
from twin.process.description import Process
from twin.process.force.isf_params import IsfForceParams, steady_fz_n
from twin.process.force.registry import build_force_field
from twin.process.material.file import material
from twin.process.toolpath.shapes import PartSpec, part_path

DOC = Path(__file__).resolve().parent.parent / "docs" / "force-validation.md"


@pytest.fixture(scope="module")
def validation():
    return validate_forces()


def test_the_page_is_the_one_a_fresh_run_writes(validation, tmp_path, monkeypatch):
    """Number by number, within what a machine's floating point moves them (`doc_numbers.page_differences`).
    The command's own part, its page written from the validation it asks for (the default seed's), is checked on
    the module's fresh run (the same call: a second run of it cost this test and its BLAS rerun ~6 s each)."""
    stale = "docs/force-validation.md is stale: run `tx200-twin force-validation --markdown docs/force-validation.md`"
    assert page_differences(DOC.read_text(encoding="utf-8"), markdown(validation)) == [], stale
    asked: list[tuple] = []

    def same_run(measurements=None, seed: int = 1):
        asked.append((measurements, seed))
        return validation

    monkeypatch.setattr("twin.apps.force_validation.validate_forces", same_run)
    out = tmp_path / "page.md"
    assert main(["force-validation", "--markdown", str(out), "--json", str(tmp_path / "rows.json")]) == 0
    assert asked == [(None, 1)]  # the fixture's call: `validate_forces()`
    assert page_differences(DOC.read_text(encoding="utf-8"), out.read_text(encoding="utf-8")) == [], stale


def test_steady_cases_are_within_20_percent_and_each_case_outside_says_why(validation):
    """Measured: BM3 +19 % (1814 vs 1525 N), Bharti's 71° cone -6 % (359 vs 381 N, with the library's R_m and the
    model's wall-angle cap), the thesis groove's peak -37 % (1262 vs about 2000 N: a groove is no cone wall)."""
    steady = [r for r in validation.cases if r.case.fz_steady_n is not None]
    assert len(steady) >= 2 and all(r.inside for r in steady)
    assert len({r.case.source for r in validation.cases}) >= 3
    for r in validation.cases:
        assert r.inside == (abs(r.error) <= TOLERANCE)
        if not r.inside:
            assert r.reasons, r.case.key


def test_the_build_up_depth_is_the_fit_to_the_published_depth_curve(validation):
    fit = fit_build_up(shipped_measurements().build_up)
    assert fit.depth_m == pytest.approx(IsfForceParams().build_up_m, rel=0.02)  # 3.74 mm fitted, 3.75 used
    assert fit.rms_n < 0.05 * fit.fz_steady_n


def test_the_force_ratio_of_two_materials_follows_their_strength():
    """The same 45° cone in AA1050-O and AA5086-H111: the ratio of their tensile strengths (it was 1.0 when the
    level was refitted to the groove history)."""
    soft, strong = material("AA1050-O"), material("AA5086-H111")
    path = part_path(PartSpec(shape="cone", depth_m=16e-3, step_down_m=0.5e-3, top_half_width_m=0.03))
    steady = path.p_sheet_m[:, 2] < -13e-3

    def formed(rm: float) -> float:  # the cone formed rigidly with the material's process
        field = build_force_field(Process(material="x", tensile_strength_mpa=rm, force_model="isf"))
        return float(np.mean(field.rigid_forces(path)[steady, 2]))

    ratio = formed(soft.tensile_strength_mpa) / formed(strong.tensile_strength_mpa)
    assert ratio == pytest.approx(soft.tensile_strength_mpa / strong.tensile_strength_mpa, rel=1e-6)
    assert ratio == pytest.approx(steady_fz_n(Process(tensile_strength_mpa=soft.tensile_strength_mpa), 0.5e-3, 45.0)
                                  / steady_fz_n(Process(), 0.5e-3, 45.0), rel=1e-6)
    assert ratio < 0.5


def test_a_bad_measurements_file_names_the_case_and_key(tmp_path):
    text = (Path(__file__).resolve().parent.parent / "twin" / "data" / "force_measurements.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("thickness_mm = 1.63", "thickness_mm = -1.63"), encoding="utf-8")
    with pytest.raises(DataFileError, match=r"BM3 cone.*thickness_mm = -1.63"):
        read_measurements(bad)
    bad.write_text(text.replace('source = "bharti2024"', 'source = "nobody"'), encoding="utf-8")
    with pytest.raises(DataFileError, match="nobody"):
        read_measurements(bad)


def test_the_springback_section_stands_beside_the_published_one(validation):
    """Measured: 0.85 mm rms over the BM3 section, 0.43 mm within |x| <= 50 mm (the clamp region is the weakest;
    0.99 and 0.73 mm before the wall's tilt, docs/springback.md)."""
    profile = validation.profile
    assert profile is not None and profile.cad_depth_mm == pytest.approx(44.489)
    assert profile.rms_mm(50.0) < profile.rms_mm() < 1.5
