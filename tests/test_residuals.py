"""Tests of the residual model (twin/analysis/discrepancy/residuals.py): noise estimated from data alone, normalised residuals."""

from __future__ import annotations

import numpy as np
import pytest

from twin.analysis.discrepancy.residuals import Noise, ResidualModel, estimate_noise, second_difference_noise
from twin.lab.virtual import LabSettings, run_lab
from twin.runs.format import Run
from twin.sim.effects import Effects
from twin.sim.spec import TwinSpec

SETTINGS = LabSettings()
DRIFT_SEED = 31


def smooth_signal(t_s: np.ndarray) -> np.ndarray:
    """A smooth 3-D signal with a few reversals, like a tool tip on a zig-zag path [mm-ish units]."""
    return np.column_stack([35.0 * np.sin(2 * np.pi * 0.1 * t_s), 0.5 * t_s - 0.01 * t_s**2, np.cos(0.7 * t_s)])


@pytest.mark.parametrize(("sigma", "seed"), [(0.02, 1), (5.0, 2), (1e-5, 3)])
def test_second_difference_noise_recovers_the_sigma_of_white_noise_on_a_smooth_signal(
    sigma: float, seed: int
) -> None:
    t_s = np.arange(0.0, 20.0, 1.0 / 50.0)
    scale = sigma / 0.02  # the signal's scale follows the noise so that signal/noise stays realistic
    clean = scale * smooth_signal(t_s)
    noisy = clean + np.random.default_rng(seed).normal(0.0, sigma, clean.shape)
    assert second_difference_noise(noisy) == pytest.approx(sigma, rel=0.10)
    assert second_difference_noise(noisy[:, 2]) == pytest.approx(sigma, rel=0.10)
    # the smooth signal alone is (almost) noise-free by this estimator
    assert second_difference_noise(clean) < 0.05 * sigma


def test_second_difference_noise_ignores_a_few_kinks() -> None:
    t_s = np.arange(0.0, 20.0, 1.0 / 50.0)
    zigzag = np.abs(((t_s / 2.0) % 2.0) - 1.0)  # a triangle wave: ten sharp reversals
    noisy = zigzag + np.random.default_rng(4).normal(0.0, 0.01, t_s.shape)
    assert second_difference_noise(noisy) == pytest.approx(0.01, rel=0.10)


def test_second_difference_noise_is_nan_for_too_few_samples() -> None:
    assert np.isnan(second_difference_noise(np.array([1.0, 2.0, 4.0, 3.0])))


def test_estimate_noise_recovers_the_lab_sensor_noise(clean_run: Run) -> None:
    noise = estimate_noise(clean_run)
    assert noise.position_m == pytest.approx(SETTINGS.tracker_noise_m, rel=0.10)
    assert noise.force_n == pytest.approx(SETTINGS.ft_noise_n, rel=0.10)
    # the profile has only 181 points and the groove walls' curvature: a looser bound
    assert noise.profile_m == pytest.approx(SETTINGS.profile_noise_m, rel=0.40)
    summary = noise.summary()
    assert summary["position_mm"] == pytest.approx(1e3 * noise.position_m)
    assert set(summary) == {"position_mm", "force_n", "profile_mm"}


def test_estimate_noise_of_a_run_without_forces_or_profile_is_nan_there(clean_run: Run) -> None:
    bare = Run(None, dict(clean_run.meta), clean_run.commanded, clean_run.tracker)
    noise = estimate_noise(bare)
    assert noise.position_m == pytest.approx(SETTINGS.tracker_noise_m, rel=0.10)
    assert np.isnan(noise.force_n)
    assert np.isnan(noise.profile_m)


@pytest.fixture(scope="module")
def clean_model(clean_run: Run) -> ResidualModel:
    return ResidualModel(clean_run)


def test_vector_of_a_clean_run_has_reduced_chi_square_one(clean_model: ResidualModel) -> None:
    vector = clean_model.vector(Effects())
    chi2 = float(np.mean(vector**2))
    assert 0.8 <= chi2 <= 1.2, chi2
    streams = clean_model.streams(Effects())
    assert set(streams) == {"position", "force", "profile"}
    assert vector.size == sum(values.size for values in streams.values())
    sigma = {"position": clean_model.noise.position_m, "force": clean_model.noise.force_n}
    for name in ("position", "force"):
        stream_chi2 = float(np.mean((streams[name] / sigma[name]) ** 2))
        assert 0.8 <= stream_chi2 <= 1.2, (name, stream_chi2)


def test_vector_is_noise_again_when_the_twin_knows_the_hidden_effect(nominal_path: tuple) -> None:
    t_s, p_m = nominal_path
    hidden = Effects({"tracker_drift": 0.02})
    run, _ = run_lab(t_s, p_m, scenario="nominal", seed=DRIFT_SEED, spec=TwinSpec(effects=hidden))
    model = ResidualModel(run)
    assert float(np.mean(model.vector(Effects()) ** 2)) > 3.0
    assert 0.8 <= float(np.mean(model.vector(hidden) ** 2)) <= 1.2


def test_measurement_side_effects_reuse_the_cached_simulation(clean_model: ResidualModel) -> None:
    base = clean_model.simulate(Effects())
    for name, value in (("tracker_drift", 0.01), ("stream_time_offset", 0.05), ("sheet_springback", 0.1)):
        assert clean_model.simulate(Effects({name: value})) is base
    assert clean_model.simulate(Effects({"tool_length_offset": 0.3})) is not base


def test_folds_split_the_vector_into_two_complementary_halves(clean_model: ResidualModel) -> None:
    first, second = clean_model.folds()
    size = clean_model.vector(Effects()).size
    assert first.shape == second.shape == (size,)
    assert not np.any(first & second)
    assert np.all(first | second)
    assert 0.3 < first.mean() < 0.7


def test_noise_summary_converts_to_millimetres() -> None:
    noise = Noise(position_m=2e-5, force_n=5.0, profile_m=3e-5)
    assert noise.summary() == pytest.approx({"position_mm": 0.02, "force_n": 5.0, "profile_mm": 0.03})
