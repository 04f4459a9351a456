"""`tx200-twin info`: JSON keys and values, and the human summary."""

from __future__ import annotations

import json

import numpy as np
import pytest

from twin.cli import main

KEYS = {"joint_stiffness_nm_per_rad", "tcp_home_m", "compliance_home_mm_per_kn", "sheet_origin_m", "model"}


def test_info_writes_json_file(tmp_path) -> None:
    path = tmp_path / "info.json"
    assert main(["info", "--json", str(path)]) == 0
    payload = json.loads(path.read_text())
    assert set(payload) >= KEYS
    assert len(payload["joint_stiffness_nm_per_rad"]) == 6
    assert all(k > 1e5 for k in payload["joint_stiffness_nm_per_rad"])
    np.testing.assert_allclose(payload["tcp_home_m"], [1.467, -0.004, 0.424], atol=2e-3)
    np.testing.assert_allclose(payload["sheet_origin_m"], payload["tcp_home_m"], atol=1e-9)
    C = np.array(payload["compliance_home_mm_per_kn"])
    assert C.shape == (3, 3)
    np.testing.assert_allclose(C, C.T, atol=1e-12)
    assert 0.1 < C[0, 0] < 10.0  # of order 1 mm/kN, like the thesis's C_R


def test_info_json_to_stdout_is_valid_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", "--json", "-"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert set(payload) >= KEYS
    assert payload["model"].endswith("scene.xml")


def test_info_prints_human_summary(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "K_q" in out and "mm/kN" in out and "sheet origin" in out
