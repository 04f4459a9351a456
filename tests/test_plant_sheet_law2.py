"""The dynamic plant's sheet law 2 (twin/lab/dynamic/sheet_patch.py): a contact patch on an elastic-plastic
foundation. Its compiled kernels against its Python reference, its smoothness on a rigid pyramid, a short run on
the plant, and that it is not of the form today's learner (`twin.process.force.learned`) or law 1 can fit.

The learner's features are a frozen copy written here (not imported): if the learner changes, this test still
asks whether law 2 is learnable by the form it had when law 2 was written. The learner predicts a force vector (its
Fz from its features, its in-plane force from Fz through the ISF in-plane law), so its form and law 1's are fitted
to law 2's stacked force (Fx, Fy, Fz), R^2 about each component's mean; the Fz-only R^2 is printed beside it.

Measured when written (rigid 6 mm cone / pyramid, R 7.5 mm, t 1 mm, mu 0.1):
    learned features: stacked R^2 0.939 / 0.683, Fz-only 0.985 / 0.900 (the cone is a strict xfail);
    law 1's form:     stacked R^2 0.826 / 0.619, Fz-only 0.878 / 0.670;
    (R^2 about the stacked force's single mean instead, as first written: learned 0.980 / 0.899, law 1 0.943 on
    the cone: the axial force's offset from the in-plane forces' zero counted as explained.)
    pyramid in-plane force: largest change 0.243 of the steady force per 0.1 mm (0.064 with mu = 0): a strict xfail.
Law 2's force level: 2.5-2.9x law 1's on these parts, 0.85x the measured NUMISHEET BM3 steady force (Aerens's
formula predicts ~1240 N steady for this pyramid; law 2's median steady force here is ~1270 N)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twin.lab.dynamic.knobs import Knobs
from twin.lab.dynamic.sheet import PlantSheet
from twin.lab.dynamic.sheet_grid import GRID_SPACING_M
from twin.lab.dynamic.sheet_laws import make_sheet
from twin.lab.dynamic.sheet_patch import PatchSheet, swift_mpa, swift_tensile_strength_mpa
from twin.process.description import Process
from twin.process.toolpath.shapes import PartSpec, part_path

#: The issue's thresholds (not chosen from this law's results): R^2 of the learner's features, of law 1's form.
LEARNED_R2_MAX, LAW1_R2_MAX = 0.8, 0.9
TIMESTEP_S = 3e-3  # a rigid step of 0.1 mm at 33 mm/s


def _resampled(path_xyz: np.ndarray, step_m: float = 1e-4) -> np.ndarray:
    """The path at equal steps of `step_m` [m] along its length."""
    d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path_xyz, axis=0), axis=1))])
    u = np.arange(0.0, d[-1], step_m)
    return np.column_stack([np.interp(u, d, path_xyz[:, i]) for i in range(3)])


def _drive(sheet: PlantSheet | PatchSheet, path: np.ndarray) -> np.ndarray:
    """The sheet's force [N] along a path driven rigidly: force, then advance, at every point; (n, 3)."""
    sheet.start(path[0], 1.0 if path[1, 0] >= path[0, 0] else -1.0)
    out = np.empty((len(path), 3))
    for i, p in enumerate(path):
        out[i] = sheet.force(p)
        sheet.advance(p)
    return out


def _cone() -> np.ndarray:
    return _resampled(part_path(PartSpec(top_half_width_m=0.02, depth_m=6e-3)).p_sheet_m)


def _pyramid() -> np.ndarray:
    return _resampled(part_path(PartSpec(shape="pyramid", top_half_width_m=0.02, depth_m=6e-3)).p_sheet_m)


# ---- a frozen copy of today's learned features (twin/process/force/learned.py, written out here)


def _membrane(rise: float, radius: float) -> tuple[float, float]:
    """(m(u), u^3) for a rise [m] one tool radius away: u = r / sqrt(r^2 + R^2), m = u^2 sqrt(1 - u^2)."""
    if rise <= 0.0:
        return 0.0, 0.0
    rise = min(rise, 0.999999 * radius)
    u = rise / math.sqrt(rise * rise + radius * radius)
    return u * u * math.sqrt(max(1.0 - u * u, 1e-12)), u**3


class _Envelope:
    """The learner's height map: the lower envelope of the tool sphere along the path, 0.5 mm grid."""

    def __init__(self, radius: float, half: float = 0.06, h: float = 5e-4) -> None:
        self.r, self.half, self.h = radius, half, h
        self.g = np.arange(-half, half + h / 2, h)
        self.z = np.zeros((len(self.g), len(self.g)))
        self.k = math.ceil(radius / h) + 1

    def height(self, x: float, y: float) -> float:
        fx, fy = (x + self.half) / self.h, (y + self.half) / self.h
        ix, iy = math.floor(fx), math.floor(fy)
        if ix < 0 or iy < 0 or ix >= len(self.g) - 1 or iy >= len(self.g) - 1:
            return 0.0
        u, v = fx - ix, fy - iy
        z = self.z
        return float((z[iy, ix] * (1 - u) + z[iy, ix + 1] * u) * (1 - v) + (z[iy + 1, ix] * (1 - u) + z[iy + 1, ix + 1] * u) * v)

    def press(self, p: np.ndarray) -> None:
        ix, iy = round((p[0] + self.half) / self.h), round((p[1] + self.half) / self.h)
        x0, x1 = max(ix - self.k, 0), min(ix + self.k + 1, len(self.g))
        y0, y1 = max(iy - self.k, 0), min(iy + self.k + 1, len(self.g))
        r2 = (self.g[y0:y1, None] - p[1]) ** 2 + (self.g[None, x0:x1] - p[0]) ** 2
        under = np.where(r2 < self.r**2, p[2] + self.r - np.sqrt(np.maximum(self.r**2 - r2, 0.0)), np.inf)
        np.minimum(self.z[y0:y1, x0:x1], under, out=self.z[y0:y1, x0:x1])


#: The ISF in-plane law's lengths when law 2 was written (`twin.process.force.sliding`, `isf.ALPHA_LENGTH_M`,
#: `IsfForceParams.direction_length_m`): L_f the travel over which the sliding direction turns, L_r the release
#: of a reversal, and the travel over which the wall's held side follows its readings [m].
TURN_M, RELEASE_M, SIDE_M = 0.996e-3, 0.05e-3, 10e-3


def _sliding(v: np.ndarray, step: np.ndarray) -> np.ndarray:
    """The ISF model's sliding direction after a step (`twin.process.force.sliding.sliding_direction`, frozen)."""
    length = float(np.hypot(*step))
    if length < 1e-9:
        return v
    e = step / length
    c = float(v @ e)
    if c < 0.0:
        v = v - (1.0 - math.exp(-length / RELEASE_M)) * c * e
    w = math.exp(-length / TURN_M)
    return w * v + (1.0 - w) * e


def _learned_features(path: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Today's learned regressors along a path, (n, 5): depth (in place of the ISF prior's linear axial term),
    side sum m(u), side sum u^3, ahead m(u), and the intercept; the rises read on the met surface, before the
    press. With the two in-plane directions the learner's force takes from the ISF model, each (n, 2): -v against
    the sliding direction v, and -side L v across it away from the wall (L the quarter turn left, side the held
    side of the wall, +1 left of the travel: here the side whose met surface rises more one radius away, in place
    of the ISF model's walk up the layers, followed over `SIDE_M` of travel as the ISF model follows its own)."""
    env = _Envelope(radius)
    out, along, across = np.empty((len(path), 5)), np.empty((len(path), 2)), np.empty((len(path), 2))
    heading, v, side = np.array([1.0, 0.0]), np.zeros(2), 0.0
    for k, p in enumerate(path):
        step = path[min(k + 1, len(path) - 1), :2] - path[max(k - 1, 0), :2]
        if np.hypot(*step) > 1e-9:
            heading = step / np.hypot(*step)
        travelled = path[k, :2] - path[max(k - 1, 0), :2]
        v = _sliding(v, travelled)
        vx, vy = heading
        x, y, z = p
        m_side = cube = m_ahead = 0.0
        rises = []
        for dx, dy, ahead in ((-vy, vx, False), (vy, -vx, False), (vx, vy, True)):
            rise = env.height(x + radius * dx, y + radius * dy) - z
            rises.append(rise)
            m, c = _membrane(rise, radius)
            if ahead:
                m_ahead += m
            else:
                m_side, cube = m_side + m, cube + c
        if max(rises[0], rises[1]) > 0.0 and rises[0] != rises[1]:
            side += (1.0 - math.exp(-float(np.hypot(*travelled)) / SIDE_M)) * (math.copysign(1.0, rises[0] - rises[1]) - side)
        out[k] = max(-z, 0.0), m_side, cube, m_ahead, 1.0
        along[k] = -v
        across[k] = -side * np.array([-v[1], v[0]])
        env.press(p)
    return out, along, across


def _stacked(fz_columns: np.ndarray, xy_columns: list[np.ndarray]) -> np.ndarray:
    """Regressors of the stacked force (Fx over the path, then Fy, then Fz): `fz_columns` (n, k) on Fz alone (zero
    on Fx, Fy), each of `xy_columns` (n, 2, k) on Fx and Fy alone (zero on Fz); (3 n, k + sum of their k)."""
    n = len(fz_columns)
    blocks = [np.vstack([np.zeros((2 * n, fz_columns.shape[1])), fz_columns])]
    for c in xy_columns:
        blocks.append(np.vstack([c[:, 0, :], c[:, 1, :], np.zeros((n, c.shape[2]))]))
    return np.hstack(blocks)


def _r2(regressors: np.ndarray, target: np.ndarray, components: int = 1) -> float:
    """R^2 of the least-squares fit of `target` on the columns of `regressors`; a target of `components` stacked
    components (equal lengths) is measured about each component's own mean (the variance-weighted R^2 of a
    multi-output fit, as scikit-learn's `r2_score(multioutput="variance_weighted")`), so that an axial force far
    from zero beside in-plane forces about zero does not count as explained."""
    coef, *_ = np.linalg.lstsq(regressors, target, rcond=None)
    residual = target - regressors @ coef
    parts = target.reshape(components, -1)
    return float(1.0 - np.sum(residual**2) / np.sum((parts - parts.mean(axis=1, keepdims=True)) ** 2))


@pytest.fixture(scope="module")
def rigid_runs() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Law 2's force along the rigid cone and pyramid, with their paths."""
    out = {}
    for name, path in (("cone", _cone()), ("pyramid", _pyramid())):
        out[name] = (path, _drive(PatchSheet(Process(), 5e-5, TIMESTEP_S), path))
    return out


def test_the_swift_law_and_its_tensile_strength() -> None:
    # NUMISHEET'93 aluminium: 576.79 (0.01658 + eps)^0.3593 MPa; yield ~132 MPa, R_m ~283 MPa (Considere)
    assert float(swift_mpa(0.0)) == pytest.approx(576.79 * 0.01658**0.3593)
    assert float(swift_mpa(0.0)) == pytest.approx(132.0, abs=1.0)
    assert swift_tensile_strength_mpa() == pytest.approx(283.0, abs=2.0)


def test_law_2_is_chosen_by_the_knob() -> None:
    assert isinstance(make_sheet(Knobs({"sheet_law": 2}), Process()), PatchSheet)
    assert isinstance(make_sheet(Knobs(), Process()), PlantSheet)


def test_the_compiled_patch_is_the_python_patch() -> None:
    """The per-tick kernels (`sheet_patch_kernels`) against the Python reference, on a short rigid cone and on a
    back-and-forth groove (reversals, unloading): the same forces, surfaces and strains to a few units in the last
    place; their constants agree."""
    from twin.lab.dynamic import sheet_patch, sheet_patch_kernels

    for name in ("SWIFT_K_MPA", "SWIFT_EPS0", "SWIFT_N", "YOUNGS_MODULUS_PA", "POISSON_RATIO", "HALF_SIZE_M",
                 "DAMPING_TIME_S", "MIN_NORMAL_Z", "MAX_SLOPE", "PLANE", "HANG_SLOPE"):
        assert getattr(sheet_patch_kernels, name) == getattr(sheet_patch, name), name
    cone = _cone()[:600]
    x = np.concatenate([np.linspace(-0.01, 0.01, 100), np.linspace(0.01, -0.01, 100)])
    groove = np.column_stack([np.tile(x, 2), np.zeros(400), -np.linspace(0.0, 2e-3, 400)])
    groove[300:, 2] += 0.3e-3 * np.linspace(0.0, 1.0, 100)  # the tool backs off: elastic unloading
    for path, spacing in ((cone, GRID_SPACING_M), (groove, GRID_SPACING_M), (groove[:200], GRID_SPACING_M / 2)):
        runs = []
        for compiled in (True, False):
            sheet = PatchSheet(Process(), 5e-5, TIMESTEP_S, spacing)
            sheet.compiled = compiled
            forces = _drive(sheet, path)
            runs.append((forces, sheet.z_m.copy(), sheet.strain.copy(), sheet.slip.copy()))
        (f1, z1, e1, s1), (f2, z2, e2, s2) = runs
        assert np.max(np.abs(f1)) > 100.0
        np.testing.assert_allclose(f1, f2, rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(z1, z2, rtol=0.0, atol=1e-15)
        np.testing.assert_allclose(e1, e2, rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(s1, s2, rtol=0.0, atol=1e-15)


def test_the_force_is_continuous_and_stiff_against_a_wall() -> None:
    """Pushed sideways into a formed wall, the patch's lateral force grows without jumps (no binary switch: a node's
    pressure rises over its elastic penetration, ~5 um) and never falls over any 0.1 mm the tool presses further
    (lateral stiffness >= 0 over every 0.1 mm)."""
    sheet = PatchSheet(Process(), 5e-5, TIMESTEP_S)
    _drive(sheet, np.column_stack([np.linspace(-0.01, 0.01, 201), np.zeros(201), np.full(201, -2e-3)]))
    ys = np.linspace(-1e-3, 1e-3, 401)
    fy = np.array([sheet.force(np.array([0.0, y, -2e-3]))[1] for y in ys])
    assert np.max(np.abs(np.diff(fy))) < 0.05 * np.max(np.abs(fy))
    assert np.all(fy[20:] - fy[:-20] <= 0.0)  # the wall at +y pushes the tool towards -y, harder the deeper


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "the in-plane force changes by 0.243 of the steady force over one 0.1 mm step (<= 0.10 asked): at the "
    "pyramid's sharp corners the Coulomb friction turns 90 deg over law 2's Mindlin pre-sliding travel, ~0.5 um; "
    "0.064 with mu = 0"))
def test_the_in_plane_force_is_smooth_on_a_rigid_pyramid(rigid_runs: dict) -> None:
    """On the rigid pyramid the in-plane force changes by at most 10 % of the steady force per 0.1 mm step. Law 2
    turns its friction over its own pre-sliding travel (Mindlin-Cattaneo, `PatchSheet.presliding_m`, ~0.5 um):
    at a sharp corner of the path the friction turns within one step, so this is not met (the xfail's reason);
    without friction the largest change is 0.064."""
    _, f = rigid_runs["pyramid"]
    inplane = np.linalg.norm(f[:, :2], axis=1)
    steady = float(np.median(np.linalg.norm(f, axis=1)[len(f) // 2 :]))
    assert np.max(np.abs(np.diff(inplane))) <= 0.10 * steady  # per 0.1 mm step


def _learned_r2(path: np.ndarray, f: np.ndarray) -> tuple[float, float]:
    """(stacked, axial-only) R^2 of today's learned form fitted to a force `f` (n, 3) along `path`."""
    phi, along, across = _learned_features(path, Process().tool_radius_m)
    xy = [along[:, :, None] * phi[:, None, :], across[:, :, None] * phi[:, None, :]]
    stacked = _r2(_stacked(phi, xy), np.concatenate([f[:, 0], f[:, 1], f[:, 2]]), 3)
    return stacked, _r2(phi, f[:, 2])


def _law1_r2(path: np.ndarray, f: np.ndarray) -> tuple[float, float]:
    """(stacked, axial-only) R^2 of law 1's form fitted to a force `f` (n, 3) along `path`: law 1's free scales
    (its flow-stress level on its membrane force, its friction on its friction force) and an intercept per
    component."""
    membrane = _drive(PlantSheet(Process(tool_friction=0.0), 5e-5), path)
    friction = _drive(PlantSheet(Process(), 5e-5), path) - membrane
    n = len(path)
    columns = [np.concatenate([membrane[:, i] for i in range(3)]), np.concatenate([friction[:, i] for i in range(3)])]
    for i in range(3):  # an intercept per component
        columns.append(np.concatenate([np.ones(n) if j == i else np.zeros(n) for j in range(3)]))
    stacked = _r2(np.column_stack(columns), np.concatenate([f[:, i] for i in range(3)]), 3)
    return stacked, _r2(np.column_stack([membrane[:, 2], friction[:, 2], np.ones(n)]), f[:, 2])


@pytest.mark.parametrize("name", [
    pytest.param("cone", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "on the rigid 6 mm cone the learner's form fits law 2's force: stacked R^2 0.939 (Fz-only 0.985), "
        "above 0.8; on the pyramid it does not (stacked 0.683, Fz-only 0.900)"))),
    "pyramid",
])
def test_todays_learned_features_do_not_fit_law_2(rigid_runs: dict, name: str) -> None:
    """The learner's force vector fitted to law 2's: its Fz a weighted sum of its features, its in-plane force
    each feature times the ISF in-plane law's two directions (against the sliding, across it away from the wall),
    every product with its own weight (looser than the learner, whose in-plane weights are two ratios times its
    Fz's weights); the threshold is on the stacked force (Fx, Fy, Fz), the axial-only R^2 is printed beside it."""
    stacked, axial = _learned_r2(*rigid_runs[name])
    print(f"learned features on law 2, {name}: stacked R^2 {stacked:.3f}, Fz-only R^2 {axial:.3f}")
    assert stacked < LEARNED_R2_MAX, (stacked, axial)


@pytest.mark.parametrize("name", ["cone", "pyramid"])
def test_law_1s_form_does_not_fit_law_2(rigid_runs: dict, name: str) -> None:
    """Law 1's form fitted to law 2's force vector (`_law1_r2`); the threshold is on the stacked force, as for the
    learner's features, the axial-only R^2 is printed beside it."""
    stacked, axial = _law1_r2(*rigid_runs[name])
    print(f"law 1's form on law 2, {name}: stacked R^2 {stacked:.3f}, Fz-only R^2 {axial:.3f}")
    assert stacked < LAW1_R2_MAX, (stacked, axial)


def test_springback_is_the_foundations_elastic_part() -> None:
    sheet = PatchSheet(Process(), 5e-5, TIMESTEP_S)
    _drive(sheet, _cone()[:3000])
    stiffness, cap = sheet.node_law(sheet.strain)
    rise = sheet.unloaded_surface() - sheet.z_m
    formed = sheet.z_m < -0.1e-3
    np.testing.assert_allclose(rise[formed], np.minimum(cap / stiffness, -sheet.z_m)[formed], atol=1e-15)
    assert np.all(sheet.unloaded_surface() <= 0.0)
    # p_cap / k, the plate's deflection under the cap pressure: tenths of a mm for the thesis's sheet and tool
    assert 0.1e-3 < float(np.median(rise[formed])) < 1.0e-3


def test_a_short_cone_on_the_plant_with_law_2() -> None:
    from twin.lab.dynamic.run import run_dynamic_lab

    path = part_path(PartSpec(top_half_width_m=0.02, depth_m=1.5e-3))
    _, _, log = run_dynamic_lab(path.t_s, path.p_sheet_m, scenario="nominal", knobs=Knobs({"sheet_law": 2}),
                                    seed=1)
    f = log.f_sheet_n
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(log.p_tip_sheet_m))
    into = log.p_tip_sheet_m[:, 2] < -0.5e-3
    assert into.sum() > 100
    assert np.mean(np.linalg.norm(f[into], axis=1) > 0.0) > 0.95  # in contact
    assert float(np.mean(f[into, 2])) > 100.0
