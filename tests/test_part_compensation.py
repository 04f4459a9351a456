"""The formed part to the design (twin/analysis/part_compensation.py, `compensate --target-stl`): the twin's
part after unclamping lands on the design, and a scan's deviation moves the next command (the learning law)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from rerun.chunk import RrdReader

from twin.analysis.part_compensation import compensate_part, design_heights, part_error
from twin.analysis.scan_learning import learn_from_scan
from twin.cli import main
from twin.process.description import Process
from twin.process.isf_force import IsfForceField
from twin.process.part_bottom import with_floating_bottom
from twin.process.part_surface import FORMED_BELOW_M, cropped_surface, heightmap_mesh
from twin.process.shapes import PartSpec, part_path
from twin.sim.spec import TwinSpec

CONE = PartSpec(shape="cone", top_half_width_m=0.02, depth_m=0.005)


def design_of(path) -> trimesh.Trimesh:
    """The tool-side surface a rigid machine forms along `path`, no springback [m] (written here, not the code's)."""
    field = IsfForceField()
    field.rigid_forces(path)
    hm = field.map
    x, y = np.asarray(hm.x_m), np.asarray(hm.y_m)
    return heightmap_mesh(*cropped_surface(x, y, with_floating_bottom(x, y, hm.z_loaded_m, hm.track_m,
                                                                      FORMED_BELOW_M), 10e-3))


@pytest.fixture(scope="module")
def cone():
    path = part_path(CONE)
    return path, design_of(path)


def test_the_twins_part_lands_on_the_design(cone) -> None:
    """Measured: path-compensated 0.504 mm rms (the springback), part-compensated 0.040 then 0.036 mm."""
    path, design = cone
    twin = TwinSpec(process=Process(force_model="isf")).build()
    result = compensate_part(path, twin, design, iterations=2)
    first = 1e-3 * result.error_per_iteration[0]["part"]["rms_mm"]
    last = 1e-3 * result.error_per_iteration[-1]["part"]["rms_mm"]
    assert first > 0.3e-3 and last < first / 3 and last < 0.06e-3
    assert np.all(result.target.p_sheet_m[:, :2] == path.p_sheet_m[:, :2])  # x-y held fixed


def test_a_scan_above_the_design_moves_the_next_command_down_by_the_gap(cone) -> None:
    path, design = cone
    x, y = np.meshgrid(np.linspace(-0.03, 0.03, 121), np.linspace(-0.03, 0.03, 121))
    z = design_heights(design, x, y) + 0.3e-3  # the part sprang back 0.3 mm everywhere
    scan = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    scan = scan[np.isfinite(scan[:, 2])]
    error = part_error(scan, design)  # normal to the design: 0.3 mm on the bottom, 0.3 cos α on the wall
    assert error["bottom"]["mean_mm"] == pytest.approx(0.3, rel=0.05)
    assert 0.3 * np.cos(np.radians(45.0)) * 0.98 < error["wall"]["mean_mm"] < 0.3  # 45° walls and their bends
    command, measured, _ = learn_from_scan(path.p_sheet_m, scan, design, gain=0.5)
    seen = np.isfinite(measured)
    assert seen.mean() > 0.95
    np.testing.assert_allclose(measured[seen], 0.3e-3, atol=0.02e-3)
    np.testing.assert_allclose(path.p_sheet_m[seen, 2] - command[seen, 2], 0.15e-3, atol=0.01e-3)


def test_the_options_are_checked(tmp_path: Path, cone, capsys: pytest.CaptureFixture[str]) -> None:
    _, design = cone
    stl = tmp_path / "design.stl"
    mesh = design.copy()
    mesh.apply_scale(1e3)
    stl.write_bytes(mesh.export(file_type="stl"))
    ideal = tmp_path / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "40", "--depth-mm", "5", "--out", str(ideal)]) == 0
    assert main(["compensate", "--method", "formula", "--ideal", str(ideal), "--target-stl", str(stl),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "--target-stl needs --method twin" in capsys.readouterr().err
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--learn-from", str(tmp_path),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "--learn-from needs --target-stl" in capsys.readouterr().err
    bad = tmp_path / "bad.stl"
    bad.write_text("solid nothing\nendsolid nothing\n")
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--target-stl", str(bad),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "bad.stl" in capsys.readouterr().err
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--figure", str(tmp_path / "f.png"),
                 "--out", str(tmp_path / "c.csv")]) == 2
    assert "--figure" in capsys.readouterr().err and not (tmp_path / "f.png").exists()
    assert main(["compensate", "--method", "twin", "--ideal", str(ideal), "--target-stl", str(stl),
                 "--force-model", "isf", "--out", str(tmp_path / "part.csv"), "--json", "-",
                 "--figure", str(tmp_path / "maps.png"), "--rrd", str(tmp_path / "part.rrd")]) == 0
    summary = json.loads(capsys.readouterr().out)
    rms = summary["predicted_surface_rms_mm_per_iteration"]
    assert rms[-1]["part"] < rms[0]["part"] / 3
    assert (tmp_path / "maps.png").stat().st_size > 20_000 and summary["figure"].endswith("maps.png")
    _check_recording(tmp_path / "part.rrd", stages=len(rms))


def _check_recording(path: Path, stages: int) -> None:
    """The recording holds the design (static), a predicted surface and the rms plots at each stage."""
    chunks: dict[str, list] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        chunks.setdefault(chunk.entity_path, []).append(chunk)
    assert all(c.is_static for c in chunks["/world/design"]) and "/README" in chunks
    for entity in ("/world/predicted", "/plots/rms_mm/wall", "/plots/rms_mm/bottom"):
        assert sum(c.num_rows for c in chunks[entity] if not c.is_static) == stages, entity
