"""Import mapping, raw tables, registration, gravity and clocks (twin/runs/mapping.py ... importer.py).

A small synthetic cell (the groove's first pass, a tracker in the sheet frame at 50 Hz, a force growing with
depth at 30 Hz) gives raw files; each bad mapping must fail with its own error naming file, line and key.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.cli import main
from twin.errors import InputError
from twin.process.toolpath.groove import groove_path
from twin.runs.clock import onset_offset
from twin.runs.gravity import contact_force_sheet, sensor_reading
from twin.runs.importer import import_run
from twin.runs.mapping import load_mapping
from twin.runs.read import read_run
from twin.runs.registration import fit_rigid
from twin.runs.toml_keys import ClockError, MappingError, RegistrationError

MAPPING = """\
[run]
scenario = "synthetic"

[commanded]
file = "cmd.csv"
time = "t"
x = "x"
y = "y"
z = "z"
unit = "mm"

[tracker]
file = "tracker.csv"
delimiter = "tab"
time = "t"
time_unit = "ms"
x = "x"
y = "y"
z = "z"
unit = "µm"

[tracker.frame]
unit = "mm"
points_sheet = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]
points_tracker = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]

[tracker.clock]
method = "motion_onset"

[forces]
file = "forces.csv"
delimiter = ";"
decimal = ","
header_line = 0
rate_hz = 30
fx = 0
fy = 1
fz = 2
unit = "N"

[forces.clock]
offset_s = 2.0
"""
TRACKER_OFFSET_S = 5.0


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Raw files of the synthetic cell and its mapping; returns the mapping path."""
    folder = tmp_path_factory.mktemp("synthetic")
    path = groove_path()
    keep = path.pass_index <= 2
    t, p = path.t_s[keep], path.p_sheet_m[keep] * 1e3
    rows = ["t,x,y,z"] + [f"{a:.5f},{x:.5f},{y:.5f},{z:.5f}" for a, (x, y, z) in zip(t, p, strict=True)]
    (folder / "cmd.csv").write_text("\n".join(rows) + "\n")
    rng = np.random.default_rng(3)
    t_tr = np.arange(-1.0, t[-1], 0.02)  # records 1 s before the motion
    p_tr = np.column_stack([np.interp(t_tr, t, p[:, k]) for k in range(3)]) + rng.normal(
        0, 0.02, (t_tr.size, 3)
    )
    rows = ["t\tx\ty\tz"] + [
        f"{(a + TRACKER_OFFSET_S) * 1e3:.3f}\t" + "\t".join(f"{v * 1e3:.1f}" for v in q)
        for a, q in zip(t_tr, p_tr, strict=True)
    ]
    (folder / "tracker.csv").write_text("\ufeff" + "\n".join(rows) + "\n", encoding="utf-8")
    t_f = np.arange(0.0, t[-1] + 2.0, 1.0 / 30.0)  # sensor clock: t_shared = n/30 - 2 s
    depth = np.maximum(0.0, -np.interp(t_f - 2.0, t, p[:, 2]))
    f = np.column_stack([0.3 * depth * 1000, 0 * depth, 1000 * depth]) + rng.normal(0, 5.0, (t_f.size, 3))
    rows = [";".join(f"{v:.3f}".replace(".", ",") for v in q) for q in f]
    (folder / "forces.csv").write_text("\n".join(rows) + "\n")
    (folder / "mapping.toml").write_text(MAPPING)
    return folder / "mapping.toml"


def _variant(cell: Path, tmp_path: Path, old: str, new: str) -> Path:
    text = cell.read_text()
    assert old in text
    for name in ("cmd.csv", "tracker.csv", "forces.csv"):
        (tmp_path / name).write_bytes((cell.parent / name).read_bytes())
    (tmp_path / "mapping.toml").write_text(text.replace(old, new, 1))
    return tmp_path / "mapping.toml"


def _line_of(path: Path, needle: str) -> int:
    return next(n for n, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


def test_synthetic_cell_imports_with_units_rate_bom_and_motion_onset(cell: Path, tmp_path: Path) -> None:
    result = import_run(load_mapping(cell))
    run = result.run
    clock = result.report["clocks"]["tracker"]
    assert clock["method"] == "motion_onset"
    assert clock["offset_s"] == pytest.approx(TRACKER_OFFSET_S, abs=max(4 * clock["sigma_s"], 0.002))
    assert 0 < clock["sigma_s"] < 0.005
    assert run.tracker.t_s[0] >= 0.0 and run.tracker.t_s[-1] <= run.commanded.t_s[-1]
    p_cmd = np.column_stack(
        [np.interp(run.tracker.t_s, run.commanded.t_s, c) for c in run.commanded.values.T]
    )
    assert (
        np.sqrt(np.mean(np.sum((run.tracker.values - p_cmd) ** 2, axis=1))) < 0.1e-3
    )  # µm -> m, 0.02 mm noise
    assert run.forces is not None and run.forces.t_s[0] == pytest.approx(0.0, abs=1e-9)  # rate_hz, offset 2 s
    assert float(np.max(run.forces.values[:, 2])) == pytest.approx(
        2000.0, rel=0.02
    )  # N: 2 mm deep x 1000 N/mm
    assert main(["import", "--mapping", str(cell), "--out", str(tmp_path / "run"), "--json", "-"]) == 0
    assert read_run(tmp_path / "run").meta["import"]["clocks"]["tracker"]["method"] == "motion_onset"


@pytest.mark.parametrize(
    ("old", "new", "error", "key", "pattern", "needle"),
    [
        (
            'file = "forces.csv"',
            'file = "missing.csv"',
            MappingError,
            "forces.file",
            r"file not found",
            '"missing.csv"',
        ),
        ('unit = "µm"', 'unit = "inch"', MappingError, "tracker.unit", r"unknown unit 'inch'", "inch"),
        (
            'time_unit = "ms"',
            'time_unit = "min"',
            MappingError,
            "tracker.time_unit",
            r"unknown unit 'min'",
            "min",
        ),
        (
            "points_sheet = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]",
            "points_sheet = [[0, 0, 0], [100, 0, 0]]",
            RegistrationError,
            "tracker.frame.points_tracker",
            r"has 3 points, points_sheet has 2",
            "points_tracker",
        ),
        (
            "points_sheet = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]\npoints_tracker = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]",
            "points_sheet = [[0, 0, 0], [100, 0, 0]]\npoints_tracker = [[0, 0, 0], [100, 0, 0]]",
            RegistrationError,
            "tracker.frame.points_sheet",
            r"2 reference point\(s\), expected at least 3",
            "points_sheet",
        ),
        (
            "points_sheet = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]\npoints_tracker = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]",
            "points_sheet = [[0, 0, 0], [100, 0, 0], [200, 0, 0]]\npoints_tracker = [[0, 0, 0], [100, 0, 0], [200, 0, 0]]",
            RegistrationError,
            "tracker.frame.points_sheet",
            r"collinear",
            "points_sheet",
        ),
        ("offset_s = 2.0", "offset_s = 500.0", ClockError, "forces.clock.offset_s", r"overlap", "500.0"),
        (
            'delimiter = ";"',
            'delimiter = ","',
            MappingError,
            "forces.decimal",
            r"equals the delimiter",
            'decimal = ","',
        ),
        (
            'x = "x"\ny = "y"',
            'x = "X"\ny = "y"',
            MappingError,
            "x",
            r"column 'X' \(x\) not in the header",
            None,
        ),
    ],
)
def test_bad_mapping_gets_a_specific_error_with_file_line_and_key(
    cell: Path, tmp_path: Path, old: str, new: str, error: type, key: str, pattern: str, needle: str | None
) -> None:
    mapping = _variant(cell, tmp_path, old, new)
    with pytest.raises(error, match=pattern) as info:
        import_run(load_mapping(mapping))
    exc = info.value
    assert exc.key == key
    if needle is None:  # a raw file's header: the commanded file, header line 1
        assert exc.path == tmp_path / "cmd.csv" and exc.row == 1
    else:
        assert exc.path == mapping and exc.row == _line_of(mapping, needle)


POINTS = "points_sheet = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]\npoints_tracker = [[0, 0, 0], [100, 0, 0], [0, 100, 0]]"


def test_a_given_transform_registers_the_tracker(cell: Path, tmp_path: Path) -> None:
    # tracker frame = sheet frame shifted by -10 mm in x: T_sheet_tracker translates by +10 mm
    mapping = _variant(
        cell, tmp_path, POINTS, "T_sheet_tracker = [[1, 0, 0, 10], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"
    )
    shifted = import_run(load_mapping(mapping))
    reference = import_run(load_mapping(cell))
    assert shifted.report["registration"]["points"] == 0
    np.testing.assert_allclose(
        shifted.run.tracker.values[:, 0] - reference.run.tracker.values[:, 0], 0.010, atol=1e-9
    )
    bad = _variant(
        cell, tmp_path, POINTS, "T_sheet_tracker = [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"
    )
    with pytest.raises(RegistrationError, match="not a rigid transform") as info:
        load_mapping(bad)
    assert info.value.row == _line_of(bad, "T_sheet_tracker")


def test_bad_value_in_a_raw_file_names_file_line_and_column(cell: Path, tmp_path: Path) -> None:
    mapping = _variant(cell, tmp_path, "[run]", "[run]")
    lines = (tmp_path / "forces.csv").read_text().splitlines()
    lines[6] = lines[6].replace(",", ".", 1)  # a decimal point where a comma is declared
    (tmp_path / "forces.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(MappingError, match=r"forces\.csv, line 7, fx: holds .*decimal ','") as info:
        import_run(load_mapping(mapping))
    assert info.value.row == 7


def test_inputs_are_never_modified_and_never_written_over(cell: Path, tmp_path: Path) -> None:
    mapping = _variant(cell, tmp_path, "[run]", "[run]")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert main(["import", "--mapping", str(mapping), "--out", str(tmp_path)]) == 2
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_cli_import_reports_a_bad_mapping(
    cell: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mapping = _variant(cell, tmp_path, 'unit = "N"', 'unit = "lbf"')
    assert main(["import", "--mapping", str(mapping), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert f"line {_line_of(mapping, 'lbf')}, forces.unit: unknown unit 'lbf'" in err
    assert not (tmp_path / "run").exists()


def test_kabsch_recovers_a_rigid_transform_and_reports_the_residual() -> None:
    rng = np.random.default_rng(5)
    angle = 0.7
    R = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0], [-np.sin(angle), 0, np.cos(angle)]])
    t = np.array([0.4, -1.2, 0.9])
    p_sheet = rng.uniform(-0.2, 0.2, (6, 3))
    p_tracker = (p_sheet - t) @ R  # p_sheet = R p_tracker + t
    exact = fit_rigid(p_tracker, p_sheet)
    np.testing.assert_allclose(exact.T_sheet_tracker[:3, :3], R, atol=1e-12)
    np.testing.assert_allclose(exact.T_sheet_tracker[:3, 3], t, atol=1e-12)
    assert exact.residual_rms_m < 1e-12
    noisy = fit_rigid(p_tracker + rng.normal(0, 1e-5, p_tracker.shape), p_sheet)
    assert 2e-6 < noisy.residual_rms_m < 2e-5
    with pytest.raises(InputError, match="collinear"):
        fit_rigid(np.outer(np.arange(4.0), [1, 2, 3]), np.outer(np.arange(4.0), [1, 0, 0]))


def test_gravity_compensation_inverts_the_sensor_model() -> None:
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    g = np.array([0.0, 0.0, -9.81])
    contact = np.array([[10.0, -20.0, 1500.0], [0.0, 0.0, 0.0]])
    reading = sensor_reading(contact, R, 3.0, g)
    np.testing.assert_allclose(reading[1], R.T @ (3.0 * g))  # unloaded: the tool's weight, sensor axes
    np.testing.assert_allclose(contact_force_sheet(reading, R, 3.0, g), contact, atol=1e-12)
    with pytest.raises(InputError, match="proper rotation"):
        contact_force_sheet(reading, -R, 3.0, g)


def test_onset_without_a_quiet_lead_in_is_refused() -> None:
    t = np.arange(0.0, 5.0, 0.02)
    ramp = np.maximum(0.0, t - 0.0)
    with pytest.raises(InputError, match="no quiet lead-in"):
        onset_offset(t, ramp + 1.0, t, ramp, max_offset_s=10.0, method="motion_onset")


def test_example_mapping_documents_every_key_the_loader_reads() -> None:
    example = (Path(__file__).resolve().parents[1] / "docs" / "examples" / "mapping.toml").read_text()
    for key in (
        "delimiter",
        "decimal",
        "header_line",
        "time_unit",
        "rate_hz",
        "points_sheet",
        "points_tracker",
        "T_sheet_tracker",
        "offset_s",
        "force_onset",
        "motion_onset",
        "R_sheet_sensor",
        "tool_mass_kg",
        "com_sensor_mm",
        "gravity_sheet_m_s2",
        "max_offset_s",
        "[profile]",
    ):
        assert key in example, key
    doc = (Path(__file__).resolve().parents[1] / "docs" / "import-export.md").read_text()
    assert example.strip() in doc  # the doc shows the complete, tested example
