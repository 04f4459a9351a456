"""The compiled rigid drive of a force model (`twin.sim.compiled.rigid.rigid_forces`) gives the Python loop's
forces (`ForceField.rigid_forces`, the reference) and leaves the model as that loop leaves it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from twin.errors import InputError
from twin.process.description import Process
from twin.process.fe.load import default_force_history
from twin.process.force.isf import IsfForceField
from twin.process.force.registry import build_force_field
from twin.process.force.table import SheetForceField
from twin.process.force.tool_friction import SlidingFriction
from twin.process.toolpath.groove import groove_path
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.compiled.rigid import rigid_forces

REL_TOL = 1e-9  # of the largest force along the path
LEARNED = (("prior_weight", 0.2), ("side_membrane_n", 2000.0), ("side_cubic_n", 900.0), ("ahead_membrane_n", 150.0))


def _same(compiled: np.ndarray, reference: np.ndarray) -> None:
    assert compiled.shape == reference.shape
    np.testing.assert_allclose(compiled, reference, rtol=0.0, atol=REL_TOL * float(np.abs(reference).max()))


def test_the_groove_on_the_table_field_gives_the_python_forces_and_state() -> None:
    path = groove_path()
    fast, slow = SheetForceField(default_force_history()), SheetForceField(default_force_history())
    _same(rigid_forces(fast, path), slow.rigid_forces(path))
    np.testing.assert_array_equal(fast.formed_z_m, slow.formed_z_m)
    np.testing.assert_array_equal(fast.profile.snapshot_m, slow.profile.snapshot_m)
    assert fast.state == slow.state


@pytest.mark.parametrize("model", ["isf", "learned"])
def test_a_cone_on_the_isf_models_gives_the_python_forces_and_state(model: str) -> None:
    cone = part_path(PartSpec(top_half_width_m=0.02, depth_m=4e-3))
    process = Process(force_model=model, force_fit=LEARNED if model == "learned" else ())
    fast, slow = build_force_field(process), build_force_field(process)
    assert isinstance(fast, IsfForceField) and isinstance(slow, IsfForceField)
    _same(rigid_forces(fast, cone), slow.rigid_forces(cone))
    np.testing.assert_array_equal(fast.map.z_met_m, slow.map.z_met_m)
    np.testing.assert_array_equal(fast.map.owner_met, slow.map.owner_met)
    np.testing.assert_allclose(fast.map.z_loaded_m, slow.map.z_loaded_m, rtol=0.0, atol=1e-12)
    assert fast.state == slow.state
    # and again from the state it left: rigid_forces starts from a flat sheet every time
    _same(rigid_forces(fast, cone), slow.rigid_forces(cone))


def test_a_model_without_a_kernel_and_passes_the_table_lacks_run_the_python_loop() -> None:
    path = groove_path()
    wrapped = SlidingFriction(SheetForceField(default_force_history()))
    _same(rigid_forces(wrapped, path), SlidingFriction(SheetForceField(default_force_history())).rigid_forces(path))
    beyond = replace(path, pass_index=path.pass_index + 100)
    with pytest.raises(InputError, match="pass_index"):  # the field's own error, from the Python loop
        rigid_forces(SheetForceField(default_force_history()), beyond)
