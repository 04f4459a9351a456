"""The thesis story end to end on the shipped data: what `tx200-twin demo` (and `make demo`) runs.

1. Lab nominal run, with the direction-dependent compliance the thesis saw (sec. 3.3.1).
2. Replay it on the twin.
3. Identify K_R: Method 1 (load test, sec. 4.2.1) and Method 2 (the run, sec. 4.2.2).
4. Compensate as the thesis did, WITH its mistake: Eq. 4.28 with the half-model FE history declared `full`.
5. Lab compensated run; `check` finds the gain ~0.5 and names the cause.
6. Discrepancy workflow on that run, with the mistaken twin: names `force_scale` and the direction effect.
7. Twin compensation with the augmented (corrected) twin; lab compensated run; `check`: residual at the
   tracker's repeatability.
Everything lands in one folder: runs, figures, a rerun recording, report.md and report.json.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from twin.analysis.check import check_run
from twin.analysis.compensate import compensate_formula, compensate_twin, compliance_from_stiffness, gain_of
from twin.analysis.discrepancy.search import find_discrepancy
from twin.analysis.discrepancy.summary import result_summary
from twin.analysis.identify.cartesian import (
    THESIS_CR1_MM_PER_KN,
    THESIS_CR2_MM_PER_KN,
    THESIS_TABLE_4_2_LOADS_N,
    fit_kr_load_cases,
)
from twin.analysis.identify.method2 import method2
from twin.analysis.replay import ReplayResult, replay
from twin.apps.report import write_report
from twin.base.csvio import write_json
from twin.base.resources import data_file
from twin.lab.effects import Effects, write_model_file
from twin.lab.virtual import load_test, run_lab
from twin.process.field import SheetForceField
from twin.process.forces import default_force_history, load_force_history
from twin.process.path import groove_path
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.runs.write import write_run
from twin.sim.quasi_static import Twin

HIDDEN_LOST_MOTION_MRAD = 0.15  # the lab's direction-dependent compliance (hidden from every reader)
T = TypeVar("T")


class _Stages:
    """Prints numbered stages with their wall time."""

    def __init__(self, total: int) -> None:
        self.total, self.index, self.start = total, 0, time.perf_counter()

    def run(self, label: str, func: Callable[[], T]) -> T:
        self.index += 1
        print(f"[{self.index}/{self.total}] {label} ...", end="", flush=True)
        began = time.perf_counter()
        value = func()
        print(f" done ({time.perf_counter() - began:.1f} s)", flush=True)
        return value


def _progress(iteration: int, rms_m: float) -> None:
    """One mark per twin-compensation iteration with its residual, so a long stage shows it is moving."""
    print(f" {iteration}:{1e3 * rms_m:.4f}mm", end="", flush=True)


def _candidate(name: str) -> None:
    """One mark per candidate effect fitted by the discrepancy workflow."""
    print(f" {name}", end="", flush=True)


def _lab(out: Path, name: str, t_s: np.ndarray, p_cmd: np.ndarray, scenario: str, seed: int) -> Run:
    run, truth = run_lab(
        t_s,
        p_cmd,
        scenario=scenario,
        effects=Effects({"direction_dependent_compliance": HIDDEN_LOST_MOTION_MRAD}),
        seed=seed,
    )
    write_run(out / "runs" / name, run, truth=truth, overwrite=True)
    return read_run(out / "runs" / name)  # everything downstream reads the run from disk, never its truth


def run_demo(out: str | Path = "out/demo") -> dict[str, Any]:
    """Run the thesis story and write runs, figures, `demo.rrd`, `report.md` and `report.json` into `out`.

    Returns:
        The numbers of every stage (the content of report.json).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    stages = _Stages(11)
    ideal = groove_path()
    history = default_force_history()
    mistaken = load_force_history(data_file("fe_force_history.csv"), symmetry="full", trust_columns=False)
    f_ideal = SheetForceField(history).rigid_forces(ideal)
    twin = Twin()
    report: dict[str, Any] = {}

    nominal = stages.run(
        "lab: nominal run (hidden direction-dependent compliance)",
        lambda: _lab(out, "nominal", ideal.t_s, ideal.p_sheet_m, "nominal", seed=1),
    )
    nominal_replay = stages.run("replay the nominal run on the twin", lambda: replay(nominal, twin=twin))
    report["nominal"] = nominal_replay.metrics

    def identify() -> dict[str, Any]:
        loads, d = load_test(
            THESIS_TABLE_4_2_LOADS_N,
            effects=Effects({"direction_dependent_compliance": HIDDEN_LOST_MOTION_MRAD}),
            seed=2,
        )
        m1 = fit_kr_load_cases(loads, d)
        m2 = method2(nominal)
        return {"method1": m1, "method2": m2}

    ident = stages.run("identify K_R: Method 1 (load test) and Method 2 (nominal run)", identify)
    k_r1 = ident["method1"].k_r_n_per_m
    report["identify"] = {
        "method1_k_r_n_per_mm": 1e-3 * k_r1,
        "method1_condition_number": ident["method1"].condition_number,
        "method2_k_r_n_per_mm": 1e-3 * ident["method2"].k_r_ideal_n_per_m,
        "method2_k_r_measured_forces_n_per_mm": 1e-3 * ident["method2"].k_r_measured_n_per_m,
        "method2_force_drop_rms_ratio": ident["method2"].force_drop,
    }

    def thesis_compensation() -> np.ndarray:
        c_r = compliance_from_stiffness(k_r1)
        f_mistaken = SheetForceField(mistaken).rigid_forces(ideal)
        comp = compensate_formula(ideal.t_s, ideal.p_sheet_m, f_mistaken, c_r)
        report["thesis_compensation"] = {
            "gain": gain_of(comp, f_ideal, c_r),
            "history_symmetry_declared": "full",
        }
        return comp.p_cmd_sheet_m

    cmd_bug = stages.run(
        "compensate as the thesis did (Eq. 4.28, half-model history declared 'full')", thesis_compensation
    )
    comp_bug = stages.run(
        "lab: compensated run",
        lambda: _lab(out, "compensated_thesis", ideal.t_s, cmd_bug, "compensated", seed=3),
    )
    check_bug = stages.run(
        "check the compensated run", lambda: check_run(comp_bug, ideal.t_s, ideal.p_sheet_m)
    )
    report["check_thesis"] = check_bug.summary()

    found = stages.run(
        "discrepancy workflow on it (twin with the mistaken history)",
        lambda: find_discrepancy(comp_bug, history=mistaken, progress=_candidate),
    )
    report["discrepancy"] = result_summary(found)
    write_model_file(out / "twin_model.json", found.effects, note="found by the demo's discrepancy workflow")

    def corrected() -> np.ndarray:
        comp = compensate_twin(
            ideal.t_s,
            ideal.p_sheet_m,
            Twin(history=mistaken, effects=found.effects.robot),
            progress=_progress,
        )
        report["twin_compensation"] = {
            "iterations": comp.iterations,
            "gain": gain_of(comp, f_ideal, twin.kinematics.compliance(twin.kinematics.q_home)),
        }
        return comp.p_cmd_sheet_m

    cmd_fixed = stages.run("compensate with the corrected twin", corrected)
    comp_fixed = stages.run(
        "lab: compensated run",
        lambda: _lab(out, "compensated_twin", ideal.t_s, cmd_fixed, "compensated", seed=4),
    )
    check_fixed = stages.run("check it", lambda: check_run(comp_fixed, ideal.t_s, ideal.p_sheet_m))
    report["check_final"] = check_fixed.summary()

    def media() -> dict[str, Any]:
        replays: list[tuple[str, Run, ReplayResult]] = [
            ("nominal", nominal, nominal_replay),
            ("compensated_thesis", comp_bug, replay(comp_bug, twin=twin)),
            ("compensated_twin", comp_fixed, replay(comp_fixed, twin=twin)),
        ]
        compliances = {
            "twin (model K_q)": 1e6
            * twin.kinematics.compliance(twin.kinematics.q_home)[np.ix_([0, 2], [0, 2])],
            "Method 1 (lab load test)": 1e6 * np.linalg.inv(k_r1)[np.ix_([0, 2], [0, 2])],
            "Method 2 (run, measured forces)": 1e6 * ident["method2"].c_measured_m_per_n,
            "thesis C_R(1)": THESIS_CR1_MM_PER_KN,
            "thesis C_R(2)": THESIS_CR2_MM_PER_KN,
        }
        return write_report(
            out, ideal, f_ideal, replays, found, check_bug, check_fixed, compliances, twin.model
        )

    report["media"] = stages.run("figures, rerun recording, report", media)
    write_json(out / "report.json", report)
    total = time.perf_counter() - stages.start
    print_summary(report, out, total)
    return report


def print_summary(report: dict[str, Any], out: Path, seconds: float) -> None:
    """The short table at the end of the demo."""
    rows = [
        (
            "nominal: max deflection (measured - commanded)",
            f"{report['nominal']['deflection_max_mm']:.2f} mm",
        ),
        ("nominal: twin replay gap (position rms)", f"{report['nominal']['position_rms_mm']:.3f} mm"),
        ("thesis compensation: gain", f"{report['thesis_compensation']['gain']:.3f}"),
        ("check of that run: gain found", f"{report['check_thesis']['gain']:.3f}"),
        ("check of that run: residual rms", f"{report['check_thesis']['residual_rms_mm']:.3f} mm"),
        (
            "discrepancy: effects named",
            ", ".join(report["discrepancy"]["effects"]) or report["discrepancy"]["effect"],
        ),
        ("corrected twin compensation: gain", f"{report['twin_compensation']['gain']:.3f}"),
        (
            "final run: residual rms / max",
            f"{report['check_final']['residual_rms_mm']:.3f} / "
            f"{report['check_final']['residual_max_mm']:.3f} mm",
        ),
    ]
    width = max(len(r[0]) for r in rows)
    print()
    for label, value in rows:
        print(f"  {label:<{width}}  {value}")
    print(f"\nreport: {out / 'report.md'}   recording: {out / 'demo.rrd'}   ({seconds:.0f} s)")
