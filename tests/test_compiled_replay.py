"""The compiled replay loop (`twin.sim.compiled`) gives the Python loop's equilibria, and its chain is MuJoCo's."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from twin.process.description import Process
from twin.process.fe.load import default_force_history
from twin.process.force.isf import IsfForceField
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import groove_path
from twin.process.toolpath.placement import Placement
from twin.sim.compiled import compiled_replay
from twin.sim.compiled.chain import chain_arrays, chain_eval
from twin.sim.effects import Effects
from twin.sim.ft_sensor import flange_sensor_forces
from twin.sim.quasi_static import Twin
from twin.sim.result import SimResult
from twin.sim.spec import TwinSpec

P_TOL_M = 1e-9  # the exactness bound on the tool tip
F_TOL_N = 1e-4  # 1e-9 m times the stiffest sheet sensitivity (1.4 kN/mm)


@pytest.mark.parametrize(
    "effects", [Effects(), Effects({"lost_motion": 0.3}), Effects({"tool_length_offset": 2.0})],
    ids=["nominal", "lost-motion-hinges", "longer-tool"],
)
def test_chain_gives_mujocos_site_position_jacobian_and_gravity_torques(effects: Effects) -> None:
    twin = TwinSpec(effects=effects).build()
    m, d = twin.model, twin.data
    site = m.site("tcp").id
    chain = chain_arrays(m, site)
    assert chain is not None
    rng = np.random.default_rng(11)
    p, jac, g = np.zeros(3), np.zeros((3, m.nv)), np.zeros(m.nv)
    jac_mj, g_mj = np.zeros((3, m.nv)), np.zeros(m.nv)
    for _ in range(40):
        q = rng.uniform(-2.5, 2.5, m.nv)
        chain_eval(chain, q, p, jac, g)
        d.qpos[:], d.qvel[:] = q, 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_rne(m, d, 0, g_mj)
        mujoco.mj_jacSite(m, d, jac_mj, None, site)
        np.testing.assert_allclose(p, d.site_xpos[site], rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(jac, jac_mj, rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(g, g_mj, rtol=0.0, atol=1e-9 * np.abs(g_mj).max())


def _both(twin: Twin, t_s: np.ndarray, p_cmd: np.ndarray) -> tuple[SimResult, SimResult]:
    fast = twin.simulate(t_s, p_cmd)
    assert twin.last_loop_compiled
    fast_state = (twin.field.formed_z_m, getattr(twin.sheet_field, "current_pass", None))  # None: the ISF model
    twin.use_compiled_loop = False
    try:
        reference = twin.simulate(t_s, p_cmd, q_ik=fast.q_ik)
        assert not twin.last_loop_compiled
    finally:
        twin.use_compiled_loop = True
    # the field is left as the Python loop leaves it
    np.testing.assert_allclose(fast_state[0], twin.field.formed_z_m, rtol=0.0, atol=1e-12)
    assert fast_state[1] == getattr(twin.sheet_field, "current_pass", None)
    return fast, reference


def _assert_same(fast: SimResult, reference: SimResult, gain_from: int = 0) -> None:
    np.testing.assert_allclose(fast.p_sheet_m, reference.p_sheet_m, rtol=0.0, atol=P_TOL_M)
    np.testing.assert_allclose(fast.qpos, reference.qpos, rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(fast.f_sheet_n, reference.f_sheet_n, rtol=0.0, atol=F_TOL_N)
    np.testing.assert_allclose(fast.p_unloaded_sheet_m, reference.p_unloaded_sheet_m, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(fast.tip_gain[gain_from:], reference.tip_gain[gain_from:], rtol=0.0, atol=1e-6)
    np.testing.assert_allclose(fast.formed_z_m, reference.formed_z_m, rtol=0.0, atol=P_TOL_M)
    np.testing.assert_array_equal(fast.iterations, reference.iterations)


def test_whole_groove_replays_to_the_python_loops_equilibria(nominal_path: tuple[np.ndarray, np.ndarray]) -> None:
    """Tool stick at the reversals, joint friction, the stateful field: same tips (<= 1e-9 m), same iterations."""
    t_s, p_cmd = nominal_path
    twin = Twin(TwinSpec())
    assert twin.joint_friction.any()
    fast, reference = _both(twin, t_s, p_cmd)
    _assert_same(fast, reference)
    assert np.ptp(fast.p_sheet_m[:, 2] - p_cmd[:, 2]) > 1e-3  # a loaded run, millimetres off the command


@pytest.mark.parametrize(
    "case", ["no-tool-stick", "lost-motion-and-force-scale", "frictionless-joints", "stateless-field", "jittered",
             "clamping-frame"]
)
def test_compiled_loop_matches_on_every_model_and_field_variant(case: str) -> None:
    path = groove_path()
    keep = path.pass_index <= 3
    t_s, p_cmd = path.t_s[keep], path.p_sheet_m[keep].copy()
    if case == "no-tool-stick":
        twin = TwinSpec(process=Process(friction_reversal_m=None)).build()
    elif case == "lost-motion-and-force-scale":
        twin = TwinSpec(effects=Effects({"lost_motion": 0.4, "force_scale": 1.3})).build()
    elif case == "frictionless-joints":
        twin = TwinSpec(joint_friction_nm=(0.0,) * 6).build()
    elif case == "clamping-frame":  # the frame's give solved in the kernel (`twin.sim.compiled.sheet`)
        twin = TwinSpec(effects=Effects({"frame_compliance": 0.5})).build()
    elif case == "stateless-field":
        twin = TwinSpec(process=Process(friction_reversal_m=None)).build()
        twin.set_sheet_field(SheetForceField(twin.history, stateful=False))
    else:  # a compensated-looking command: seeded 20 µm jitter, joints reversing every few samples
        twin = Twin(TwinSpec())
        p_cmd += np.random.default_rng(5).normal(0.0, 2e-5, p_cmd.shape) * np.array([1.0, 0.0, 1.0])
    _assert_same(*_both(twin, t_s, p_cmd))


def test_other_fields_and_out_of_range_passes_fall_back_to_the_python_loop() -> None:
    twin = Twin(TwinSpec())
    path = groove_path()
    q_nom = np.zeros((3, twin.model.nv))
    args = (np.array([1, 1, 1]), np.array([1, 1, 1]), np.zeros(3), np.ones(6), np.eye(6), True)
    site = twin.model.site("tcp").id

    class OwnField(SheetForceField):  # a user's field: its own methods, so the Python loop calls them
        compiled_kernel = None  # a subclass that changes the physics declares no kernel (`ForceField`)

    assert compiled_replay(twin.model, site, OwnField(default_force_history()), q_nom, *args) is None
    used = IsfForceField()
    used.advance(np.array([0.0, 0.0, -1e-4]))  # a field already formed: the compiled loop starts flat
    assert compiled_replay(twin.model, site, used, q_nom, *args) is None
    beyond = (np.array([1, 2, 99]), *args[1:])
    assert compiled_replay(twin.model, site, twin.field, q_nom, *beyond) is None
    assert SheetForceField(default_force_history()).n_passes == int(path.pass_index.max())


def test_light_sensor_pipeline_reads_what_mj_inverse_reads(nominal_path: tuple[np.ndarray, np.ndarray]) -> None:
    t_s, p_cmd = nominal_path
    twin = Twin(TwinSpec())
    sim = twin.simulate(t_s[:400], p_cmd[:400])
    t_sensor = np.linspace(t_s[0], t_s[399], 150)
    light = flange_sensor_forces(twin.model, twin.data, sim, t_sensor, robot=twin.robot)
    full = flange_sensor_forces(twin.model, twin.data, sim, t_sensor, robot=twin.robot, full_inverse=True)
    np.testing.assert_allclose(light, full, rtol=0.0, atol=1e-8)
    assert np.abs(full).max() > 100.0


def test_a_chain_that_disagrees_with_mujoco_is_caught_and_replayed_in_python(
    first_pass_path: tuple[np.ndarray, np.ndarray], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every compiled replay is checked against mj_kinematics at a few poses; a misread chain falls back."""
    import twin.sim.compiled as compiled

    t_s, p_cmd = first_pass_path
    twin = Twin(TwinSpec())
    reference = twin.simulate(t_s, p_cmd)
    assert twin.last_loop_compiled

    def misread(*args: object):  # the site 0.1 mm off, as a parsing slip would put it
        chain = chain_arrays(*args)  # type: ignore[arg-type]
        assert chain is not None
        return chain._replace(site_pos=chain.site_pos + np.array([0.0, 0.0, 1e-4]))

    monkeypatch.setattr(compiled, "chain_arrays", misread)
    with pytest.warns(UserWarning, match="disagrees with MuJoCo"):
        result = twin.simulate(t_s, p_cmd)
    assert not twin.last_loop_compiled
    np.testing.assert_allclose(result.p_sheet_m, reference.p_sheet_m, rtol=0.0, atol=P_TOL_M)


def test_a_yawed_and_shifted_sheet_replays_in_its_own_frame(first_pass_path: tuple[np.ndarray, np.ndarray]) -> None:
    """Placement: the unloaded robot lands on the path in the sheet frame, the sensor reads the sheet-frame force,
    both loops agree, and the robot's anisotropic compliance makes the deflection depend on the yaw."""
    t_s, p_cmd = first_pass_path
    default = Twin(TwinSpec()).simulate(t_s, p_cmd)
    origin = Twin(TwinSpec()).p_base_sheet_origin + np.array([0.05, -0.04, 0.0])
    twin = TwinSpec(placement=Placement(origin_base_m=tuple(origin), yaw_rad=np.pi / 2)).build()
    fast, reference = _both(twin, t_s, p_cmd)
    # the first sample sits on the force table's first node (x = -35 mm): a 1e-16 m rounding difference of the
    # rotated tip picks the clamped side (slope 0) or the cell (the table's slope) for the gain's stiffness there
    _assert_same(fast, reference, gain_from=1)
    np.testing.assert_allclose(fast.p_unloaded_sheet_m, p_cmd, rtol=0.0, atol=1e-9)
    sensor = twin.sensor_forces(fast, t_s[::10])
    np.testing.assert_allclose(sensor, fast.f_sheet_n[::10], rtol=0.0, atol=1e-6 * np.abs(fast.f_sheet_n).max())
    # MuJoCo's own tool tip, turned into the sheet frame, is the replay's
    m, d = twin.model, twin.data
    d.qpos[:] = fast.qpos[-1]
    mujoco.mj_kinematics(m, d)
    p_sheet = twin.R_base_sheet.T @ (d.site_xpos[m.site("tcp").id] - origin)
    np.testing.assert_allclose(p_sheet, fast.p_sheet_m[-1], rtol=0.0, atol=1e-12)
    gap = np.abs(fast.deflection_sheet_m - default.deflection_sheet_m).max()
    assert gap > 1e-4, f"the yaw changed the deflection by only {gap * 1e3:.3f} mm"


def test_an_edited_kernel_source_drops_every_cached_kernel(tmp_path: Path) -> None:
    """numba checks a cached kernel against its own file only; a change in any kernel file must drop them all."""
    import shutil

    import twin.sim.compiled as compiled

    here = Path(compiled.__file__).parent
    for name in compiled.KERNEL_SOURCES:
        shutil.copy(here / name, tmp_path / name)
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    cached = [cache / "loop.replay_loop-1.py311.nbi", cache / "loop.replay_loop-1.py311.1.nbc"]
    for path in cached:
        path.write_bytes(b"kernel")
    assert compiled.drop_stale_kernels(tmp_path)  # no stamp yet: dropped
    assert not any(path.exists() for path in cached)
    for path in cached:
        path.write_bytes(b"kernel")
    assert not compiled.drop_stale_kernels(tmp_path)  # sources unchanged: kept
    assert all(path.exists() for path in cached)
    with (tmp_path / "chain.py").open("a") as source:
        source.write("\n# an edit of the chain, which the loop's cached kernel inlined\n")
    assert compiled.drop_stale_kernels(tmp_path)
    assert not any(path.exists() for path in cached)


@pytest.mark.parametrize("effects", [Effects(), Effects({"frame_compliance": 0.5})], ids=["bare", "giving-frame"])
def test_the_height_map_isf_model_replays_compiled_to_the_python_loops_equilibria(effects: Effects) -> None:
    """A cone on the ISF model (any part), bare or on a clamping frame that gives: same tips and forces, and the
    field is left as the Python loop leaves it (track, pending commits, travel direction, wall angle), so the part's
    surface after the run is the same."""
    from twin.process.part.surface import formed_surface
    from twin.process.toolpath.shapes import PartSpec, part_path

    path = part_path(PartSpec(depth_m=3e-3, top_half_width_m=15e-3))
    twin = TwinSpec(process=Process(force_model="isf"), effects=effects).build()
    fast = twin.simulate(path.t_s, path.p_sheet_m)
    assert twin.last_loop_compiled
    field = twin.sheet_field
    before = field.state
    track, pending = field.map.track_m, len(field.map._queue)
    surface = formed_surface(field)
    twin.use_compiled_loop = False
    try:
        reference = twin.simulate(path.t_s, path.p_sheet_m, q_ik=fast.q_ik)
    finally:
        twin.use_compiled_loop = True
    # the first two samples touch the flat sheet at Δh = 0, the kink of the force law: the gain's stiffness there
    # takes either side with a 1e-16 m rounding of the tip
    _assert_same(fast, reference, gain_from=2)
    assert np.ptp(fast.f_sheet_n[:, 1]) > 100.0  # the in-plane force turns with the contour
    assert pending > 0 and pending == len(field.map._queue)  # commits still within the lag when the run ended
    np.testing.assert_allclose(track, field.map.track_m, rtol=0.0, atol=1e-12)
    after = field.state
    np.testing.assert_allclose(before.direction, after.direction, rtol=0.0, atol=1e-9)
    assert before.last_tip_m is not None and after.last_tip_m is not None
    np.testing.assert_allclose(before.last_tip_m, after.last_tip_m, rtol=0.0, atol=1e-12)
    assert before.wall_angle_deg == pytest.approx(after.wall_angle_deg, abs=1e-9)
    assert before.last_step_m == pytest.approx(after.last_step_m, abs=1e-12)
    assert surface is not None
    np.testing.assert_allclose(surface[2], formed_surface(field)[2], rtol=0.0, atol=1e-12)  # type: ignore[index]


def test_the_isf_model_at_reversals_replays_compiled_to_the_python_loops_equilibria() -> None:
    """The groove's first three passes on the ISF model: at each reversal the sliding direction is released
    (`twin.process.force.sliding`), a branch a cone never takes; compiled and Python loops find the same tips and forces."""
    from twin.process.toolpath.groove import GrooveSpec, groove_path

    path = groove_path(GrooveSpec(passes=3, depth_m=0.003, bottom_length_m=0.068))
    fast, reference = _both(TwinSpec(process=Process(force_model="isf")).build(), path.t_s, path.p_sheet_m)
    _assert_same(fast, reference, gain_from=2)
    fx = fast.f_sheet_n[:, 0]
    reversals = np.flatnonzero(np.diff(fast.pass_index) != 0)
    assert len(reversals) == 2
    for r in reversals:  # released: one sample after the turn (the tip moved back 0.1-0.2 mm) the in-plane force
        # is below 25 % of its straight-run value (0.8 of it without the release), a sample later it opposes the
        # new travel
        assert abs(fx[r + 1]) < 0.25 * abs(fx[r - 1]) and np.sign(fx[r + 2]) == -np.sign(fx[r - 1])


def test_the_learned_force_model_replays_compiled_to_the_python_loops_equilibria() -> None:
    """The `learned` model (the ISF model with membrane and formed-state terms learned from a cell) runs in the ISF
    kernel with its terms: a cone, a pyramid (past its corners the side rises fall into the last side's trough)
    and the groove's first passes give the Python loop's tips and forces."""
    from twin.process.toolpath.groove import GrooveSpec, groove_path
    from twin.process.toolpath.shapes import PartSpec, part_path

    fit = (("prior_weight", -0.1), ("side_membrane_n", 2200.0), ("side_cubic_n", 1300.0),
           ("ahead_membrane_n", 100.0), ("engagement_n_per_mm", -300.0), ("contact_n", 200.0),
           ("wall_angle_n", 100.0), ("depth_n_per_mm", 20.0), ("depth_engagement_n_per_mm2", -5.0),
           ("prior_per_cm", 0.3), ("wall_depth_n_per_mm", 8.0), ("depth_sat_1mm_n", 120.0), ("depth_sat_2mm_n", -80.0),
           ("depth_sat_4mm_n", 60.0), ("side_rise_n", 300.0), ("side_rise_sq_n", -200.0),
           ("ahead_rise_n", 150.0), ("mu_eff", 0.1), ("mu_radial", 0.05), ("mu_radial_rise", 0.3))
    twin = TwinSpec(process=Process(force_model="learned", force_fit=fit)).build()
    flat = TwinSpec(process=Process(force_model="learned", force_fit=fit[:-1])).build()  # no radial rise
    for path in (part_path(PartSpec(depth_m=3e-3, top_half_width_m=15e-3)),
                 part_path(PartSpec(shape="pyramid", depth_m=2e-3, top_half_width_m=12e-3)),
                 groove_path(GrooveSpec(passes=3, depth_m=0.003, bottom_length_m=0.068))):
        fast, reference = _both(twin, path.t_s, path.p_sheet_m)
        _assert_same(fast, reference, gain_from=2)
        assert np.max(fast.f_sheet_n[:, 2]) > 300.0
    # on the cone the walls' rise turns the force across the travel: the radial ratio's μ_ρ is in the kernel
    cone = part_path(PartSpec(depth_m=3e-3, top_half_width_m=15e-3))
    with_rise, without = (t.simulate(cone.t_s, cone.p_sheet_m).f_sheet_n for t in (twin, flat))
    assert np.max(np.linalg.norm(with_rise[:, :2] - without[:, :2], axis=1)) > 10.0
