"""What the thesis measured on the real cell, and the same quantities measured on the twin.

Each target is a number of the thesis with the section it comes from and an uncertainty that says how well the
thesis pins it down (the calibration weighs each residual by 1/σ):

| target | thesis | σ | why this σ |
|---|---|---|---|
| C_R(1) x–z, 4 entries (Eq. 4.27a) | [[1.54, 0.19], [0.79, 1.02]] mm/kN | 0.15 mm/kN | §4.2.3: the two methods' diagonals differ by < 0.15 mm/kN |
| C_yy = inv(K_R(1))[y, y] (Eq. 4.17) | 1.227 mm/kN | 0.15 mm/kN | the only y information (pins joint 1) |
| C_R(2) x–z, 4 entries (Eq. 4.27b) | [[1.67, 0.68], [0.53, 0.95]] mm/kN | 0.15 mm/kN | as C_R(1) |
| peak vertical force, robot run (§4.2.3) | 2000 N | 200 N | "about 2 kN" |
| formed depth after springback, rigid CNC (§2.3.1) | 8.7 mm | 0.2 mm | read as "≈ 8.7 mm" |
| compensation gain of the failed run (§5.1) | 0.5 | 0.05 | half the forces were used |
| k_load (Aerens et al., IJAMT 46, 2010, prior) | 0.15 kN/mm | 0.05 kN/mm | exponent 0.09 ± 0.03 at 1.7 kN, read on the step-down Δz = 1 mm (as published the exponent is on the scallop height: about 0.18 on Δz) |

The twin side repeats what the thesis did, without noise: the Method 1 load test at Table 4.2's loads
(static deflections, OLS K_R, C_R(1) = inverse of the x–z sub-block of K_R, y held); Method 2 on a nominal
run with ideal (FE) forces; the CNC test on the rigid machine; and the failed run (compensation Eq. 4.28
with C_R from the load test and the half-model forces used as full, then `check`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twin.analysis.check import check_run
from twin.analysis.compensate import compensate_formula, compliance_from_stiffness
from twin.analysis.identify.cartesian import (
    THESIS_CR1_MM_PER_KN,
    THESIS_CR2_MM_PER_KN,
    THESIS_KR1_N_PER_MM,
    THESIS_TABLE_4_2_LOADS_N,
    fit_kr_load_cases,
)
from twin.analysis.identify.method2 import method2
from twin.base.signals import interp_rows, uniform_times
from twin.errors import InputError
from twin.process.force.table import SheetForceField
from twin.process.part.springback import form_rigidly
from twin.process.toolpath.groove import ToolPath
from twin.runs.format import Run, Stream
from twin.sim.quasi_static import Twin

_XZ = np.ix_([0, 2], [0, 2])
_ENTRIES = ("xx", "xz", "zx", "zz")
#: Compliance entries' uncertainty [mm/kN] (§4.2.3: the two methods' diagonals differ by < 0.15 mm/kN).
SIGMA_COMPLIANCE_MM_PER_KN = 0.15


@dataclass(frozen=True)
class Target:
    """One measured number of the thesis.

    Attributes:
        name: Identifier, e.g. `cr1_xz`.
        thesis: The thesis's value, in `unit`.
        sigma: Its uncertainty (1σ), in `unit`.
        unit: Unit of `thesis` and `sigma`.
        source: Where the thesis gives it.
    """

    name: str
    thesis: float
    sigma: float
    unit: str
    source: str


def _compliance_targets(prefix: str, matrix: np.ndarray, source: str) -> list[Target]:
    return [
        Target(f"{prefix}_{e}", float(v), SIGMA_COMPLIANCE_MM_PER_KN, "mm/kN", source)
        for e, v in zip(_ENTRIES, matrix.ravel(), strict=True)
    ]


TARGETS: tuple[Target, ...] = (
    *_compliance_targets("cr1", THESIS_CR1_MM_PER_KN, "Eq. 4.27a (Method 1, load test)"),
    Target(
        "c_yy", float(np.linalg.inv(THESIS_KR1_N_PER_MM)[1, 1] * 1e3), SIGMA_COMPLIANCE_MM_PER_KN, "mm/kN",
        "Eq. 4.17, inv(K_R(1)) y-y",
    ),
    *_compliance_targets("cr2", THESIS_CR2_MM_PER_KN, "Eq. 4.27b (Method 2, nominal run, ideal forces)"),
    Target("peak_fz", 2000.0, 200.0, "N", "§4.2.3: maximum vertical force about 2 kN"),
    Target("depth_cnc", 8.7, 0.2, "mm", "§2.3.1: formed depth after springback on the rigid CNC"),
    Target("gain_failed_run", 0.5, 0.05, "-", "§5.1: half-model forces used as full"),
    Target("k_load_prior", 0.15, 0.05, "kN/mm", "Aerens et al. (IJAMT 46, 2010) read on the step-down: dFz/dΔz = 0.09·Fz/Δz"),
)


@dataclass(frozen=True)
class TwinMeasurements:
    """The targets' quantities measured on a twin (same order and units as `TARGETS`), and the matrices.

    Attributes:
        values: Target name -> twin value.
        k_r1_n_per_mm: K_R from the load test [N/mm], (3, 3).
        cr1_mm_per_kn: C_R(1), x–z, y held [mm/kN], (2, 2).
        k_r2_n_per_mm: K_R(2) from the nominal run with ideal forces [N/mm], (2, 2).
        cr2_mm_per_kn: C_R(2) [mm/kN], (2, 2).
        force_drop: Method 2's RMS fall of the sheet force as the robot gave way [-].
        residual_corrected_mm: RMS residual of a correctly compensated run (Eq. 4.28 with full forces) [mm].
    """

    values: dict[str, float]
    k_r1_n_per_mm: np.ndarray
    cr1_mm_per_kn: np.ndarray
    k_r2_n_per_mm: np.ndarray
    cr2_mm_per_kn: np.ndarray
    force_drop: float
    residual_corrected_mm: float


def _noise_free_run(twin: Twin, path: ToolPath, p_cmd_sheet_m: np.ndarray, scenario: str) -> Run:
    """A run of the twin as an ideal lab would measure it: tracker at 50 Hz, sheet force at 30 Hz."""
    sim = twin.simulate(path.t_s, p_cmd_sheet_m)
    t_end = float(path.t_s[-1])
    t_tr, t_fs = uniform_times(t_end, 50.0), uniform_times(t_end, 30.0)
    return Run(
        directory=None,
        meta={"scenario": scenario, "tracker_rate_hz": 50.0, "sensor_rate_hz": 30.0},
        commanded=Stream(path.t_s, p_cmd_sheet_m),
        tracker=Stream(t_tr, interp_rows(t_tr, sim.t_s, sim.p_sheet_m)),
        forces=Stream(t_fs, interp_rows(t_fs, sim.t_s, sim.f_sheet_n)),
    )


def measure_twin(
    twin: Twin,
    path: ToolPath,
    *,
    field_factory: Callable[[], SheetForceField],
    f_ideal_n: np.ndarray,
) -> TwinMeasurements:
    """Measure the thesis's quantities on a twin, without noise.

    Args:
        twin: The twin (its K_q and field are the candidate's).
        path: The ideal groove path U_ID.
        field_factory: A fresh sheet force field with the candidate's constants (for the CNC test).
        f_ideal_n: Ideal (FE) forces along `path` [N], shape (n, 3).
    """
    d = np.array([twin.static_deflection(f) for f in THESIS_TABLE_4_2_LOADS_N])
    k_r1 = fit_kr_load_cases(THESIS_TABLE_4_2_LOADS_N, d).k_r_n_per_m
    cr1 = np.linalg.inv(k_r1[_XZ]) * 1e6
    nominal = _noise_free_run(twin, path, path.p_sheet_m, "nominal")
    m2 = method2(nominal, twin.spec.process)
    cr2 = np.linalg.inv(m2.k_r_ideal_n_per_m) * 1e6
    assert nominal.forces is not None
    peak_fz = float(np.max(nominal.forces.values[:, 2]))
    _, z_after = form_rigidly(path, field_factory())
    c_r = compliance_from_stiffness(k_r1)
    failed = compensate_formula(path.t_s, path.p_sheet_m, 0.5 * f_ideal_n, c_r)
    gain = check_run(_noise_free_run(twin, path, failed.p_cmd_sheet_m, "compensated"), path.t_s, path.p_sheet_m)
    right = compensate_formula(path.t_s, path.p_sheet_m, f_ideal_n, c_r)
    corrected = check_run(
        _noise_free_run(twin, path, right.p_cmd_sheet_m, "compensated"), path.t_s, path.p_sheet_m
    )
    values = {
        **{f"cr1_{e}": float(v) for e, v in zip(_ENTRIES, cr1.ravel(), strict=True)},
        "c_yy": float(np.linalg.inv(k_r1)[1, 1] * 1e6),
        **{f"cr2_{e}": float(v) for e, v in zip(_ENTRIES, cr2.ravel(), strict=True)},
        "peak_fz": peak_fz,
        "depth_cnc": -1e3 * float(np.min(z_after)),
        "gain_failed_run": gain.gain,
        "k_load_prior": _table_field(twin).k_load * 1e-6,
    }
    return TwinMeasurements(
        values=values,
        k_r1_n_per_mm=1e-3 * k_r1,
        cr1_mm_per_kn=cr1,
        k_r2_n_per_mm=1e-3 * m2.k_r_ideal_n_per_m,
        cr2_mm_per_kn=cr2,
        force_drop=m2.force_drop,
        residual_corrected_mm=float(corrected.summary()["residual_rms_mm"]),  # type: ignore[arg-type]
    )


def _table_field(twin: Twin) -> SheetForceField:
    """The twin's sheet field, the per-pass table field the calibration sets."""
    field = twin.sheet_field
    if not isinstance(field, SheetForceField):
        raise InputError(f"the calibration needs the table force field, the twin has {type(field).__name__}")
    return field
