"""The thesis reproduction table: every number of the thesis the twin can produce, thesis vs twin.

The numbers on the twin side are read from the JSON outputs of the `tx200-twin` commands a new user would
run (`tx200-twin reproduce` runs them, in order, in a scratch folder); each row names its command. This
module holds the thesis's values, the rows and the Markdown; it computes nothing from the twin itself.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twin.analysis.identify.cartesian import (
    THESIS_CR1_MM_PER_KN,
    THESIS_CR2_MM_PER_KN,
    THESIS_KR1_N_PER_MM,
    THESIS_KR2_N_PER_MM,
)

#: The commands, in the order `reproduce` runs them; `{dir}` is the scratch folder.
COMMANDS: tuple[tuple[str, str], ...] = (
    ("loadtest", "tx200-twin lab --scenario loadtest --seed 1 --out {dir}/loadtest.csv"),
    ("method1", "tx200-twin identify --method 1 --loads {dir}/loadtest.csv --json {dir}/method1.json"),
    ("nominal", "tx200-twin lab --scenario nominal --seed 1 --out {dir}/nominal --json {dir}/nominal.json"),
    ("method2", "tx200-twin identify --method 2 {dir}/nominal --json {dir}/method2.json"),
    ("cnc", "tx200-twin lab --scenario cnc --seed 1 --out {dir}/cnc --json {dir}/cnc.json"),
    (
        "compensate_thesis",
        "tx200-twin compensate --method formula --stiffness {dir}/method1.json "
        "--history twin/data/fe_force_history.csv --symmetry full --unchecked-symmetry "
        "--out {dir}/thesis_cmd.csv --json {dir}/compensate_thesis.json",
    ),
    (
        "lab_thesis",
        "tx200-twin lab --scenario compensated --commanded {dir}/thesis_cmd.csv --seed 3 --out {dir}/thesis_run",
    ),
    ("check_thesis", "tx200-twin check {dir}/thesis_run --json {dir}/check_thesis.json"),
    (
        "compensate_fixed",
        "tx200-twin compensate --method formula --stiffness {dir}/method1.json --out {dir}/fixed_cmd.csv "
        "--json {dir}/compensate_fixed.json",
    ),
    (
        "lab_fixed",
        "tx200-twin lab --scenario compensated --commanded {dir}/fixed_cmd.csv --seed 4 --out {dir}/fixed_run",
    ),
    ("check_fixed", "tx200-twin check {dir}/fixed_run --json {dir}/check_fixed.json"),
    ("compensate_twin", "tx200-twin compensate --method twin --out {dir}/twin_cmd.csv --json {dir}/compensate_twin.json"),
    (
        "lab_twin",
        "tx200-twin lab --scenario compensated --commanded {dir}/twin_cmd.csv --seed 5 --out {dir}/twin_run",
    ),
    ("check_twin", "tx200-twin check {dir}/twin_run --json {dir}/check_twin.json"),
)


@dataclass(frozen=True)
class Row:
    """One line of the table.

    Attributes:
        quantity: What it is, with the thesis's equation or section.
        unit: Unit of both values.
        thesis: The thesis's value (a matrix, a number, or words where the thesis gives no number).
        twin: The twin's value.
        commands: Names (keys of `COMMANDS`) of the commands that make it.
        note: Why the two differ, where they do.
        fitted: Whether the calibration saw it: the targets it holds (`twin.analysis.calibration.targets`).
        predicted: Its leave-one-out prediction (each entry refitted without its own target), or None.
    """

    quantity: str
    unit: str
    thesis: Any
    twin: Any
    commands: tuple[str, ...]
    note: str = ""
    fitted: str = "no: a prediction"
    predicted: Any = None

    @property
    def relative_difference(self) -> float | None:
        """|twin - thesis| / |thesis| (Frobenius for matrices); None where the thesis gives no number."""
        if isinstance(self.thesis, str):
            return None
        a, b = np.asarray(self.twin, dtype=float), np.asarray(self.thesis, dtype=float)
        return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def _fmt(value: Any) -> str:
    if isinstance(value, str):
        return value
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        return f"{float(a):.3g}" if abs(float(a)) < 100 else f"{float(a):.0f}"
    if a.ndim == 1:
        return "[" + ", ".join(_fmt(v) for v in a) + "]"
    return "[" + ", ".join(_fmt(r) for r in a) + "]"


def _loo_cell(row: Row) -> str:
    if row.predicted is None:
        return "–"
    a, b = np.asarray(row.predicted, dtype=float), np.asarray(row.thesis, dtype=float)
    return f"{_fmt(row.predicted)} ({100 * np.linalg.norm(a - b) / np.linalg.norm(b):.0f} %)"


def rows(outputs: Mapping[str, Mapping[str, Any]], loo: Mapping[str, Mapping[str, Any]] | None = None) -> list[Row]:
    """The table's rows from the commands' JSON outputs (keys of `COMMANDS` -> parsed JSON).

    Args:
        outputs: The commands' JSON outputs.
        loo: Target name -> its leave-one-out record (`tx200-twin calibrate --loo`); None: no predictions.
    """
    m1, m2 = outputs["method1"], outputs["method2"]

    def pred(*names: str) -> Any:
        if loo is None:
            return None
        values = [float(loo[n]["predicted"]) for n in names]
        return values[0] if len(values) == 1 else np.reshape(values, (2, 2))

    def alone(name: str) -> str:
        sole = [] if loo is None else list(loo[name]["sole"])
        return f"; {', '.join(sole)} alone sets it: held at its prior, not a prediction" if sole else ""

    asym = float(np.linalg.norm(0.5 * (THESIS_CR1_MM_PER_KN - THESIS_CR1_MM_PER_KN.T)))
    floor = asym / float(np.linalg.norm(THESIS_CR1_MM_PER_KN))
    return [
        Row("K_R(1), Method 1 (Eq. 4.17)", "N/mm", THESIS_KR1_N_PER_MM, m1["k_r_n_per_mm"], ("loadtest", "method1"),
            "the twin's arm moves in the x–z plane, so its y row and column hold no coupling; the thesis's "
            "(-949, 1130 N/mm) come from loads that all lie in one octant (Table 4.2) and are not reciprocal",
            "only inv(K_R(1)) y-y, as target c_yy" + alone("c_yy")),
        Row("C_R(1) x–z, y held (Eq. 4.27a)", "mm/kN", THESIS_CR1_MM_PER_KN, m1["c_r_xz_y_held_mm_per_kn"],
            ("loadtest", "method1"),
            f"its antisymmetric part alone is {100 * floor:.0f} % of its norm; the twin's joint friction gives part "
            "of it (see docs/thesis-reproduction.md)", "yes: 4 targets", pred("cr1_xx", "cr1_xz", "cr1_zx", "cr1_zz")),
        Row("K_R(2), Method 2, ideal forces (Eq. 4.26)", "N/mm", THESIS_KR2_N_PER_MM, m2["k_r_n_per_mm"],
            ("nominal", "method2"), fitted="yes: as its inverse C_R(2)"),
        Row("C_R(2) (Eq. 4.27b)", "mm/kN", THESIS_CR2_MM_PER_KN, m2["c_r_mm_per_kn"], ("nominal", "method2"),
            fitted="yes: 4 targets", predicted=pred("cr2_xx", "cr2_xz", "cr2_zx", "cr2_zz")),
        Row("peak vertical force, nominal robot run (§4.2.3)", "N", 2000.0, outputs["nominal"]["peak_fz_n"],
            ("nominal",), "the thesis says 'about 2 kN'", "yes", pred("peak_fz")),
        Row("formed depth after springback, rigid CNC (§2.3.1)", "mm", 8.7, outputs["cnc"]["formed_depth_mm"],
            ("cnc",), fitted="yes" + alone("depth_cnc"), predicted=pred("depth_cnc")),
        Row("gain of the failed compensated run, found by `check` (§5.1)", "-", 0.5,
            outputs["check_thesis"]["gain"], ("method1", "compensate_thesis", "lab_thesis", "check_thesis"),
            "the half-model forces were used as full; the cause `check` names from the run's record of what the "
            f"compensation used: `{outputs['check_thesis'].get('cause', 'unknown')}`", "yes", pred("gain_failed_run")),
        Row("residual of the corrected run, rms (§5.1.2)", "mm",
            "no number: 'quite satisfactory', offsets at the stroke ends (Figs. 5.4–5.5)",
            outputs["check_fixed"]["residual_rms_mm"],
            ("method1", "compensate_fixed", "lab_fixed", "check_fixed"),
            "Eq. 4.28 with K_R(1) and the doubled forces, run on the lab; a linear C_R cannot cancel the "
            "friction offsets that flip with each reversal"),
        Row("residual of a twin-compensated run, rms (not in the thesis)", "mm", "–",
            outputs["check_twin"]["residual_rms_mm"], ("compensate_twin", "lab_twin", "check_twin"),
            "the twin's compensation knows the friction"),
    ]


def markdown(table: Sequence[Row]) -> str:
    """The table in Markdown, followed by the numbered commands."""
    index = {name: i + 1 for i, (name, _) in enumerate(COMMANDS)}
    lines = [
        "| quantity | unit | thesis | twin | rel. diff. | fitted? | leave-one-out (rel. diff.) | commands | note |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table:
        rel = r.relative_difference
        rel_text = "–" if rel is None else f"{100 * rel:.0f} %"
        cmds = ", ".join(str(index[c]) for c in r.commands)
        lines.append(
            f"| {r.quantity} | {r.unit} | {_fmt(r.thesis)} | {_fmt(r.twin)} | {rel_text} | {r.fitted} | "
            f"{_loo_cell(r)} | {cmds} | {r.note} |"
        )
    lines += ["", "Commands (run in order, `DIR` a scratch folder; seeds fixed, so the numbers repeat):", ""]
    for i, (_, command) in enumerate(COMMANDS, start=1):
        lines.append(f"{i}. `{command.format(dir='DIR')}`")
    return "\n".join(lines) + "\n"


def loo_records(calibration: Mapping[str, Any]) -> dict[str, Mapping[str, Any]]:
    """Target name -> leave-one-out record, from a `tx200-twin calibrate --loo --json` output."""
    return {str(p["target"]): p for p in calibration["leave_one_out"]}


def loo_markdown(calibration: Mapping[str, Any]) -> str:
    """The fit's statistics and the leave-one-out table, per target, from `calibrate --loo --json` output."""
    targets, dof = int(calibration["targets_count"]), int(calibration["degrees_of_freedom"])
    sigma = {str(t["target"]): float(t["sigma"]) for t in calibration["targets"]}
    records = list(loo_records(calibration).values())
    lines = [
        "## Fitted and predicted",
        "",
        f"The calibration fits {targets - dof} parameters to {targets} targets: {dof} degrees of freedom, reduced "
        f"χ² {float(calibration['chi2_reduced']):.2f} (`tx200-twin calibrate --loo --json docs/calibration.json`). "
        "Every thesis number in the table below is one of the targets, except K_R(1)'s y couplings; the twin "
        "column is therefore a fit, not a prediction. The leave-one-out column is: each target refitted without "
        "it, from the full fit, then predicted (its refit has one target and one degree of freedom less). Where "
        "one parameter alone sets a target, nothing else constrains that parameter: the refit holds it at its "
        "prior, so that prediction is essentially the prior, itself read from the same thesis number. The "
        "fitted value here is the noise-free twin experiment of the calibration; the table below runs the lab "
        "(noise, seeds), so its twin column differs slightly.",
        "",
        "| target | unit | thesis | fitted | leave-one-out | (leave-one-out − thesis)/σ | refit χ²_red (dof) | note |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for p in records:
        name = str(p["target"])
        z = (float(p["predicted"]) - float(p["thesis"])) / sigma[name]
        note = f"{', '.join(p['sole'])} alone sets it: held at its prior, not a prediction" if p["sole"] else ""
        lines.append(
            f"| {name} | {p['unit']} | {_fmt(p['thesis'])} | {_fmt(p['fitted'])} | {_fmt(p['predicted'])} | "
            f"{z:+.1f} | {float(p['chi2_reduced']):.2f} ({p['dof']}) | {note} |"
        )
    return "\n".join(lines) + "\n\n"
