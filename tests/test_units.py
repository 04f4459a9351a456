"""Units by declaration (twin/base/units.py): a length column is `_mm` or `_m`, and the checks for metres
under `_mm` names do not depend on the size of the part (a 10 mm path reads like the 70 mm groove)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twin.base.csvio import write_table
from twin.base.units import (
    check_path_speed,
    check_point_spacing,
    moving_median_speed,
    read_si_table,
)
from twin.cli import main
from twin.errors import DataFileError, UnitsError
from twin.process.fe.load import load_force_history
from twin.runs.format import Run, Stream
from twin.runs.read import read_commanded_csv, read_run
from twin.runs.write import write_run

FEED_M_S = 2.0 / 60.0  # 2 m/min (thesis §1.2.3)
POSITIONS = ("x_mm", "y_mm", "z_mm")


def circle(diameter_m: float, rate_hz: float = 50.0, offset_m: float = 0.0) -> Stream:
    """Two laps of a circle at 1 mm depth at 2 m/min, sampled at `rate_hz`, starting at t = 0."""
    radius = diameter_m / 2.0
    t = np.arange(0.0, 2.0 * 2.0 * np.pi * radius / FEED_M_S, 1.0 / rate_hz)
    angle = FEED_M_S * t / radius
    p = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.full_like(t, -1e-3)])
    return Stream(t, p + offset_m)


def write_path(file: Path, stream: Stream, unit: str = "mm", scale: float | None = None) -> Path:
    """A `commanded.csv`-format file with length columns declared `_mm` or `_m` (values times `scale`)."""
    scale = (1e3 if unit == "mm" else 1.0) if scale is None else scale
    columns = {"t_s": stream.t_s, **{f"{a}_{unit}": stream.values[:, i] * scale for i, a in enumerate("xyz")}}
    digits = ".7f" if unit == "mm" else ".10f"  # both 0.1 nm
    return write_table(file, columns, formats=dict.fromkeys(columns, digits))


@pytest.mark.parametrize("diameter_m", [0.020, 0.010])
def test_small_paths_read_with_read_commanded_csv(tmp_path: Path, diameter_m: float) -> None:
    path = circle(diameter_m)
    assert np.ptp(path.values[:, 0]) < 0.030  # under the old "30 mm" rule
    back = read_commanded_csv(write_path(tmp_path / "small.csv", path))
    np.testing.assert_allclose(back.values, path.values, atol=1e-9)
    np.testing.assert_allclose(back.t_s, path.t_s, atol=1e-9)


def test_a_20_mm_cone_from_the_path_command_reads_back(tmp_path: Path) -> None:
    out = tmp_path / "cone.csv"
    assert (
        main(["path", "--shape", "cone", "--depth-mm", "2", "--top-width-mm", "20", "--out", str(out)]) == 0
    )
    cone = read_commanded_csv(out)
    assert 0.015 < np.ptp(cone.values[:, 0]) < 0.030


def small_run(diameter_m: float) -> Run:
    commanded = circle(diameter_m)
    tracker = circle(diameter_m, rate_hz=100.0, offset_m=2e-4)
    x_p = np.linspace(-diameter_m / 2, diameter_m / 2, 41)  # a 0.25-0.5 mm step
    profile = (x_p, -1e-3 * (np.abs(x_p) < diameter_m / 4))
    g = np.linspace(-diameter_m / 2, diameter_m / 2, 21)
    xx, yy = np.meshgrid(g, g)
    scan = np.column_stack([xx.ravel(), yy.ravel(), -1e-3 * (np.hypot(xx, yy) < diameter_m / 4).ravel()])
    meta = {"scenario": "nominal", "tool_length_m": 0.27494, "tracker_rate_hz": 100}
    return Run(None, meta, commanded, tracker, None, profile, scan)


@pytest.mark.parametrize("diameter_m", [0.020, 0.010])
def test_small_paths_read_as_a_runs_streams(tmp_path: Path, diameter_m: float) -> None:
    run = small_run(diameter_m)
    back = read_run(write_run(tmp_path / "run", run), require_forces=False)
    np.testing.assert_allclose(back.commanded.values, run.commanded.values, atol=0.6e-7)  # 4 decimals in mm
    np.testing.assert_allclose(back.tracker.values, run.tracker.values, atol=0.6e-7)
    assert back.part_profile is not None and back.part_scan is not None and run.part_scan is not None
    np.testing.assert_allclose(back.part_scan, run.part_scan, atol=0.6e-6)  # 3 decimals in mm


def test_metre_columns_read_to_the_same_si_arrays(tmp_path: Path) -> None:
    path = circle(0.010)
    in_mm = read_commanded_csv(write_path(tmp_path / "mm.csv", path))
    in_m = read_commanded_csv(write_path(tmp_path / "m.csv", path, unit="m"))
    assert (tmp_path / "m.csv").read_text().splitlines()[0] == "t_s,x_m,y_m,z_m"
    np.testing.assert_allclose(in_m.values, in_mm.values, atol=1e-9)
    np.testing.assert_array_equal(in_m.t_s, in_mm.t_s)
    table = read_si_table(tmp_path / "m.csv", ("t_s", *POSITIONS))
    assert table.typed == {"t_s": "t_s", "x_mm": "x_m", "y_mm": "y_m", "z_mm": "z_m"}
    assert not table.declared_mm(POSITIONS)


def test_a_run_with_metre_columns_reads_like_the_one_in_mm(tmp_path: Path) -> None:
    run = small_run(0.020)
    directory = write_run(tmp_path / "run", run)
    in_mm = read_run(directory, require_forces=False)
    write_path(directory / "commanded.csv", run.commanded, unit="m")
    write_path(directory / "tracker.csv", run.tracker, unit="m")
    assert run.part_profile is not None
    write_table(directory / "part_profile.csv", {"x_m": run.part_profile[0], "z_m": run.part_profile[1]})
    in_m = read_run(directory, require_forces=False)
    for got in (in_m, in_mm):  # written to 4 decimals in mm (0.1 µm), 10 in m
        np.testing.assert_allclose(got.commanded.values, run.commanded.values, atol=0.6e-7)
        np.testing.assert_allclose(got.tracker.values, run.tracker.values, atol=0.6e-7)
    assert in_m.part_profile is not None and in_mm.part_profile is not None
    np.testing.assert_allclose(in_m.part_profile[0], in_mm.part_profile[0], atol=1e-9)


@pytest.mark.parametrize("diameter_m", [0.070, 0.010])
def test_metres_in_mm_columns_of_a_moving_path_raise(tmp_path: Path, diameter_m: float) -> None:
    file = write_path(tmp_path / "wrong.csv", circle(diameter_m), scale=1.0)  # metres under _mm names
    with pytest.raises(UnitsError) as info:
        read_commanded_csv(file)
    message = str(info.value)
    assert info.value.path == file and str(file) in message
    assert "columns 'x_mm', 'y_mm', 'z_mm' move at a median 0.0333 mm/s" in message
    assert "expected at least 0.05 mm/s" in message and "'x_m', 'y_m', 'z_m'" in message


def test_a_file_with_both_spellings_of_a_column_is_refused(tmp_path: Path) -> None:
    file = tmp_path / "both.csv"
    file.write_text("t_s,x_mm,y_mm,z_mm,x_m\n0,1,0,0,0.001\n0.1,4,0,0,0.004\n")
    with pytest.raises(
        UnitsError, match=r"both\.csv: declares one length twice, as 'x_mm' \[mm\] and 'x_m' \[m\]"
    ):
        read_commanded_csv(file)
    with pytest.raises(UnitsError, match=r"'x_mm'.*'x_m'"):
        read_si_table(file, ("x_mm",))


def test_a_missing_length_names_both_spellings(tmp_path: Path) -> None:
    file = tmp_path / "no_y.csv"
    file.write_text("t_s,x_mm,z_mm\n0,1,0\n1,2,0\n")
    with pytest.raises(
        DataFileError,
        match=r"missing column\(s\) \['y_mm'\] \(a length may be declared in metres instead: \['y_m'\]\)",
    ):
        read_si_table(file, ("t_s", *POSITIONS))


def test_a_standing_path_says_nothing_of_its_unit(tmp_path: Path) -> None:
    t = np.arange(0.0, 1.0, 0.02)
    file = write_path(tmp_path / "still.csv", Stream(t, np.tile([1e-3, 0.0, -1e-3], (t.size, 1))), scale=1.0)
    assert read_commanded_csv(file).values.shape == (t.size, 3)


def test_moving_speed_leaves_dwells_and_standing_noise_out() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    x = np.clip(FEED_M_S * (t - 8.0), 0.0, None)  # stands 80 % of the time, then moves at 2 m/min
    flicker = 1e-7 * (np.arange(t.size) % 2)  # a quantised tracker's last digit while standing
    p = np.column_stack([x + flicker, np.zeros_like(t), np.zeros_like(t)])
    assert moving_median_speed(t, p) == pytest.approx(FEED_M_S, rel=0.01)
    assert moving_median_speed(t, np.zeros((t.size, 3))) is None


def test_point_spacing_refuses_metres_whatever_the_part_size(tmp_path: Path) -> None:
    for width_mm in (10.0, 500.0):
        x = np.linspace(-width_mm / 2, width_mm / 2, 201)
        good = write_table(tmp_path / "good.csv", {"x_mm": x, "z_mm": -0.1 * np.abs(x)})
        check_point_spacing(read_si_table(good, ("x_mm", "z_mm")), ("x_mm", "z_mm"))
        declared = write_table(
            tmp_path / "m.csv", {"x_m": x / 1e3, "z_m": -1e-4 * np.abs(x)}, formats={"x_m": ".7f"}
        )
        check_point_spacing(read_si_table(declared, ("x_mm", "z_mm")), ("x_mm", "z_mm"))
        wrong = write_table(
            tmp_path / "wrong.csv", {"x_mm": x / 1e3, "z_mm": -1e-4 * np.abs(x)}, formats={"x_mm": ".7f"}
        )
        with pytest.raises(
            UnitsError,
            match=r"wrong\.csv: columns 'x_mm', 'z_mm' hold points all within .* columns to 'x_m', 'z_m'",
        ):
            check_point_spacing(read_si_table(wrong, ("x_mm", "z_mm")), ("x_mm", "z_mm"))


def test_path_speed_is_checked_only_for_columns_declared_in_mm(tmp_path: Path) -> None:
    path = circle(0.010)
    declared = read_si_table(write_path(tmp_path / "m.csv", path, unit="m"), ("t_s", "x_mm", "y_mm", "z_mm"))
    check_path_speed(declared, POSITIONS)  # metres declared: trusted


def test_run_streams_and_part_files_with_metres_under_mm_names_raise(tmp_path: Path) -> None:
    run = small_run(0.010)
    directory = write_run(tmp_path / "run", run)
    write_path(directory / "tracker.csv", run.tracker, scale=1.0)
    with pytest.raises(UnitsError, match=r"tracker\.csv: columns 'x_mm', 'y_mm', 'z_mm' move at"):
        read_run(directory, require_forces=False)
    write_path(directory / "tracker.csv", run.tracker)
    assert run.part_profile is not None and run.part_scan is not None
    write_table(
        directory / "part_profile.csv",
        {"x_mm": run.part_profile[0], "z_mm": run.part_profile[1]},
        formats={"x_mm": ".7f", "z_mm": ".7f"},
    )
    with pytest.raises(UnitsError, match=r"part_profile\.csv: columns 'x_mm', 'z_mm' hold points"):
        read_run(directory, require_forces=False)
    (directory / "part_profile.csv").unlink()
    write_table(
        directory / "part_scan.csv",
        dict(zip(POSITIONS, run.part_scan.T, strict=True)),
        formats=dict.fromkeys(POSITIONS, ".7f"),
    )
    with pytest.raises(UnitsError, match=r"part_scan\.csv: columns 'x_mm', 'y_mm', 'z_mm' hold points"):
        read_run(directory, require_forces=False)


def test_fe_history_in_metre_columns_loads_like_the_one_in_mm(tmp_path: Path) -> None:
    s = np.linspace(0.0, 80.0, 161)
    x, z = s - 35.0, -np.minimum(s, 10.0) / 10.0
    forces = {"fx_half_n": 10.0 + 0 * s, "fz_half_n": 500.0 + s}
    in_mm = write_table(tmp_path / "mm.csv", {"s_mm": s, "x_mm": x, "z_mm": z, **forces})
    in_m = write_table(
        tmp_path / "m.csv",
        {"s_m": s / 1e3, "x_m": x / 1e3, "z_m": z / 1e3, **forces},
        formats={"s_m": ".9f", "x_m": ".9f", "z_m": ".9f"},
    )
    a, b = load_force_history(in_mm, symmetry="half"), load_force_history(in_m, symmetry="half")
    np.testing.assert_allclose(b.s_m, a.s_m, atol=1e-12)
    np.testing.assert_allclose(b.p_sheet_m, a.p_sheet_m, atol=1e-12)
    np.testing.assert_array_equal(b.f_sheet_n, a.f_sheet_n)
