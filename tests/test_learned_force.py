"""The `learned` force model: its prior is the ISF model, its stiffness is its force's gradient, it is saved in
the model file and carried by the registry."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from twin.errors import InputError
from twin.process.description import Process
from twin.process.force.learned import LearnedForceField, LearnedWeights
from twin.process.force.registry import build_force_field
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.spec import TwinSpec

WEIGHTS = (("prior_weight", 0.2), ("side_membrane_n", 2000.0), ("side_cubic_n", 900.0), ("ahead_membrane_n", 150.0),
           ("engagement_n_per_mm", -300.0), ("contact_n", 200.0), ("wall_angle_n", 100.0), ("depth_n_per_mm", 20.0),
           ("engagement_sq_n_per_mm2", 40.0), ("depth_sq_n_per_mm2", 2.0), ("depth_engagement_n_per_mm2", -5.0),
           ("prior_per_cm", 0.3), ("wall_depth_n_per_mm", 8.0), ("depth_sat_1mm_n", 120.0),
           ("depth_sat_2mm_n", -80.0), ("depth_sat_4mm_n", 60.0), ("side_rise_n", 300.0), ("side_rise_sq_n", -200.0),
           ("ahead_rise_n", 150.0))


@pytest.fixture(scope="module")
def small_cone():
    return part_path(PartSpec(top_half_width_m=0.015, depth_m=3e-3))


def test_the_prior_is_the_isf_model(small_cone) -> None:
    isf = build_force_field(Process(force_model="isf")).rigid_forces(small_cone)
    learned = build_force_field(Process(force_model="learned")).rigid_forces(small_cone)
    assert type(build_force_field(Process(force_model="learned"))).kernel() == "isf"  # its terms are in that kernel
    np.testing.assert_array_equal(learned, isf)


def test_the_learned_terms_gradients_are_their_derivatives(small_cone) -> None:
    field = build_force_field(Process(force_model="learned", force_fit=WEIGHTS))
    assert isinstance(field, LearnedForceField)
    field.reset()
    n = len(small_cone) // 2
    for p in small_cone.p_sheet_m[:n]:
        field.force(p)
        field.advance(p)
    p0 = small_cone.p_sheet_m[n] + np.array([0.13e-3, 0.07e-3, -0.2e-3])  # off the map's grid lines
    values, grads = field.features(p0)
    assert values[1] > 0.05  # the sides wrap the tool
    assert 0.5 < values[5] < 1.0 and values[7] > 1.0 and values[12] > 0.5  # in contact, below the sheet's plane
    h = 1e-7
    numeric = np.column_stack([(field.features(p0 + h * e)[0] - field.features(p0 - h * e)[0]) / (2 * h)
                               for e in np.eye(3)])
    # the learned terms (the prior's own stiffness is the ISF model's, tested there)
    np.testing.assert_allclose(grads[1:], numeric[1:], rtol=1e-4, atol=1e-3)
    fz, stiffness = field.force_and_stiffness(p0)
    assert stiffness[2, 2] == pytest.approx(np.asarray(field.weights.as_array()) @ grads[:, 2], rel=1e-9)
    assert fz[2] > 100.0


def test_a_model_file_from_before_the_formed_state_terms_reads_them_as_zero(tmp_path, small_cone) -> None:
    old = WEIGHTS[:4]
    spec = TwinSpec(process=Process(force_model="learned", force_fit=old))
    back = read_model_file(write_model_file(tmp_path / "m.json", spec, note="test"))
    field = build_force_field(back.process)
    assert isinstance(field, LearnedForceField)
    assert field.weights == LearnedWeights(**dict(old))
    assert not np.any(field.weights.as_array()[4:])


def test_weights_scale_with_a_force_scale_history(small_cone) -> None:
    process = Process(force_model="learned", force_fit=WEIGHTS)
    history = process.force_history()
    doubled = replace(history, f_sheet_n=2.0 * history.f_sheet_n)
    one = build_force_field(process).rigid_forces(small_cone)
    two = build_force_field(process, doubled).rigid_forces(small_cone)
    big = one[:, 2] > 50.0
    np.testing.assert_allclose(two[big, 2], 2.0 * one[big, 2], rtol=0.02)


def test_bad_weights_are_refused() -> None:
    with pytest.raises(InputError, match="side_membrane_n"):
        LearnedWeights(side_membrane_n=float("nan"))
    with pytest.raises(InputError, match="table force model's scale"):
        build_force_field(Process(force_model="table", force_fit=(("scale", -1.0),)))


def test_the_model_file_keeps_the_learned_sheet(tmp_path, small_cone) -> None:
    spec = TwinSpec(process=Process(force_model="learned", force_fit=WEIGHTS),
                    joint_stiffness_nm_per_rad=(2.2e6, 1.8e6, 1.2e6, 5e5, 4e5, 5e5))
    path = write_model_file(tmp_path / "m.json", spec, note="test")
    back = read_model_file(path)
    assert back.process.force_model == "learned"
    assert dict(back.process.force_fit) == dict(WEIGHTS)
    field = build_force_field(back.process)
    assert isinstance(field, LearnedForceField)
    np.testing.assert_array_equal(field.rigid_forces(small_cone), build_force_field(spec.process).rigid_forces(small_cone))


def test_past_a_pyramids_corner_the_side_rise_falls_as_the_page_says() -> None:
    """docs/learning.md (the learned sheet on parts it never formed): on each level of a pyramid formed on
    the twin's own sheet, the side rise read one tool radius square to the travel falls past the corners to
    0.59-0.76 of its median along the level (the point lies in the trough the last side formed)."""
    from doc_numbers import quoted

    from twin.process.force.learned import SIDE_RISE_INDEX

    path = part_path(PartSpec(shape="pyramid", top_half_width_m=0.02, depth_m=3e-3, mode="z-level"))
    field = build_force_field(Process(force_model="learned", force_fit=WEIGHTS))
    field.reset()
    rise = []
    for p in path.p_sheet_m:
        rise.append(field.features(p)[0][SIDE_RISE_INDEX])
        field.advance(p)
    rise_arr, level = np.array(rise), np.round(path.p_sheet_m[:, 2] * 1e4)  # the z-levels [0.1 mm]
    lows = [np.min(rise_arr[level == z]) / np.median(rise_arr[level == z])
            for z in np.unique(level[path.p_sheet_m[:, 2] < -0.8e-3]) if np.count_nonzero(level == z) >= 100]
    low, high = quoted("learning.md", "so the side rise falls there to", 2)
    low.check(min(lows))
    high.check(max(lows))
    assert len(lows) >= 4 and max(lows) < 0.8
