"""A force model written inside this test goes through the registry into the lab, replay and compensation.

The toy sheet is a linear spring below a plane, with Coulomb friction against the commanded travel and no
forming state worth the name: a law the library does not have. It declares no compiled kernel, so the twin runs
its Python loop; the registry gives it a `--force-model` choice, the lab records its name in `meta.json`, and
`replay --force-model auto` takes the name the run records.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from twin.cli import main
from twin.process.description import Process
from twin.process.fe.load import ForceHistory
from twin.process.force.base import ForceField
from twin.process.force.registry import FORCE_MODELS, ForceModel, register_force_model, unregister_force_model
from twin.process.toolpath.groove import groove_path
from twin.sim.spec import TwinSpec

TOY_K_N_PER_M = 1.2e5  # 1.2 kN at the groove's 10 mm
TOY_MU = 0.25


class ToySheet(ForceField):
    """Fz = k·depth below the flat sheet, F_x = -μ·Fz along the commanded travel; a flat-bottomed record of depth."""

    radius = 7.5e-3
    k_unload = 1.0e6

    def __init__(self) -> None:
        self._x = np.linspace(-0.12, 0.12, 481)
        self._z = np.zeros_like(self._x)

    def reset(self) -> None:
        self._z[:] = 0.0

    def force_and_stiffness(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> tuple[np.ndarray, np.ndarray]:
        depth = max(-float(p_sheet_m[2]), 0.0)
        k = TOY_K_N_PER_M if depth > 0.0 else 0.0
        fz = TOY_K_N_PER_M * depth
        force = np.array([-TOY_MU * direction * fz, 0.0, fz])
        stiffness = np.zeros((3, 3))
        stiffness[2, 2], stiffness[0, 2] = -k, TOY_MU * direction * k
        return force, stiffness

    def force(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        return self.force_and_stiffness(p_sheet_m, pass_index, direction)[0]

    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None) -> None:
        near = np.abs(self._x - float(p_sheet_m[0])) <= self.radius
        self._z[near] = np.minimum(self._z[near], float(p_sheet_m[2]))

    @property
    def x_grid_m(self) -> np.ndarray:
        return self._x

    @property
    def formed_z_m(self) -> np.ndarray:
        return self._z.copy()


def _build(history: ForceHistory, process: Process) -> ForceField:
    del history, process
    return ToySheet()


@pytest.fixture(scope="module")
def toy() -> Iterator[str]:
    register_force_model(ForceModel("toy", "a linear spring sheet written in a test", _build))
    try:
        yield "toy"
    finally:
        unregister_force_model("toy")
    assert "toy" not in FORCE_MODELS


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict[str, object]:
    capsys.readouterr()
    assert main([*argv, "--json", "-"]) == 0
    payload: dict[str, object] = json.loads(capsys.readouterr().out)
    return payload


def test_the_toy_model_runs_in_the_twin_in_python(toy: str) -> None:
    twin = TwinSpec(process=Process(force_model=toy)).build()
    path = groove_path()
    keep = path.pass_index <= 2
    sim = twin.simulate(path.t_s[keep], path.p_sheet_m[keep])
    assert not twin.last_loop_compiled  # no compiled kernel declared: the Python loop
    assert isinstance(twin.sheet_field, ToySheet)
    depth = -sim.p_sheet_m[:, 2]
    np.testing.assert_allclose(sim.f_sheet_n[:, 2], TOY_K_N_PER_M * np.maximum(depth, 0.0), rtol=1e-9, atol=1e-9)


def test_the_toy_model_goes_through_lab_replay_and_compensate(
    toy: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "toy_run"
    lab = _json(capsys, ["lab", "--scenario", "nominal", "--force-model", toy, "--seed", "2", "--out", str(run)])
    meta = json.loads((run / "meta.json").read_text())
    assert meta["force_model"] == toy
    assert 1.0e3 < float(lab["peak_fz_n"]) < 1.3e3  # k x 10 mm, less what the robot gives way, plus noise
    on_toy = _json(capsys, ["replay", str(run)])  # auto: the model the run records
    on_table = _json(capsys, ["replay", str(run), "--force-model", "table"])
    assert float(on_toy["position_rms_mm"]) < 0.04  # the tracker's 0.02 mm noise, per axis
    assert float(on_table["position_rms_mm"]) > 10.0 * float(on_toy["position_rms_mm"])
    cmd = tmp_path / "toy_cmd.csv"
    comp = _json(capsys, ["compensate", "--method", "twin", "--force-model", toy, "--out", str(cmd)])
    assert comp["force_model"] == toy and float(comp["predicted_residual_rms_mm"]) < 0.01
    compensated = tmp_path / "toy_compensated"
    assert main(["lab", "--scenario", "compensated", "--commanded", str(cmd), "--force-model", toy, "--seed", "3",
                 "--out", str(compensated)]) == 0
    check = _json(capsys, ["check", str(compensated)])
    assert float(check["residual_rms_mm"]) < 0.06


def test_a_name_the_registry_does_not_know_is_refused(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with pytest.raises(SystemExit):
        main(["lab", "--scenario", "nominal", "--force-model", "nope", "--seed", "1", "--out", str(tmp_path / "x")])
    assert "invalid choice: 'nope'" in capsys.readouterr().err
    with pytest.raises(Exception, match="unknown force model 'nope'; registered"):
        TwinSpec(process=Process(force_model="nope"))


def test_the_compiled_kernel_is_chosen_by_the_declared_capability(twin_nominal: object) -> None:
    from twin.process.force.table import SheetForceField

    class Subclass(SheetForceField):  # a subclass may change the physics: it declares no kernel of its own
        pass

    class Declared(SheetForceField):  # one that keeps the table's physics declares the kernel again
        compiled_kernel = "table"

    spec = TwinSpec()
    twin = spec.build()
    twin.set_sheet_field(Subclass(twin.history))
    path = groove_path()
    keep = path.pass_index == 1
    twin.simulate(path.t_s[keep], path.p_sheet_m[keep])
    assert not twin.last_loop_compiled
    twin.set_sheet_field(Declared(twin.history))
    twin.simulate(path.t_s[keep], path.p_sheet_m[keep])
    assert twin.last_loop_compiled
