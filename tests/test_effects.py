"""Tests of the named effects, `--effect` parsing and the twin model file (twin/lab/effects.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from twin.lab.effects import (
    EFFECTS,
    MODEL_FORMAT,
    TRACKER_DRIFT_DIRECTION,
    Effects,
    parse_effect_args,
    read_model_file,
    write_model_file,
)

from twin.errors import DataFileError, InputError
from twin.robot.model import RobotEffects


def test_parse_effect_args_reads_values_in_their_units() -> None:
    effects = parse_effect_args(["force_scale=1.5", "tcp_offset=1.0", "direction_dependent_compliance=0.5"])
    assert effects.values == {"force_scale": 1.5, "tcp_offset": 1.0, "direction_dependent_compliance": 0.5}
    assert effects.robot == RobotEffects(lost_motion_rad=5e-4, tcp_offset_m=1e-3, force_scale=1.5)
    assert parse_effect_args(None) == Effects()
    assert parse_effect_args([]).values == {}


@pytest.mark.parametrize(
    ("item", "match"),
    [
        ("backlash=0.5", "unknown effect 'backlash'"),
        ("force_scale", "expected NAME=VALUE"),
        ("force_scale=big", "not a number"),
    ],
)
def test_parse_effect_args_errors_list_the_valid_names(item: str, match: str) -> None:
    with pytest.raises(InputError, match=match) as info:
        parse_effect_args([item])
    for name, spec in EFFECTS.items():
        assert f"{name} [{spec.unit}]" in str(info.value)


def test_parse_effect_args_rejects_nan() -> None:
    with pytest.raises(InputError, match="finite"):
        parse_effect_args(["tracker_drift=nan"])


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ({"force_scale": float("nan")}, "finite"),
        ({"tcp_offset": float("inf")}, "finite"),
        ({"force_scale": -1.5}, ">= 0"),
        ({"sheet_springback": -0.1}, ">= 0"),
        ({"sheet_springback": 1.0}, r"\[0, 1\)"),
        ({"backlash": 1.0}, "valid effects"),
    ],
)
def test_effects_reject_bad_values(values: dict[str, float], match: str) -> None:
    with pytest.raises(InputError, match=match):
        Effects(values)


def test_neutral_values_switch_an_effect_off() -> None:
    effects = Effects({"force_scale": 1.0, "tcp_offset": 0.0, "tracker_drift": 0.02})
    assert effects.values == {"tracker_drift": 0.02}
    assert effects.get("force_scale") == 1.0
    assert effects.with_value("tracker_drift", 0.0) == Effects()
    assert effects.with_value("force_scale", 2.0).values == {"tracker_drift": 0.02, "force_scale": 2.0}
    assert Effects().robot == RobotEffects()


def test_effect_units_convert_to_si() -> None:
    effects = Effects({"tracker_drift": 0.02, "stream_time_offset": 0.2, "sheet_springback": 0.13})
    assert np.linalg.norm(TRACKER_DRIFT_DIRECTION) == pytest.approx(1.0)
    np.testing.assert_allclose(effects.tracker_drift_m_per_s, 2e-5 * TRACKER_DRIFT_DIRECTION)
    assert effects.stream_time_offset_s == 0.2
    assert effects.springback_ratio == 0.13
    assert effects.named_parameters() == {
        "tracker_drift": {"tracker_drift_mm_per_s": 0.02},
        "stream_time_offset": {"stream_time_offset_s": 0.2},
        "sheet_springback": {"sheet_springback_ratio": 0.13},
    }


def test_model_file_round_trip(tmp_path: Path) -> None:
    effects = Effects({"force_scale": 1.5, "direction_dependent_compliance": 0.5})
    k_q = np.array([1.1e6, 2.2e6, 1.3e6, 4.0e5, 3.0e5, 2.0e5])
    path = write_model_file(tmp_path / "model.json", effects, joint_stiffness_nm_per_rad=k_q, note="fit")
    back, k_back = read_model_file(path)
    assert back == effects
    assert k_back is not None
    np.testing.assert_array_equal(k_back, k_q)
    payload = json.loads(path.read_text())
    assert payload["format"] == MODEL_FORMAT
    assert payload["units"] == {"force_scale": "-", "direction_dependent_compliance": "mrad"}
    only_effects = write_model_file(tmp_path / "effects.json", Effects({"tcp_offset": 1.0}))
    assert read_model_file(only_effects) == (Effects({"tcp_offset": 1.0}), None)


@pytest.mark.parametrize(
    ("payload", "match"),
    [
        ({"format": "something/2", "effects": {}}, "format"),
        ({"format": MODEL_FORMAT, "effects": {"backlash": 1.0}}, "bad effects"),
        ({"format": MODEL_FORMAT, "effects": {"force_scale": "big"}}, "bad effects"),
        ({"format": MODEL_FORMAT, "effects": {}, "joint_stiffness_nm_per_rad": [1e6] * 5}, "6 positive"),
        (
            {"format": MODEL_FORMAT, "effects": {}, "joint_stiffness_nm_per_rad": [1e6] * 5 + [-1]},
            "6 positive",
        ),
    ],
)
def test_read_model_file_rejects_bad_files_naming_them(tmp_path: Path, payload: dict, match: str) -> None:
    path = tmp_path / "bad_model.json"
    path.write_text(json.dumps(payload))
    with pytest.raises(DataFileError, match=match) as info:
        read_model_file(path)
    assert "bad_model.json" in str(info.value)


def test_read_model_file_reports_a_missing_file(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match="not found"):
        read_model_file(tmp_path / "missing.json")
