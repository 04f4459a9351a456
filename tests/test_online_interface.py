"""How the plant's controller takes an online correction (twin/lab/dynamic/online.py, knobs `correction_period_ms`,
`correction_along_path`): held between the corrections it takes, its part along the path dropped for EGM's path
correction; and (slow) docs/online.md's interface table against a fresh run of one cell."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.online import OnlineCycle, OnlineFt
from twin.robot.description import load_robot
from twin.robot.kinematics import Kinematics
from twin.robot.model import build_model

ROOT = Path(__file__).resolve().parents[1]
DT = 0.001


class Constant:
    """A corrector that always asks for the same correction, sheet frame [m]."""

    cycle_s = 0.004

    def __init__(self, correction_m: np.ndarray) -> None:
        self.correction_m = np.asarray(correction_m, dtype=float)

    def step(self, t_s: float, sample_t_s: float, f_sheet_n: np.ndarray, q_rad: np.ndarray) -> int:
        return 0


def _cycle(knobs: dict[str, float], correction_m: np.ndarray) -> tuple[OnlineCycle, Kinematics, np.ndarray]:
    robot = load_robot("tx200")
    kin = Kinematics(build_model(robot), robot=robot)
    p0, _ = kin.fk(robot.q_home)
    line = p0 + np.outer(np.linspace(0.0, 0.05, 200), [1.0, 0.0, 0.0])  # 50 mm along x in 0.2 s
    q_sp = kin.ik_path(line)
    ft = OnlineFt(Knobs(knobs), np.random.default_rng(0), 0.0, np.eye(3), DT)
    return OnlineCycle((Constant(correction_m), ft), kin, q_sp, np.eye(3), DT, len(q_sp)), kin, q_sp


def _applied(cycle: OnlineCycle, kin: Kinematics, q_sp: np.ndarray) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(tick, the joint offsets the controller holds [rad], their tip motion at that tick [m]) per corrector cycle."""
    log = np.zeros((len(q_sp), 3))
    out = []
    for k in range(0, len(q_sp), cycle.every):
        dq = cycle.run(k, k * DT, q_sp[k], log, np.tile(np.eye(3).ravel(), (len(q_sp), 1))).copy()
        out.append((k, dq, kin.jacobian(q_sp[k])[:3] @ dq))
    return out


def test_position_guidance_takes_every_correction_whole():
    cycle, kin, q_sp = _cycle({}, np.array([0.3e-3, -0.2e-3, 0.1e-3]))
    for _, _, twist in _applied(cycle, kin, q_sp):
        np.testing.assert_allclose(twist, [0.3e-3, -0.2e-3, 0.1e-3], atol=1e-9)


def test_path_correction_holds_48_ms_and_drops_the_part_along_the_path():
    cycle, kin, q_sp = _cycle({"correction_period_ms": 48.0, "correction_along_path": 0.0},
                              np.array([0.3e-3, -0.2e-3, 0.1e-3]))
    applied = _applied(cycle, kin, q_sp)
    assert cycle.hold == 48
    for k, dq, twist in applied:
        assert abs(twist[0]) < 2e-6, (k, twist)  # the path runs along x: its part is gone
        np.testing.assert_allclose(twist[1:], [-0.2e-3, 0.1e-3], atol=2e-6)
        taken = next(d for j, d, _ in applied if j == k - k % 48)
        assert np.array_equal(dq, taken)  # held until the next correction the controller takes


def _cell(doc: str, variant: str, interface: str) -> float:
    """The default model's rms [mm] in docs/online.md's interface table."""
    row = next(line for line in doc.splitlines() if line.startswith(f"| {variant} | {interface} |"))
    return float(row.split("|")[3].split("/")[0])


def test_the_pages_shares_are_its_tables():
    """'gives back 67 % ... on the groove ... and 39 % on the cone': (path correction - 4 ms) / (nominal - 4 ms)."""
    doc = (ROOT / "docs" / "online.md").read_text(encoding="utf-8")
    said = re.search(r"gives back (\d+) % of what the\s+correction took off on the groove.*?and (\d+) % on the cone",
                     doc, flags=re.DOTALL)
    assert said is not None
    for share, variant in zip(said.groups(), ("groove-default", "cone-default"), strict=True):
        nominal = _cell(doc, variant, "nominal, no correction")
        whole = _cell(doc, variant, "4 ms, all axes (RSI; EGM position guidance)")
        path = _cell(doc, variant, "48 ms, y and z of the path (EGM path correction)")
        assert float(share) == pytest.approx(100.0 * (path - whole) / (nominal - whole), abs=2.0)


def test_the_interface_table_cell_is_what_a_fresh_run_gives(tmp_path):
    """docs/online.md's groove row of EGM path correction, default model: rms and max of a fresh run."""
    sys.path.insert(0, str(ROOT / "experiments"))
    import online_study
    from experiments_cli import cli

    ideal = tmp_path / "ideal.csv"
    cli("path", "--shape", "groove", "--out", str(ideal))
    online_study.PLANT_KNOBS.update({"correction_period_ms": 48.0, "correction_along_path": 0.0})
    try:
        formed = online_study._lab(1.0, ideal, tmp_path / "groove_run", 3, online=True)
    finally:
        online_study.PLANT_KNOBS.clear()
    got = online_study._residual(formed, ideal, [0.0, 0.0, 0.0])
    doc = (ROOT / "docs" / "online.md").read_text(encoding="utf-8")
    row = next(line for line in doc.splitlines()
               if line.startswith("| groove-default | 48 ms, y and z of the path (EGM path correction) |"))
    rms, peak = (float(v) for v in re.search(r"\| ([\d.]+) / ([\d.]+) \(", row).groups())  # type: ignore[union-attr]
    assert got["rms_mm"] == pytest.approx(rms, abs=0.02) and got["max_mm"] == pytest.approx(peak, abs=0.05)
