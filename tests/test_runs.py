"""Tests of the run directory format `tx200-twin-run/1` (twin/runs/format.py, read.py, write.py)."""

from __future__ import annotations

import builtins
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from twin.errors import DataFileError, InputError, RunFormatError, UnitsError
from twin.runs.format import RUN_FORMAT, Run, Stream, resample
from twin.runs.read import read_run
from twin.runs.write import write_run


def make_run(seed: int = 0, *, with_forces: bool = True, with_profile: bool = True) -> Run:
    """A small synthetic run: a 70 mm stroke at 33.33 mm/s, tracker 50 Hz, sensor 30 Hz."""
    rng = np.random.default_rng(seed)
    t_cmd = np.linspace(0.0, 2.1, 43)
    x_cmd = -0.035 + 0.07 * t_cmd / 2.1
    commanded = Stream(t_cmd, np.column_stack([x_cmd, np.zeros_like(t_cmd), -0.001 * t_cmd / 2.1]))
    t_trk = np.arange(0.0, 2.1, 1.0 / 50.0)
    p_trk = np.column_stack(
        [np.interp(t_trk, t_cmd, x_cmd) - 0.0012, np.zeros_like(t_trk), np.full_like(t_trk, 0.0008)]
    )
    tracker = Stream(t_trk, p_trk + rng.normal(0.0, 4e-5, p_trk.shape))
    forces = None
    if with_forces:
        t_f = np.arange(0.0, 2.1, 1.0 / 30.0)
        forces = Stream(t_f, np.column_stack([-200.0 + 0 * t_f, 5.0 + 0 * t_f, 1500.0 + 100.0 * t_f]))
    profile = None
    if with_profile:
        x_p = np.linspace(-0.05, 0.05, 101)
        profile = (x_p, -0.0087 * (np.abs(x_p) < 0.03))
    meta: dict[str, Any] = {
        "scenario": "nominal",
        "tool_length_m": 0.27494,
        "tracker_rate_hz": 50,
        "notes": "synthetic test run",
    }
    if with_forces:
        meta["sensor_rate_hz"] = 30
    return Run(None, meta, commanded, tracker, forces, profile)


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    return write_run(tmp_path / "run", make_run(), truth={"effects": {"backlash": True}, "k_q": [1e6] * 6})


def rewrite_csv(path: Path, edit) -> None:
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")


def test_write_read_round_trip_keeps_values_to_the_written_precision(tmp_path: Path) -> None:
    run = make_run()
    written = write_run(tmp_path / "run", run)
    back = read_run(written)
    assert back.directory == written
    assert back.meta["format"] == RUN_FORMAT and back.meta["frame"] == "sheet"
    assert back.scenario == "nominal" and back.tracker_rate_hz == 50.0 and back.sensor_rate_hz == 30.0
    np.testing.assert_allclose(back.commanded.values, run.commanded.values, atol=0.6e-7)  # 4 decimals in mm
    np.testing.assert_allclose(back.tracker.values, run.tracker.values, atol=0.6e-7)
    np.testing.assert_allclose(back.tracker.t_s, run.tracker.t_s, atol=1e-6)
    assert back.forces is not None and run.forces is not None
    np.testing.assert_allclose(back.forces.values, run.forces.values, atol=0.6e-3)  # 3 decimals in N
    assert back.part_profile is not None
    np.testing.assert_allclose(back.part_profile[1], run.part_profile[1], atol=0.6e-7)  # type: ignore[index]


def test_read_run_without_forces_when_not_required(tmp_path: Path) -> None:
    written = write_run(tmp_path / "run", make_run(with_forces=False, with_profile=False))
    back = read_run(written, require_forces=False)
    assert back.forces is None and back.part_profile is None and back.sensor_rate_hz is None
    with pytest.raises(RunFormatError, match=r"forces\.csv.*file not found"):
        read_run(written)


def test_read_run_works_with_truth_deleted(run_dir: Path) -> None:
    (run_dir / "truth.json").unlink()
    assert read_run(run_dir).scenario == "nominal"


def test_read_run_never_opens_truth_json(run_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (run_dir / "truth.json").unlink()
    (run_dir / "truth.json").mkdir()  # opening it would raise IsADirectoryError
    real_open = builtins.open
    real_path_open = Path.open

    def guarded_open(file: Any, *args: Any, **kwargs: Any) -> Any:
        assert "truth" not in str(file), f"read_run opened {file}"
        return real_open(file, *args, **kwargs)

    def guarded_path_open(self: Path, *args: Any, **kwargs: Any) -> Any:
        assert "truth" not in self.name, f"read_run opened {self}"
        return real_path_open(self, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", guarded_open)
    monkeypatch.setattr(Path, "open", guarded_path_open)
    monkeypatch.setattr(Path, "read_text", lambda self, *a, **k: guarded_path_open(self).read())
    assert read_run(run_dir).tracker.values.shape == (105, 3)


def test_write_run_writes_truth_only_when_given(tmp_path: Path) -> None:
    plain = write_run(tmp_path / "plain", make_run())
    assert not (plain / "truth.json").exists()
    lab = write_run(tmp_path / "lab", make_run(), truth={"k_q": [1.0]})
    assert json.loads((lab / "truth.json").read_text()) == {"k_q": [1.0]}
    assert "k_q" not in json.loads((lab / "meta.json").read_text())


def test_write_run_refuses_non_empty_directory_unless_overwrite(run_dir: Path) -> None:
    with pytest.raises(InputError, match="not empty"):
        write_run(run_dir, make_run(seed=1))
    write_run(run_dir, make_run(seed=1, with_forces=False), overwrite=True)
    assert not (run_dir / "forces.csv").exists() and not (run_dir / "truth.json").exists()
    assert read_run(run_dir, require_forces=False).forces is None
    assert not [p for p in run_dir.parent.iterdir() if p.name.startswith(".")]  # no temporaries left


def test_write_run_never_writes_into_a_directory_holding_an_input(run_dir: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="holds the input"):
        write_run(run_dir, make_run(), overwrite=True, protect=[run_dir / "tracker.csv"])
    loaded = read_run(run_dir)
    with pytest.raises(InputError, match="holds the input"):
        write_run(run_dir, loaded, overwrite=True)  # the run's own directory is protected
    assert (run_dir / "truth.json").is_file()


def test_write_run_rejects_a_run_the_reader_would_reject(tmp_path: Path) -> None:
    bad = make_run()
    bad = Run(None, {**bad.meta, "tracker_rate_hz": 100}, bad.commanded, bad.tracker, bad.forces, None)
    with pytest.raises(InputError, match=r"tracker\.csv.*100 Hz"):
        write_run(tmp_path / "run", bad)
    assert not (tmp_path / "run").exists()
    assert not list(tmp_path.iterdir())


def test_missing_directory_and_files_are_named(run_dir: Path, tmp_path: Path) -> None:
    with pytest.raises(RunFormatError, match="run directory not found"):
        read_run(tmp_path / "nope")
    (run_dir / "commanded.csv").unlink()
    with pytest.raises(RunFormatError, match=r"commanded\.csv: file not found"):
        read_run(run_dir)


@pytest.mark.parametrize(
    ("name", "edit", "pattern"),
    [
        (
            "tracker.csv",
            lambda ls: [ls[0].replace("y_mm", "why_mm"), *ls[1:]],
            r"tracker\.csv: missing column",
        ),
        (
            "tracker.csv",
            lambda ls: [*ls[:4], ls[4].replace(ls[4].split(",")[2], "nan", 1), *ls[5:]],
            r"tracker\.csv, row 4: .*finite",
        ),
        (
            "forces.csv",
            lambda ls: [*ls[:6], ",".join(ls[6].split(",")[:2]), *ls[7:]],
            r"forces\.csv, row 6: .*truncated",
        ),
        (
            "commanded.csv",
            lambda ls: [*ls[:3], ls[2], *ls[4:]],
            r"commanded\.csv, row 3: .*strictly increasing",
        ),
        ("commanded.csv", lambda ls: [], r"commanded\.csv: file is empty"),
        ("forces.csv", lambda ls: ls[:1], r"forces\.csv: has 0 data row"),
    ],
    ids=["wrong-column", "nan", "truncated", "time-not-increasing", "empty", "header-only"],
)
def test_bad_csv_raises_run_format_error_naming_file_and_row(
    run_dir: Path, name: str, edit, pattern: str
) -> None:
    rewrite_csv(run_dir / name, edit)
    with pytest.raises(RunFormatError, match=pattern):
        read_run(run_dir)


def test_extra_columns_are_ignored(run_dir: Path) -> None:
    rewrite_csv(run_dir / "tracker.csv", lambda ls: [ls[0] + ",quality", *(line + ",1" for line in ls[1:])])
    assert read_run(run_dir).tracker.values.shape == (105, 3)


def metres(lines: list[str]) -> list[str]:
    out = [lines[0]]
    for line in lines[1:]:
        t, *xyz = line.split(",")
        out.append(",".join([t, *(f"{float(v) / 1000:.7f}" for v in xyz)]))
    return out


@pytest.mark.parametrize("name", ["commanded.csv", "tracker.csv"])
def test_metres_in_mm_columns_raise_units_error(run_dir: Path, name: str) -> None:
    rewrite_csv(run_dir / name, metres)
    pattern = rf"{name}: columns 'x_mm', 'y_mm', 'z_mm' move at a median .*metres"
    with pytest.raises(UnitsError, match=pattern):
        read_run(run_dir)


@pytest.mark.parametrize(
    ("change", "pattern"),
    [
        (
            {"format": "tx200-twin-run/0"},
            r"meta\.json: format is 'tx200-twin-run/0', expected 'tx200-twin-run/1'",
        ),
        ({"frame": "base"}, r"meta\.json: frame is 'base', expected 'sheet'"),
        ({"tracker_rate_hz": 100}, r"tracker\.csv: .*50 Hz but meta\.json tracker_rate_hz is 100 Hz"),
        ({"sensor_rate_hz": 31.6}, r"forces\.csv: .*30 Hz but meta\.json sensor_rate_hz is 31\.6 Hz"),
        ({"tracker_rate_hz": "fifty"}, r"tracker_rate_hz is 'fifty', expected a positive number"),
    ],
)
def test_bad_meta_raises(run_dir: Path, change: dict[str, Any], pattern: str) -> None:
    meta = json.loads((run_dir / "meta.json").read_text())
    (run_dir / "meta.json").write_text(json.dumps({**meta, **change}))
    with pytest.raises(RunFormatError, match=pattern):
        read_run(run_dir)


def test_rate_within_five_percent_is_accepted(run_dir: Path) -> None:
    meta = json.loads((run_dir / "meta.json").read_text())
    (run_dir / "meta.json").write_text(json.dumps({**meta, "sensor_rate_hz": 31.4}))
    assert read_run(run_dir).sensor_rate_hz == 31.4


def test_missing_meta_key_is_named(run_dir: Path) -> None:
    meta = json.loads((run_dir / "meta.json").read_text())
    del meta["tool_length_m"]
    (run_dir / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(RunFormatError, match=r"meta\.json: missing key\(s\) \['tool_length_m'\]"):
        read_run(run_dir)


def shift_time(offset_s: float):
    def edit(lines: list[str]) -> list[str]:
        out = [lines[0]]
        for line in lines[1:]:
            t, *rest = line.split(",")
            out.append(",".join([f"{float(t) + offset_s:.6f}", *rest]))
        return out

    return edit


def test_streams_on_another_clock_raise(run_dir: Path) -> None:
    rewrite_csv(run_dir / "tracker.csv", shift_time(1.5))
    with pytest.raises(RunFormatError, match=r"tracker\.csv, row 1: starts at t_s = 1\.5 s.*share a clock"):
        read_run(run_dir)


def test_tracker_offset_below_one_second_is_accepted(run_dir: Path) -> None:
    rewrite_csv(run_dir / "tracker.csv", shift_time(0.3))
    assert read_run(run_dir).tracker.t_s[0] == pytest.approx(0.3)


def test_commanded_path_must_start_at_zero(run_dir: Path) -> None:
    rewrite_csv(run_dir / "commanded.csv", shift_time(0.2))
    with pytest.raises(RunFormatError, match=r"commanded\.csv, row 1: t_s starts at 0\.2 s, expected 0"):
        read_run(run_dir)


def test_run_errors_are_data_file_errors_with_row(run_dir: Path) -> None:
    rewrite_csv(
        run_dir / "forces.csv", lambda ls: [*ls[:10], ls[10].replace(ls[10].split(",")[3], "abc"), *ls[11:]]
    )
    with pytest.raises(DataFileError) as info:
        read_run(run_dir)
    assert info.value.row == 10 and info.value.path.name == "forces.csv"


def test_resample_interpolates_linearly_and_refuses_extrapolation() -> None:
    t = np.array([0.0, 1.0, 2.0])
    stream = Stream(t, np.column_stack([t, 2 * t, -t]))
    np.testing.assert_allclose(
        resample(stream, np.array([0.5, 1.25])), [[0.5, 1.0, -0.5], [1.25, 2.5, -1.25]]
    )
    np.testing.assert_allclose(
        resample(stream, np.array([-0.4, 2.4]))[:, 0], [0.0, 2.0]
    )  # within half a sample
    with pytest.raises(InputError, match="half a sample"):
        resample(stream, np.array([2.6]))


def test_stream_rejects_bad_shapes_and_nan() -> None:
    with pytest.raises(InputError, match="expected equal"):
        Stream(np.arange(3.0), np.zeros((4, 3)))
    with pytest.raises(InputError, match="NaN"):
        Stream(np.array([0.0, np.nan]), np.zeros((2, 3)))
    with pytest.raises(InputError, match="strictly increasing"):
        Stream(np.array([0.0, 0.0]), np.zeros((2, 3)))
    stream = Stream(np.arange(2.0), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="read-only"):
        stream.values[0, 0] = 1.0
