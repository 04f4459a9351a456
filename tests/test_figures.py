"""Tests of the figures (twin/viz/*_figures.py): every plot writes a sane PNG from synthetic data and rejects bad shapes."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from twin.errors import InputError
from twin.viz.deflection_figures import plot_deflection_by_pass, plot_residual_before_after
from twin.viz.path_figures import plot_forces, plot_path_xz
from twin.viz.stiffness_figures import plot_stiffness_ellipse

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
C_R1_MM_PER_KN = np.array([[1.54, 0.19], [0.79, 1.02]])  # thesis Eq. 4.27
C_R2_MM_PER_KN = np.array([[1.67, 0.68], [0.53, 0.95]])  # thesis Eq. 4.27


def _groove(n_pass: int = 4, per_pass: int = 60) -> dict[str, np.ndarray]:
    """Zig-zag passes, each 1 mm deeper, with forces and the deflection C_R(1)·F."""
    pass_index = np.repeat(np.arange(1, n_pass + 1), per_pass)
    direction = np.where(pass_index % 2 == 1, 1.0, -1.0)
    s = np.tile(np.linspace(0.0, 1.0, per_pass), n_pass)
    x = direction * (-0.035 + 0.07 * s)
    z = -0.001 * (pass_index - 1 + s)
    p = np.column_stack([x, np.zeros_like(x), z])
    f = np.column_stack([-direction * (200 + 2e4 * -z), np.zeros_like(x), 800 + 1.2e5 * -z])
    deflection = np.zeros_like(p)
    deflection[:, [0, 2]] = f[:, [0, 2]] @ (C_R1_MM_PER_KN * 1e-6).T
    t = np.arange(len(x)) * 0.02
    return {"t": t, "p": p, "f": f, "d": deflection, "pass": pass_index, "dir": direction}


def _assert_png(path: Path) -> None:
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    width, height = struct.unpack(">II", data[16:24])  # IHDR
    assert (width, height) == (960, 600)  # 8 x 5 in at 120 dpi
    assert 20_000 < len(data) < 2_000_000
    assert not list(path.parent.glob(".*.tmp"))  # no temporary file left behind


def test_plot_path_xz_writes_png_with_equal_sampling(tmp_path: Path):
    g = _groove()
    out = plot_path_xz(
        tmp_path / "path.png", g["p"], g["p"] + g["d"], p_commanded_sheet_m=g["p"] - g["d"]
    )
    assert out == tmp_path / "path.png"
    _assert_png(out)


def test_plot_path_xz_pairs_differently_sampled_paths_by_time(tmp_path: Path):
    g = _groove()
    measured = (g["p"] + g["d"])[::2]
    out = plot_path_xz(
        tmp_path / "sub" / "path.png", g["p"], measured, t_ideal_s=g["t"], t_measured_s=g["t"][::2]
    )
    _assert_png(out)


def test_plot_path_xz_raises_if_paths_cannot_be_paired(tmp_path: Path):
    g = _groove()
    with pytest.raises(InputError, match="t_ideal_s"):
        plot_path_xz(tmp_path / "path.png", g["p"], g["p"][::2])
    assert not (tmp_path / "path.png").exists()


def test_plot_forces_writes_png_with_and_without_ideal(tmp_path: Path):
    g = _groove()
    _assert_png(plot_forces(tmp_path / "f1.png", g["t"], g["f"]))
    _assert_png(
        plot_forces(
            tmp_path / "f2.png", g["t"], g["f"], t_ideal_s=g["t"][::3], f_ideal_n=g["f"][::3, [0, 2]]
        )
    )


def test_plot_deflection_by_pass_writes_png(tmp_path: Path):
    g = _groove()
    _assert_png(
        plot_deflection_by_pass(tmp_path / "d.png", g["p"][:, 0], g["d"], g["pass"], g["dir"])
    )


def test_plot_residual_before_after_writes_png(tmp_path: Path):
    g = _groove()
    out = plot_residual_before_after(
        tmp_path / "r.png", g["t"], g["d"], 0.1 * g["d"], label_before="nominal", label_after="compensated"
    )
    _assert_png(out)


def test_plot_stiffness_ellipse_writes_png(tmp_path: Path):
    out = plot_stiffness_ellipse(
        tmp_path / "e.png", [C_R1_MM_PER_KN, C_R2_MM_PER_KN, np.eye(2)], ["C_R(1)", "C_R(2)", "twin"]
    )
    _assert_png(out)


def test_plot_overwrites_an_existing_file(tmp_path: Path):
    target = tmp_path / "e.png"
    target.write_bytes(b"old")
    plot_stiffness_ellipse(target, [C_R1_MM_PER_KN], ["C_R(1)"])
    _assert_png(target)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda g, p: plot_path_xz(p, g["p"][:, 0], g["p"]), "p_ideal_sheet_m"),
        (lambda g, p: plot_path_xz(p, g["p"], g["p"][:, :1]), "p_measured_sheet_m"),
        (lambda g, p: plot_forces(p, g["t"][:-1], g["f"]), "same number"),
        (lambda g, p: plot_forces(p, g["t"], g["f"], t_ideal_s=g["t"]), "both"),
        (lambda g, p: plot_forces(p, g["t"], np.full_like(g["f"], np.nan)), "NaN"),
        (
            lambda g, p: plot_deflection_by_pass(p, g["p"][:, 0], g["d"], g["pass"], 2 * g["dir"]),
            "direction",
        ),
        (
            lambda g, p: plot_deflection_by_pass(p, g["p"][:, 0], g["d"], g["pass"][:-1], g["dir"]),
            "same",
        ),
        (lambda g, p: plot_residual_before_after(p, g["t"], g["d"], g["d"][:, [0, 2]]), "shapes"),
        (lambda g, p: plot_stiffness_ellipse(p, [np.eye(3)], ["3x3"]), r"\(2, 2\)"),
        (lambda g, p: plot_stiffness_ellipse(p, [np.eye(2)], ["a", "b"]), "labels"),
        (lambda g, p: plot_stiffness_ellipse(p, [], []), "at least one"),
    ],
)
def test_plots_raise_input_error_on_bad_shapes(tmp_path: Path, call, match: str):
    with pytest.raises(InputError, match=match):
        call(_groove(), tmp_path / "bad.png")
    assert list(tmp_path.iterdir()) == []
