"""Tests of the named effects, `--effect` parsing and the twin model file (twin/sim/effects.py,
twin/sim/model_file.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from twin.errors import DataFileError, InputError
from twin.sim.effects import EFFECTS, TRACKER_DRIFT_DIRECTION, Effects, parse_effect_args
from twin.sim.model_file import MODEL_FORMAT, read_model_file, write_model_file
from twin.sim.spec import TwinSpec


def test_parse_effect_args_reads_values_in_their_units() -> None:
    effects = parse_effect_args(["force_scale=1.5", "tool_length_offset=1.0", "lost_motion=0.5"])
    assert effects.values == {"force_scale": 1.5, "tool_length_offset": 1.0, "lost_motion": 0.5}
    assert effects.lost_motion_rad == 5e-4
    assert effects.tool_offset_m == 1e-3
    assert effects.force_scale == 1.5
    assert effects.changes_model
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
        ({"tool_length_offset": float("inf")}, "finite"),
        ({"force_scale": -1.5}, r"within \[0, 100\]"),
        ({"sheet_springback": -0.1}, r"within \[0, 0.99\]"),
        ({"sheet_springback": 1.0}, r"within \[0, 0.99\]"),
        ({"lost_motion": 25.0}, r"within \[-20, 20\]"),
        ({"backlash": 1.0}, "unknown effect 'backlash'; valid"),
    ],
)
def test_effects_reject_bad_values(values: dict[str, float], match: str) -> None:
    with pytest.raises(InputError, match=match):
        Effects(values)


def test_neutral_values_switch_an_effect_off() -> None:
    effects = Effects({"force_scale": 1.0, "tool_length_offset": 0.0, "tracker_drift": 0.02})
    assert effects.values == {"tracker_drift": 0.02}
    assert effects.get("force_scale") == 1.0
    assert effects.with_value("tracker_drift", 0.0) == Effects()
    assert effects.with_value("force_scale", 2.0).values == {"tracker_drift": 0.02, "force_scale": 2.0}
    neutral = Effects()
    assert (neutral.lost_motion_rad, neutral.tool_offset_m, neutral.force_scale) == (0.0, 0.0, 1.0)
    assert not neutral.changes_model


def test_an_old_effect_name_is_read_as_the_new_one_with_a_warning() -> None:
    with pytest.warns(FutureWarning, match="'direction_dependent_compliance' is now called 'lost_motion'"):
        effects = Effects({"direction_dependent_compliance": 0.5})
    assert effects.values == {"lost_motion": 0.5}
    assert effects == Effects({"lost_motion": 0.5})
    with pytest.warns(FutureWarning, match="'tcp_offset' is now called 'tool_length_offset'"):
        assert parse_effect_args(["tcp_offset=1.0"]).values == {"tool_length_offset": 1.0}


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
    robot_side = Effects({"lost_motion": 0.5, "tool_length_offset": 1.0, "force_scale": 2.0})
    assert robot_side.named_parameters() == {
        "lost_motion": {"lost_motion_mrad": 0.5},
        "tool_length_offset": {"tool_length_offset_mm": 1.0},
        "force_scale": {"force_scale_ratio": 2.0},
    }


def test_model_file_round_trip(tmp_path: Path) -> None:
    effects = Effects({"force_scale": 1.5, "lost_motion": 0.5})
    k_q = np.array([1.1e6, 2.2e6, 1.3e6, 4.0e5, 3.0e5, 2.0e5])
    spec = TwinSpec(effects=effects, joint_stiffness_nm_per_rad=tuple(k_q))
    path = write_model_file(tmp_path / "model.json", spec, note="fit")
    back = read_model_file(path)
    assert back.effects == effects
    assert back.joint_stiffness is not None
    np.testing.assert_array_equal(back.joint_stiffness, k_q)
    payload = json.loads(path.read_text())
    assert payload["format"] == MODEL_FORMAT
    assert payload["units"] == {"force_scale": "-", "lost_motion": "mrad"}
    offset = Effects({"tool_length_offset": 1.0})
    only_effects = write_model_file(tmp_path / "effects.json", TwinSpec(effects=offset))
    back = read_model_file(only_effects)
    assert (back.effects, back.joint_stiffness) == (offset, None)


def test_a_model_file_of_the_first_format_is_read_with_the_new_effect_names(tmp_path: Path) -> None:
    k_q = [1.1e6, 2.2e6, 1.3e6, 4.0e5, 3.0e5, 2.0e5]
    path = tmp_path / "old_model.json"
    path.write_text(json.dumps({
        "format": "tx200-twin-model/1",
        "effects": {"direction_dependent_compliance": 0.15},
        "units": {"direction_dependent_compliance": "mrad"},
        "joint_stiffness_nm_per_rad": k_q,
        "note": "written before the effect vocabulary",
    }))
    with pytest.warns(FutureWarning, match="'direction_dependent_compliance' is now called 'lost_motion'"):
        spec = read_model_file(path)
    assert isinstance(spec, TwinSpec)
    assert spec.effects.values == {"lost_motion": 0.15}
    assert spec.effects == Effects({"lost_motion": 0.15})
    assert spec.joint_stiffness is not None
    np.testing.assert_array_equal(spec.joint_stiffness, k_q)
    assert spec.joint_stiffness_nm_per_rad == tuple(k_q)


@pytest.mark.parametrize(
    ("payload", "match"),
    [
        ({"format": "something/2", "effects": {}}, "format"),
        ({"format": MODEL_FORMAT, "effects": {"backlash": 1.0}}, "bad model"),
        ({"format": MODEL_FORMAT, "effects": {"force_scale": "big"}}, "bad model"),
        (
            {"format": MODEL_FORMAT, "effects": {}, "joint_stiffness_nm_per_rad": [1e6] * 5},
            "6 finite values > 0",
        ),
        (
            {"format": MODEL_FORMAT, "effects": {}, "joint_stiffness_nm_per_rad": [1e6] * 5 + [-1]},
            "6 finite values > 0",
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
