"""Springback learned from a scan (`identify --springback`, twin/analysis/identify/springback.py): a part that
springs back otherwise than the twin says, its scan built here in the test's own form, and the two constants found
from it; a run without a scan is refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.analysis.identify.springback import fit_springback
from twin.cli import main
from twin.errors import InputError
from twin.process.description import Process
from twin.process.part.bottom import with_floating_bottom
from twin.process.part.surface import FORMED_BELOW_M, design_part_surface, heightmap_mesh, surface_points
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.runs.format import Run, Stream, run_meta
from twin.runs.write import write_run
from twin.sim.spec import TwinSpec

CONE = PartSpec(shape="cone", top_half_width_m=0.02, depth_m=0.005)
#: What the test hides: the elastic recovery 1.6 x the twin's F/k_unload, then 6 % of the depth lost.
HIDDEN_RECOVERY, HIDDEN_LIFT = 1.6, 0.06


def _scanned_part(path, spec: TwinSpec, seed: int) -> tuple[np.ndarray, object]:
    """The part the twin's robot forms along `path`, sprung back by the test's own rule, as a noisy, shifted scan.

    The rule, written here: each formed cell rises by HIDDEN_RECOVERY x (the vertical force of the commit that formed
    it) / k_unload, never above the sheet, the unsupported bottom hangs from the last contour, then every point lifts
    by HIDDEN_LIFT of its depth.
    """
    twin = spec.build()
    twin.simulate(path.t_s, path.p_sheet_m)
    hm, k = twin.sheet_field.map, twin.sheet_field.k_unload
    hm.flush()
    f_z = hm.commit_f_z_n
    z = hm.z_met_m.copy()
    owned = hm.owner_met >= 0
    z[owned] = np.minimum(z[owned] + HIDDEN_RECOVERY * np.maximum(f_z[hm.owner_met[owned]], 0.0) / k, 0.0)
    x, y = np.asarray(hm.x_m), np.asarray(hm.y_m)
    z = with_floating_bottom(x, y, z, hm.track_m, FORMED_BELOW_M)
    z = z + HIDDEN_LIFT * (-z)
    scan = surface_points(x, y, z)
    rng = np.random.default_rng(seed)
    scan = scan + np.array([0.2e-3, -0.1e-3, 0.0]) + np.column_stack([np.zeros((len(scan), 2)),
                                                                      rng.normal(0.0, 2e-5, len(scan))])
    return scan, twin


@pytest.fixture(scope="module")
def cone():
    path = part_path(CONE)
    design = heightmap_mesh(*design_part_surface(path))
    return path, design


def test_the_springback_constants_are_found_from_a_scan(cone) -> None:
    """Fitted: recovery_scale and depth_ratio within 1 % and 0.1 % of what the test hid (1.6, 0.94; measured
    1.602, 0.9400), the wall's tilt the test's rule does not have near 0, the scan's shift found by the
    registration, the residual at the scan's noise (0.02 mm)."""
    path, design = cone
    spec = TwinSpec(process=Process(force_model="isf"))
    scan, _ = _scanned_part(path, spec, seed=3)
    run = Run(None, {}, Stream(path.t_s, path.p_sheet_m), Stream(path.t_s, path.p_sheet_m), part_scan=scan)
    fit = fit_springback(run, spec, design)
    found = dict(fit.springback_fit)
    doc = quoted("any-part.md", "fitted from its scan | recovery_scale", 2)
    doc[0].check(found["recovery_scale"], slack=2.0)
    doc[1].check(found["depth_ratio"], slack=2.0)
    assert found["recovery_scale"] == pytest.approx(HIDDEN_RECOVERY, rel=0.01)
    assert found["depth_ratio"] == pytest.approx(1.0 - HIDDEN_LIFT, abs=0.001)
    assert found["wall_tilt_scale"] < 0.05  # the test's part does not turn its wall: the fit says so
    assert fit.rms_before_m > 0.15e-3 and fit.rms_after_m < 0.03e-3 and fit.points > 500
    np.testing.assert_allclose(fit.registration.translation_m[:2], [-0.2e-3, 0.1e-3], atol=0.02e-3)


def test_a_run_without_a_scan_is_refused(tmp_path: Path, cone, capsys: pytest.CaptureFixture[str]) -> None:
    path, design = cone
    meta = run_meta(scenario="nominal", source="test", tracker_rate_hz=1.0 / float(np.median(np.diff(path.t_s))), sensor_rate_hz=30.0, seed=0,
                    tool_length_m=TwinSpec().robot.tool_length_m)
    run = Run(None, meta, Stream(path.t_s, path.p_sheet_m), Stream(path.t_s, path.p_sheet_m))
    with pytest.raises(InputError, match="has none"):
        fit_springback(run, TwinSpec(process=Process(force_model="isf")), design)
    stl = tmp_path / "design.stl"
    mesh = design.copy()
    mesh.apply_scale(1e3)
    stl.write_bytes(mesh.export(file_type="stl"))
    write_run(tmp_path / "run", run)
    assert main(["identify", "--springback", str(tmp_path / "run"), "--design", str(stl)]) == 2
    assert "has no part_scan.csv" in capsys.readouterr().err
    assert main(["identify", "--springback", str(tmp_path / "run")]) == 2
    assert "needs --design DESIGN" in capsys.readouterr().err
