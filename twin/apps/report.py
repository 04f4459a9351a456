"""The demo's report: figures (matplotlib), a rerun recording and report.md, from the stages' results."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from twin.analysis.check import CheckResult
from twin.analysis.discrepancy.search import DiscrepancyResult
from twin.analysis.replay import ReplayResult
from twin.base.csvio import write_text
from twin.errors import RunFormatError
from twin.process.toolpath.groove import ToolPath
from twin.runs.format import Run, resample
from twin.viz.deflection_figures import plot_deflection_by_pass, plot_residual_before_after
from twin.viz.path_figures import plot_forces, plot_path_xz
from twin.viz.recording import record_runs
from twin.viz.stiffness_figures import plot_stiffness_ellipse


def write_report(
    out: Path,
    ideal: ToolPath,
    f_ideal_n: np.ndarray,
    replays: Sequence[tuple[str, Run, ReplayResult]],
    found: DiscrepancyResult,
    check_thesis: CheckResult,
    check_final: CheckResult,
    compliances_mm_per_kn: Mapping[str, np.ndarray],
    model: mujoco.MjModel,
) -> dict[str, Any]:
    """Write figures into `out/figures`, `out/demo.rrd` and `out/report.md`; return their paths."""
    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    runs = {name: (run, rep) for name, run, rep in replays}
    nominal, _ = runs["nominal"]
    final, _ = runs["compensated_twin"]
    thesis, _ = runs["compensated_thesis"]
    figures = [
        *_nominal_figures(fig_dir, ideal, f_ideal_n, nominal),
        *_compensation_figures(fig_dir, ideal, thesis, final, found, compliances_mm_per_kn),
    ]
    rrd = record_runs(out / "demo.rrd", list(replays), ideal_sheet_m=ideal.p_sheet_m, twin_model=model)
    _write_markdown(out, figures, rrd, replays, found, check_thesis, check_final)
    return {"figures": [str(f) for f in figures], "recording": str(rrd), "report": str(out / "report.md")}


def _nominal_figures(fig_dir: Path, ideal: ToolPath, f_ideal_n: np.ndarray, nominal: Run) -> list[Path]:
    """Figures 1-3 of the nominal run: its path against the ideal, its forces, its deflection per pass.

    Args:
        fig_dir: Folder of the figures.
        ideal: The ideal tool path, sheet frame [m, s].
        f_ideal_n: Ideal (FE) force at the ideal path's samples [N], shape (n, 3).
        nominal: The nominal run, with forces.

    Returns:
        The three PNG files written.

    Raises:
        RunFormatError: The nominal run has no forces.
    """
    if nominal.forces is None:
        raise RunFormatError(nominal.directory or "nominal run", "the demo report needs forces.csv")
    return [
        plot_path_xz(
            fig_dir / "1_nominal_path_xz.png",
            ideal.p_sheet_m,
            nominal.tracker.values,
            t_ideal_s=ideal.t_s,
            t_measured_s=nominal.tracker.t_s,
            title="Nominal run: ideal vs measured tool path (cf. thesis Fig. 3.10)",
        ),
        plot_forces(
            fig_dir / "2_nominal_forces.png",
            nominal.forces.t_s,
            nominal.forces.values,
            t_ideal_s=ideal.t_s,
            f_ideal_n=f_ideal_n,
            title="Nominal run: measured vs ideal (FE) forces (cf. thesis Fig. 3.11)",
        ),
        plot_deflection_by_pass(
            fig_dir / "3_nominal_deflection_by_pass.png",
            nominal.tracker.values[:, 0],
            nominal.tracker.values - resample(nominal.commanded, nominal.tracker.t_s),
            *_labels(ideal, nominal.tracker.t_s),
            title="Nominal run: deflection per pass",
        ),
    ]


def _compensation_figures(
    fig_dir: Path,
    ideal: ToolPath,
    thesis: Run,
    final: Run,
    found: DiscrepancyResult,
    compliances_mm_per_kn: Mapping[str, np.ndarray],
) -> list[Path]:
    """Figures 4-6: the discrepancy residual, the stiffness ellipses and the run compensated with the twin.

    Args:
        fig_dir: Folder of the figures.
        ideal: The ideal tool path, sheet frame [m, s].
        thesis: The run compensated as in the thesis.
        final: The run compensated with the corrected twin.
        found: The discrepancy workflow's result on the thesis's compensated run.
        compliances_mm_per_kn: Label -> x-z compliance [mm/kN], shape (2, 2).

    Returns:
        The three PNG files written.
    """
    return [
        plot_residual_before_after(
            fig_dir / "4_discrepancy_residual.png",
            thesis.tracker.t_s,
            found.residual_before["position"],
            found.residual_after["position"],
            label_before="twin as used for the thesis compensation",
            label_after="twin + " + " + ".join(found.found or (found.verdict,)),
            title="Thesis compensated run: measured - twin",
        ),
        plot_stiffness_ellipse(
            fig_dir / "5_stiffness_ellipses.png",
            list(compliances_mm_per_kn.values()),
            list(compliances_mm_per_kn),
        ),
        plot_path_xz(
            fig_dir / "6_compensated_run_xz.png",
            ideal.p_sheet_m,
            final.tracker.values,
            p_commanded_sheet_m=final.commanded.values,
            t_ideal_s=ideal.t_s,
            t_measured_s=final.tracker.t_s,
            t_commanded_s=final.commanded.t_s,
            title="Run compensated with the corrected twin (cf. thesis Fig. 5.1)",
        ),
    ]


def _labels(ideal: ToolPath, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    index = np.clip(np.searchsorted(ideal.t_s, t_s), 0, len(ideal.t_s) - 1)
    return ideal.pass_index[index], ideal.direction[index]


def _write_markdown(
    out: Path,
    figures: Sequence[Path],
    rrd: Path,
    replays: Sequence[tuple[str, Run, ReplayResult]],
    found: DiscrepancyResult,
    check_thesis: CheckResult,
    check_final: CheckResult,
) -> None:
    lines = ["# tx200-twin demo: the thesis story on the twin", ""]
    lines += [
        "| run | max deflection [mm] | twin replay gap, position rms [mm] | force rms [N] |",
        "|---|---|---|---|",
    ]
    for name, _, rep in replays:
        m = rep.metrics
        lines.append(
            f"| {name} | {m['deflection_max_mm']:.2f} | {m['position_rms_mm']:.3f} | "
            f"{m.get('force_rms_n', float('nan')):.1f} |"
        )
    thesis, final = check_thesis.summary(), check_final.summary()
    lines += [
        "",
        "## Checks against the ideal path",
        f"- Thesis compensation (half-model history declared `full`): residual rms {thesis['residual_rms_mm']:.3f} mm,"
        f" max {thesis['residual_max_mm']:.3f} mm; {check_thesis.diagnosis}.",
        f"- Corrected twin compensation: residual rms {final['residual_rms_mm']:.3f} mm, "
        f"max {final['residual_max_mm']:.3f} mm; {check_final.diagnosis}.",
        "",
        "## Discrepancy workflow on the thesis's compensated run",
        f"- Verdict: `{found.verdict}`; effects named in order: {', '.join(found.found) or 'none'} "
        f"({100 * found.explained_fraction:.0f} % of the gap explained); what is left: {found.remainder['words']}.",
        f"- Parameters: {found.effects.named_parameters()}.",
        f"- Gap before: {found.gap_before}; after: {found.gap_after}; noise estimated: {found.noise}.",
        "",
        "## Figures",
    ]
    lines += [f"![{f.stem}](figures/{f.name})" for f in figures]
    lines += ["", f"Rerun recording: `{rrd.name}` (open with `rerun {rrd.name}`).", ""]
    write_text(out / "report.md", "\n".join(lines))
