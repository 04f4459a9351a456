"""Tests of the stand-in FE force history generator and the shipped file (twin/process/fe/generator.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.base.csvio import read_table
from twin.base.resources import data_file
from twin.cli import main
from twin.errors import InputError
from twin.process.fe.generator import FE_SAMPLES, generate_history, stand_in_level_n, write_history
from twin.process.fe.load import load_force_history
from twin.process.toolpath.groove import groove_path, label_passes, resample_by_arc_length

COLUMNS = ("s_mm", "x_mm", "z_mm", "fx_half_n", "fy_sym_n", "fz_half_n")


def test_shipped_file_has_1311_rows_and_the_half_model_columns():
    table = read_table(data_file("fe_force_history.csv"), COLUMNS)
    assert FE_SAMPLES == 1311
    assert all(len(v) == 1311 for v in table.values())
    np.testing.assert_allclose(np.diff(table["s_mm"]), table["s_mm"][-1] / 1310, atol=1.5e-4)


def test_physical_peak_fz_is_about_2_kn_and_fx_a_third_of_it():
    history = load_force_history(data_file("fe_force_history.csv"), symmetry="half")
    fx, fz = history.f_sheet_n[:, 0], history.f_sheet_n[:, 2]
    assert 1500.0 <= fz.max() <= 2500.0
    assert np.all(fz >= 0.0)
    ratio = np.abs(fx[fz > 500]) / fz[fz > 500]
    assert ratio.max() <= 0.40
    assert 0.25 <= np.median(ratio) <= 0.40


def test_fx_opposes_travel_and_changes_sign_at_every_reversal():
    h = generate_history()
    # the history's own samples, labelled geometrically (label_passes may give the one sample just past a
    # reversal corner to the old pass, since x alone cannot tell)
    labelled = resample_by_arc_length(groove_path(), FE_SAMPLES)
    np.testing.assert_allclose(labelled.p_sheet_m[:, 0] * 1e3, h["x_mm"], atol=1e-4)
    pass_index, direction = labelled.pass_index, labelled.direction
    assert np.mean(label_passes(h["x_mm"] / 1e3)[0] == pass_index) > 0.99
    reversals = np.flatnonzero(np.diff(pass_index))
    assert len(reversals) == 9
    for b in reversals:
        before, after = h["fx_half_n"][b - 3], h["fx_half_n"][b + 4]
        assert np.sign(before) == -direction[b] and np.sign(after) == -direction[b + 1]
    moving = np.abs(h["fx_half_n"]) > 20.0  # away from the reversal points themselves
    assert moving.sum() > 1200
    assert np.all(np.sign(h["fx_half_n"][moving]) * direction[moving] <= 0)


def test_fy_sym_is_nonzero_where_the_tool_forms():
    h = generate_history()
    assert np.all(np.abs(h["fy_sym_n"][h["fz_half_n"] > 50]) > 10.0)


def test_the_stand_in_level_is_1_7_kn_and_the_published_formula_puts_the_groove_at_1_2_kn():
    """The stand-in's level reads Aerens's Δh as the step-down; as published (scallop height) it is 1.20 kN."""
    assert stand_in_level_n(275.0, 1.0, 15.0, 1.0, 63.4349) == pytest.approx(1695.0, rel=0.01)
    scallop_mm = 7.5 - math.sqrt(7.5**2 - (0.5 / math.sin(math.radians(63.4349))) ** 2)
    assert stand_in_level_n(275.0, 1.0, 15.0, scallop_mm, 63.4349) == pytest.approx(1200.0, rel=0.01)


def test_generator_reproduces_the_shipped_file_bit_for_bit(tmp_path):
    out = write_history(tmp_path / "fe.csv")
    assert out.read_bytes() == data_file("fe_force_history.csv").read_bytes()


def test_fe_history_command_regenerates_the_file(tmp_path, capsys):
    assert main(["fe-history", "--out", str(tmp_path / "h.csv")]) == 0
    assert "1311 samples" in capsys.readouterr().out
    assert (tmp_path / "h.csv").read_bytes() == data_file("fe_force_history.csv").read_bytes()


def test_the_shipped_taper_keeps_fx_until_the_tool_reverses() -> None:
    """The shipped (`since`) Fx tapers only after each reversal; the old `nearest` variant already before it."""
    shipped, acausal = generate_history(), generate_history(fx_taper="nearest")
    np.testing.assert_array_equal(shipped["fz_half_n"], acausal["fz_half_n"])
    first_reversal = int(np.argmax(shipped["x_mm"]))  # pass 1 runs towards +x
    before = slice(first_reversal - 3, first_reversal)
    assert np.all(np.abs(shipped["fx_half_n"][before]) > np.abs(acausal["fx_half_n"][before]) + 1.0)
    ratio = np.abs(shipped["fx_half_n"][before]) / shipped["fz_half_n"][before]
    assert np.all(ratio > 0.30)  # the full in-plane ratio (and the clamp rise) up to the corner
    with pytest.raises(InputError, match="fx_taper"):
        generate_history(fx_taper="both")
