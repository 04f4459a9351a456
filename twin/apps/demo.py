"""The thesis story end to end on the shipped data: what `tx200-twin demo` (and `make demo`) runs.

1. Lab nominal run, with the lost motion of joints 2-3 behind the direction-dependent lag the thesis saw
   (sec. 3.3.1).
2. Replay it on the twin.
3. Identify K_R: Method 1 (load test, sec. 4.2.1) and Method 2 (the run, sec. 4.2.2).
4. Compensate as the thesis did, WITH its mistake: Eq. 4.28 with the half-model FE history declared `full`.
5. Lab compensated run; `check` finds the gain ~0.5 and names the cause.
6. Discrepancy workflow on that run, with the mistaken twin: names `force_scale` and `lost_motion`.
7. Twin compensation with the augmented (corrected) twin; lab compensated run; `check`: residual at the
   tracker's repeatability.
Everything lands in one folder: runs, figures, a rerun recording, report.md and report.json.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from twin.analysis.check import CheckResult, check_run
from twin.analysis.compensate import compensate_formula, compensate_twin, compliance_from_stiffness, gain_of
from twin.analysis.compensation_record import CompensationRecord
from twin.analysis.discrepancy.search import DiscrepancyResult, find_discrepancy
from twin.analysis.discrepancy.summary import result_summary
from twin.analysis.identify.cartesian import (
    THESIS_CR1_MM_PER_KN,
    THESIS_CR2_MM_PER_KN,
    THESIS_TABLE_4_2_LOADS_N,
    KrFit,
    fit_kr_load_cases,
)
from twin.analysis.identify.method2 import Method2Result, method2
from twin.analysis.replay import ReplayResult, replay
from twin.apps.report import write_report
from twin.base.jsonio import write_json
from twin.base.resources import data_file
from twin.lab.virtual import load_test, run_lab
from twin.process.description import Process
from twin.process.fe.load import default_force_history, load_force_history
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import groove_path
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.runs.write import write_run
from twin.sim.effects import Effects
from twin.sim.model_file import write_model_file
from twin.sim.spec import TwinSpec

HIDDEN_LOST_MOTION_MRAD = 0.15  # the lab's lost motion of joints 2-3 (hidden from every reader) [mrad]
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


class _Demo:
    """The demo's stages on shared inputs: the ideal groove, its forces, the nominal twin and the report."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.stages = _Stages(11)
        self.ideal = groove_path()
        self.f_ideal = SheetForceField(default_force_history()).rigid_forces(self.ideal)
        self.mistaken = load_force_history(data_file("fe_force_history.csv"), symmetry="full", trust_columns=False)
        self.twin = TwinSpec().build()
        self.report: dict[str, Any] = {}
        self.records: dict[str, CompensationRecord] = {}

    def lab(self, name: str, p_cmd: np.ndarray, scenario: str, seed: int) -> Run:
        """A lab run with the hidden lost motion, written and read back (downstream never sees its truth); a
        compensated run carries what its compensation used (as `lab --commanded` does)."""
        run, truth = run_lab(self.ideal.t_s, p_cmd, scenario=scenario, seed=seed, spec=LAB)
        if name in self.records:
            run = replace(run, meta={**run.meta, "compensation": self.records[name].to_json()})
        write_run(self.out / "runs" / name, run, truth=truth, overwrite=True)
        return read_run(self.out / "runs" / name)

    def identify(self, nominal: Run) -> tuple[KrFit, Method2Result]:
        """Method 1 on a lab load test and Method 2 on the nominal run."""
        loads, d = load_test(THESIS_TABLE_4_2_LOADS_N, seed=2, spec=LAB)
        m1, m2 = fit_kr_load_cases(loads, d), method2(nominal)
        self.report["identify"] = {
            "method1_k_r_n_per_mm": 1e-3 * m1.k_r_n_per_m,
            "method1_condition_number": m1.condition_number,
            "method2_k_r_n_per_mm": 1e-3 * m2.k_r_ideal_n_per_m,
            "method2_k_r_measured_forces_n_per_mm": 1e-3 * m2.k_r_measured_n_per_m,
            "method2_force_drop_rms_ratio": m2.force_drop,
        }
        return m1, m2

    def thesis_compensation(self, k_r1: np.ndarray) -> np.ndarray:
        """Eq. 4.28 with the half-model history declared `full`: the thesis's mistake."""
        c_r = compliance_from_stiffness(k_r1)
        f_mistaken = SheetForceField(self.mistaken).rigid_forces(self.ideal)
        comp = compensate_formula(self.ideal.t_s, self.ideal.p_sheet_m, f_mistaken, c_r)
        self.records["compensated_thesis"] = CompensationRecord(
            "formula", comp.t_s, f_mistaken, self.mistaken.symmetry, self.mistaken.column_symmetry,
            "twin/data/fe_force_history.csv")
        self.report["thesis_compensation"] = {"gain": gain_of(comp, self.f_ideal, c_r), "history_symmetry_declared": "full"}
        return comp.p_cmd_sheet_m

    def corrected(self, spec: TwinSpec) -> np.ndarray:
        """Twin compensation with the augmented twin."""
        comp = compensate_twin(self.ideal.t_s, self.ideal.p_sheet_m, spec, progress=_progress)
        f_used = spec.build().simulate(comp.t_s, comp.p_cmd_sheet_m).f_sheet_n
        self.records["compensated_twin"] = CompensationRecord(
            "twin", comp.t_s, f_used, spec.process.force_history().symmetry,
            spec.process.force_history().column_symmetry)
        kin = self.twin.kinematics
        self.report["twin_compensation"] = {
            "iterations": comp.iterations, "gain": gain_of(comp, self.f_ideal, kin.compliance(kin.q_home)),
        }
        return comp.p_cmd_sheet_m

    def media(
        self, runs: dict[str, tuple[Run, ReplayResult]], found: DiscrepancyResult, checks: tuple[CheckResult, CheckResult],
        identified: tuple[KrFit, Method2Result],
    ) -> dict[str, Any]:
        """Figures, the rerun recording and report.md."""
        kin, k_r1 = self.twin.kinematics, identified[0].k_r_n_per_m
        xz = np.ix_([0, 2], [0, 2])
        compliances = {
            "twin (model K_q)": 1e6 * kin.compliance(kin.q_home)[xz],
            "Method 1 (lab load test)": 1e6 * np.linalg.inv(k_r1)[xz],
            "Method 2 (run, measured forces)": 1e6 * identified[1].c_measured_m_per_n,
            "thesis C_R(1)": THESIS_CR1_MM_PER_KN,
            "thesis C_R(2)": THESIS_CR2_MM_PER_KN,
        }
        replays = [(name, run, rep) for name, (run, rep) in runs.items()]
        return write_report(self.out, self.ideal, self.f_ideal, replays, found, *checks, compliances, self.twin.model)


#: The lab's cell: the thesis's, with a lost motion of joints 2-3 hidden from every reader (sec. 3.3.1).
LAB = TwinSpec(effects=Effects({"lost_motion": HIDDEN_LOST_MOTION_MRAD}))


def run_demo(out: str | Path = "out/demo") -> dict[str, Any]:
    """Run the thesis story and write runs, figures, `demo.rrd`, `report.md` and `report.json` into `out`.

    Returns:
        The numbers of every stage (the content of report.json).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    demo = _Demo(out)
    stages, ideal, report = demo.stages, demo.ideal, demo.report
    nominal = stages.run("lab: nominal run (hidden lost motion)", lambda: demo.lab("nominal", ideal.p_sheet_m, "nominal", 1))
    nominal_replay = stages.run("replay the nominal run on the twin", lambda: replay(nominal, twin=demo.twin))
    report["nominal"] = nominal_replay.metrics
    identified = stages.run("identify K_R: Method 1 (load test) and Method 2 (nominal run)", lambda: demo.identify(nominal))
    cmd_bug = stages.run(
        "compensate as the thesis did (Eq. 4.28, half-model history declared 'full')",
        lambda: demo.thesis_compensation(identified[0].k_r_n_per_m),
    )
    comp_bug = stages.run("lab: compensated run", lambda: demo.lab("compensated_thesis", cmd_bug, "compensated", 3))
    check_bug = stages.run("check the compensated run", lambda: check_run(comp_bug, ideal.t_s, ideal.p_sheet_m))
    report["check_thesis"] = check_bug.summary()
    mistaken = TwinSpec(process=Process(history=demo.mistaken))
    found = stages.run(
        "discrepancy workflow on it (twin with the mistaken history)",
        lambda: find_discrepancy(comp_bug, mistaken, progress=_candidate),
    )
    report["discrepancy"] = result_summary(found)
    augmented = mistaken.replace(effects=found.effects)
    write_model_file(out / "twin_model.json", augmented, note="found by the demo's discrepancy workflow")
    cmd_fixed = stages.run("compensate with the corrected twin", lambda: demo.corrected(augmented))
    comp_fixed = stages.run("lab: compensated run", lambda: demo.lab("compensated_twin", cmd_fixed, "compensated", 4))
    check_fixed = stages.run("check it", lambda: check_run(comp_fixed, ideal.t_s, ideal.p_sheet_m))
    report["check_final"] = check_fixed.summary()
    runs = {
        "nominal": (nominal, nominal_replay),
        "compensated_thesis": (comp_bug, replay(comp_bug, twin=demo.twin)),
        "compensated_twin": (comp_fixed, replay(comp_fixed, twin=demo.twin)),
    }
    report["media"] = stages.run(
        "figures, rerun recording, report", lambda: demo.media(runs, found, (check_bug, check_fixed), identified)
    )
    report["lab_hidden_effects"] = dict(LAB.effects.values)
    write_json(out / "report.json", report)
    print_summary(report, out, time.perf_counter() - stages.start)
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
