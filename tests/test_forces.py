"""Tests of the FE force-history loader (twin/process/fe/load.py): the symmetry declaration and bad files."""

from __future__ import annotations

import numpy as np
import pytest

from twin.base.csvio import read_table
from twin.base.resources import data_file
from twin.errors import DataFileError, SymmetryError, UnitsError
from twin.process.fe.load import default_force_history, load_force_history

SHIPPED = data_file("fe_force_history.csv")

HEADER_HALF = "s_mm,x_mm,z_mm,fx_half_n,fy_sym_n,fz_half_n\n"
GOOD_HALF = HEADER_HALF + "0,-35,0,-1,-2,10\n1,-34,-0.5,-100,-90,400\n2,-33,-1,-120,-95,450\n"
GOOD_FULL = (
    "t_s,x_mm,z_mm,fx_n,fy_n,fz_n\n0,-35,0,-2,3,20\n0.03,-34,-0.5,-200,4,800\n0.06,-33,-1,-240,5,900\n"
)


def _write(tmp_path, text, name="h.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_load_raises_if_symmetry_missing_or_invalid(tmp_path):
    path = _write(tmp_path, GOOD_HALF)
    with pytest.raises(TypeError):
        load_force_history(path)  # type: ignore[call-arg]
    for bad in (None, "", "Half", "quarter"):
        with pytest.raises(SymmetryError, match=r"doubl"):
            load_force_history(path, symmetry=bad)  # type: ignore[arg-type]


def test_half_doubles_fx_and_fz_and_zeroes_fy():
    raw = read_table(SHIPPED, ("fx_half_n", "fy_sym_n", "fz_half_n"))
    history = load_force_history(SHIPPED, symmetry="half")
    np.testing.assert_array_equal(history.f_sheet_n[:, 0], 2 * raw["fx_half_n"])
    np.testing.assert_array_equal(history.f_sheet_n[:, 2], 2 * raw["fz_half_n"])
    assert np.all(history.f_sheet_n[:, 1] == 0.0)
    assert history.symmetry == "half" and history.source == SHIPPED


def test_default_history_is_the_shipped_file_loaded_as_half():
    history = default_force_history()
    assert history.symmetry == "half"
    assert history.p_sheet_m.shape == (1311, 3) and history.s_m.shape == (1311,)
    assert history.p_sheet_m[0, 0] == pytest.approx(-0.035)
    assert history.f_sheet_n[:, 2].max() > 1500.0


def test_full_model_export_with_time_column_loads_unscaled(tmp_path):
    history = load_force_history(_write(tmp_path, GOOD_FULL), symmetry="full")
    np.testing.assert_allclose(history.f_sheet_n[:, 2], [20, 800, 900])
    np.testing.assert_allclose(history.f_sheet_n[:, 1], [3, 4, 5])
    np.testing.assert_allclose(history.s_m[-1], 2 * np.hypot(1.0, 0.5) / 1e3)


def test_half_named_columns_declared_full_raise_naming_file_and_columns(tmp_path):
    path = _write(tmp_path, GOOD_HALF)
    with pytest.raises(SymmetryError, match=r"h\.csv.*fx_half_n"):
        load_force_history(path, symmetry="full")


def test_full_named_columns_declared_half_raise(tmp_path):
    with pytest.raises(SymmetryError, match=r"fx_n"):
        load_force_history(_write(tmp_path, GOOD_FULL), symmetry="half")


def test_escape_hatch_reproduces_the_thesis_mistake_of_half_forces():
    right = load_force_history(SHIPPED, symmetry="half")
    wrong = load_force_history(SHIPPED, symmetry="full", trust_columns=False)
    np.testing.assert_allclose(wrong.f_sheet_n, right.f_sheet_n / 2)


@pytest.mark.parametrize(
    ("text", "error", "pattern"),
    [
        ("s_mm,x_mm,z_mm,fx_half_n\n0,-35,0,1\n1,-34,-1,2\n", DataFileError, r"fz_half_n"),
        ("s_mm,x_mm,fx_half_n,fz_half_n\n0,-35,1,2\n1,-34,1,2\n", DataFileError, r"z_mm"),
        ("x_mm,z_mm,fx_half_n,fz_half_n\n-35,0,1,2\n-34,-1,1,2\n", DataFileError, r"s_mm"),
        (GOOD_HALF.replace("-100", "nan"), DataFileError, r"row 2"),
        (GOOD_HALF.replace("\n1,-34", "\n3,-34"), DataFileError, r"s_mm.*increasing"),
        (GOOD_HALF.replace("\n2,-33", "\n1,-33"), DataFileError, r"row 3"),
        (GOOD_HALF.rstrip("\n").rsplit(",", 2)[0] + "\n", DataFileError, r"row 3.*truncated"),
        (
            "s_mm,x_mm,z_mm,fx_half_n,fz_half_n\n0,-0.035,0,1,2\n0.001,-0.034,-0.0005,1,2\n0.002,-0.033,-0.001,1,2\n",
            UnitsError,
            r"metres",
        ),
    ],
    ids=["no-fz", "no-z", "no-s-or-t", "nan", "unsorted-s", "repeated-s", "truncated", "metres"],
)
def test_bad_files_raise_clear_errors_naming_the_file(tmp_path, text, error, pattern):
    path = _write(tmp_path, text, "bad.csv")
    with pytest.raises(error, match=pattern) as info:
        load_force_history(path, symmetry="half")
    assert "bad.csv" in str(info.value)


def test_history_records_what_its_columns_say_even_when_declared_otherwise() -> None:
    from twin.base.resources import data_file

    mistaken = load_force_history(data_file("fe_force_history.csv"), symmetry="full", trust_columns=False)
    assert (mistaken.symmetry, mistaken.column_symmetry) == ("full", "half")
    correct = load_force_history(data_file("fe_force_history.csv"), symmetry="half")
    assert correct.column_symmetry == correct.symmetry == "half"
    np.testing.assert_allclose(correct.f_sheet_n[:, [0, 2]], 2.0 * mistaken.f_sheet_n[:, [0, 2]])
