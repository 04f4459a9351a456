"""The wall's tilt (twin/process/part/wall_tilt.py) and its study against 32 scanned cones (twin/apps/springback_scans.py,
springback_page.py): the model's physics limits, the scans' table as transcribed, a fitted row reproduced, and
(slow) docs/springback.md as a fresh run writes it, with the shipped constants the fit's."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.doc_numbers import page_differences
from twin.apps.springback_scans import (
    ASSUMED,
    FITTED_ANGLES,
    form,
    measure,
    measured,
    predictions,
    read_scans,
    turn,
)
from twin.cli import main
from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.isf_params import IsfForceParams, params_for, sheet_constants
from twin.process.material.file import material
from twin.process.material.hardening import HardeningLaw, power_law_equivalent
from twin.process.part.wall_tilt import Sheet, TiltConstants, step_down_from_track, tilt_rad

DOC = Path(__file__).resolve().parent.parent / "docs" / "springback.md"
AA1050 = Sheet(1e-3, 6e-3, 71e9, 0.33, 149e6, 0.30)


def test_the_tilt_falls_with_depth_and_rises_with_the_step_and_the_sheets_strength():
    """A deeper wall of the same plan width is held by its hoops; a larger step and a stronger sheet turn it more;
    no bottom, no turn; never more than a free bend's springback."""
    a = math.radians(40.0)
    base = tilt_rad(a, 0.7e-3, AA1050, 0.030, 0.025, 0.020)
    assert 0.0 < math.degrees(base) < 3.0
    assert tilt_rad(math.radians(60.0), 0.7e-3, AA1050, 0.030, 0.052, 0.020) < 0.3 * base
    assert tilt_rad(a, 0.3e-3, AA1050, 0.030, 0.025, 0.020) < base
    assert tilt_rad(a, 0.7e-3, AA1050._replace(hardening_k_pa=400e6), 0.030, 0.025, 0.020) > base
    assert tilt_rad(a, 0.7e-3, AA1050, 0.030, 0.025, 0.0) == 0.0
    free = 3.0 * a * (2 / math.sqrt(3) * 149e6 * (2 / math.sqrt(3) * math.log(1 / math.cos(a))) ** 0.3) \
        * (6e-3 + 0.5e-3 * math.cos(a)) / (71e9 / (1 - 0.33**2) * 1e-3 * math.cos(a))
    assert tilt_rad(a, 0.7e-3, AA1050, 0.030, 1e-4, 0.020, TiltConstants(1e9)) == pytest.approx(free, rel=1e-3)
    with pytest.raises(InputError, match="finite"):
        tilt_rad(a, math.nan, AA1050, 0.030, 0.025, 0.020)


def test_the_step_down_is_read_off_a_z_level_track():
    turns = np.linspace(0.0, 2.0 * math.pi * 10, 2001)
    track = np.column_stack([0.03 * np.cos(turns), 0.03 * np.sin(turns), -0.5e-3 * np.floor(turns / (2 * math.pi))])
    assert step_down_from_track(track) == pytest.approx(0.5e-3, rel=0.02)
    assert step_down_from_track(track[:50]) is None


def test_the_scans_table_is_16_conditions_with_the_designs_plan_width():
    """4 wall angles x 2 step-downs x 2 tools; every design 30 mm wide in plan (depth = 30 mm x tan α)."""
    rows = read_scans()
    assert len(rows) == 16
    assert {(r.wall_angle_deg, r.step_down_mm, r.tool_diameter_mm) for r in rows} == {
        (a, s, d) for a in (40.0, 50.0, 60.0, 70.0) for s in (0.3, 0.7) for d in (12.0, 16.0)}
    for r in rows:
        assert r.design_depth_mm / math.tan(math.radians(r.wall_angle_deg)) == pytest.approx(30.0, abs=0.05)
        assert abs(r.angle_deg - r.wall_angle_deg) < 1.5 and abs(r.height_mm - r.design_depth_mm) < 1.0


def test_a_material_gives_its_power_law_and_an_unknown_one_no_tilt():
    law = HardeningLaw(kind="hollomon", k_mpa=400.0, n=0.17)
    assert power_law_equivalent(law, None, 228.0) == pytest.approx((400.0, 0.17), rel=1e-6)
    k, n = power_law_equivalent(None, 23.0, 77.0)  # type: ignore[misc]
    assert k * 0.002**n == pytest.approx(23.0, rel=1e-6)
    assert k * n**n * math.exp(-n) == pytest.approx(77.0, rel=1e-6)  # Considère
    assert power_law_equivalent(None, None, 77.0) is None
    assert sheet_constants(Process(material="x", tensile_strength_mpa=200.0)) == {"wall_tilt_scale": 0.0}
    assert material("DC01").youngs_modulus_gpa is None
    assert sheet_constants(Process(material="DC01", tensile_strength_mpa=270.0)) == {"wall_tilt_scale": 0.0}
    assert params_for(Process(material="AA1050-O", tensile_strength_mpa=77.0)).hardening_n == pytest.approx(n)
    assert IsfForceParams(wall_tilt_scale=0.0).wall_tilt_scale == 0.0
    default, derived = IsfForceParams(), sheet_constants(Process())  # the defaults are the thesis's AA5086-H111's
    assert (default.youngs_modulus_gpa, default.poisson_ratio) == (derived["youngs_modulus_gpa"], derived["poisson_ratio"])
    assert default.hardening_k_mpa == pytest.approx(derived["hardening_k_mpa"], abs=0.05)
    assert default.hardening_n == pytest.approx(derived["hardening_n"], abs=5e-4)
    for bad in ({"wall_tilt_scale": -1.0}, {"poisson_ratio": 0.5}, {"hardening_n": 1.5}):
        with pytest.raises(InputError, match="IsfForceParams"):
            IsfForceParams(**bad)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def cone_40():
    return form(next(c for c in read_scans() if (c.wall_angle_deg, c.step_down_mm, c.tool_diameter_mm)
                     == (40.0, 0.7, 12.0)))


def test_a_fitted_row_of_the_page_is_the_shipped_model_on_its_cone(cone_40):
    """The 40° / 0.7 mm / Ø 12 mm row: the page's 'now' angle and depth, from the shipped constants."""
    row = next(line for line in DOC.read_text(encoding="utf-8").splitlines() if line.startswith("| 40 | 0.7 | 12 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    now = measure(cone_40, turn(cone_40, TiltConstants()))
    assert now.angle_short_deg == pytest.approx(float(cells[6]), abs=0.015)
    assert now.depth_short_mm == pytest.approx(float(cells[9]), abs=0.015)
    target = measured([cone_40])[0]
    assert abs(now.angle_short_deg - target[0]) < 0.5 * abs(predictions([cone_40], None)[0, 0] - target[0])


def test_the_rigid_machines_part_carries_the_tilt(cone_40):
    """The process's own material turns the wall of a cone the rigid machine forms: the bottom rises by about the
    wall's plan width times the turn (`twin.process.part.surface.springback_surface`)."""
    from twin.process.force.registry import build_force_field
    from twin.process.part.springback import form_rigidly
    from twin.process.part.surface import formed_surface
    from twin.process.toolpath.shapes import PartSpec, part_path

    path = part_path(PartSpec(shape="cone", top_half_width_m=0.05 - 6e-3 * math.tan(math.radians(20.0)),
                              depth_m=25.2e-3, wall_angle_deg=40.0, step_down_m=0.7e-3, mode="z-level"))
    bottoms = []
    for scale in (0.0, 1.0):
        process = Process(material=ASSUMED, tensile_strength_mpa=77.0, tool_radius_m=6e-3, force_model="isf",
                          force_fit=(("wall_tilt_scale", scale),))
        field = build_force_field(process)
        form_rigidly(path, field)
        x, y, z = formed_surface(field)  # type: ignore[misc]
        bottoms.append(float(z[np.argmin(np.abs(y)), np.argmin(np.abs(x))]))
    lift = bottoms[1] - bottoms[0]
    assert lift == pytest.approx(0.030 * turn(cone_40, TiltConstants()), rel=0.15)
    assert replace(IsfForceParams(), wall_tilt_scale=0.0).wall_tilt_scale == 0.0


@pytest.mark.slow
def test_the_page_is_the_one_a_fresh_run_writes_and_the_constants_are_its_fit(tmp_path):
    out = tmp_path / "page.md"
    assert main(["springback-scans", "--markdown", str(out), "--json", str(tmp_path / "rows.json")]) == 0
    stale = "docs/springback.md is stale: run `tx200-twin springback-scans --markdown docs/springback.md`"
    assert page_differences(DOC.read_text(encoding="utf-8"), out.read_text(encoding="utf-8")) == [], stale
    fitted = json.loads((tmp_path / "rows.json").read_text())["constants"]
    assert list(fitted.values()) == pytest.approx(list(TiltConstants()), rel=0.01)
    assert FITTED_ANGLES == (40.0, 60.0)
