"""How the controller takes an online correction, measured on the dynamic plant: every 4 ms on every axis (KUKA
RSI's IPO_FAST, ABB EGM's position guidance), every 48 ms on every axis, and every 48 ms on y and z of the path
frame only (ABB EGM's path correction: `EGMActMove ... \\SampleRate:=48`, "nor corrections in x (which is the path
direction)", EGM application manual 3HAC073318 rev. K). The plant's knobs `correction_period_ms` and
`correction_along_path` set it (twin/lab/dynamic/online.py). Each 48 ms case runs twice: with the compensator's
default settings (it predicts over the sensor's latency only), and "predicting over the period", its `period_s`
set to the exported program's sample rate (`twin.apps.export.rapid_egm.SAMPLE_RATE_MS`), as `online --serve egm`
sets it in path-correction mode.

For each variant of `experiments/online_study.py` (the groove and the 60 mm cone, default knobs): a nominal run
(seed 1) to `learn` from, then with seed 3 the ideal path with the controller compensating online under each
interface, with the twin's default model and the learned one. Residuals are `check`'s (tracker minus ideal) as in
that study: rms / max, and in brackets the rms less the tracker offset `learn` found, over the whole run and away
from the reversals. Writes OUT/egm_interface.json and, with `--doc`, the table between the egm-table markers of
docs/online.md (`tests/test_online_interface.py` reruns a cell, slow):

    .venv/bin/python experiments/egm_interface_study.py OUT [--variants groove-default,cone-default] [--doc docs/online.md]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import online_study
from online_study import VARIANTS, _lab, _residual

from twin.apps.export.rapid_egm import SAMPLE_RATE_MS
from twin.sim.online_settings import OnlineSettings

#: The compensator predicting over the path correction's period (`OnlineSettings.period_s`).
OVER_PERIOD = OnlineSettings(period_s=1e-3 * SAMPLE_RATE_MS)
#: (name, plant knobs, the compensator's settings or None for the defaults) of each way the controller takes the
#: correction.
INTERFACES: dict[str, tuple[dict[str, float], OnlineSettings | None]] = {
    "4 ms, all axes (RSI; EGM position guidance)": ({"correction_period_ms": 4.0, "correction_along_path": 1.0}, None),
    "48 ms, all axes": ({"correction_period_ms": 48.0, "correction_along_path": 1.0}, None),
    "48 ms, all axes, predicting over the period": (
        {"correction_period_ms": 48.0, "correction_along_path": 1.0}, OVER_PERIOD),
    "48 ms, y and z of the path (EGM path correction)": (
        {"correction_period_ms": 48.0, "correction_along_path": 0.0}, None),
    "48 ms, y and z of the path (EGM path correction), predicting over the period": (
        {"correction_period_ms": 48.0, "correction_along_path": 0.0}, OVER_PERIOD),
}


def interface_study(out: Path, name: str) -> dict[str, Any]:
    """One variant's rows: the nominal run, then each interface with the default and the learned model."""
    from experiments_cli import cli, cli_json

    path_args, strength = VARIANTS[name]
    out.mkdir(parents=True, exist_ok=True)
    ideal = out / "ideal.csv"
    cli("path", *path_args, "--out", str(ideal))
    online_study.PLANT_KNOBS.clear()
    model = out / "learned.json"
    learned = cli_json("learn", str(_lab(strength, ideal, out / "nominal1", 1)), "--write-model", str(model))
    offset = learned["robot"]["tracker_offset_mm"]
    row: dict[str, Any] = {"variant": name, "nominal": _residual(_lab(strength, ideal, out / "nominal3", 3), ideal,
                                                                 offset)}
    for k, (interface, (knobs, settings)) in enumerate(INTERFACES.items()):
        online_study.PLANT_KNOBS.clear()
        online_study.PLANT_KNOBS.update(knobs)
        for twin, online in (("default", True), ("learned", model)):
            formed = _lab(strength, ideal, out / f"online_{twin}_{k}", 3, online=online, settings=settings)
            row[f"{interface} | {twin}"] = _residual(formed, ideal, offset)
    online_study.PLANT_KNOBS.clear()
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """The page's table: a row per variant and interface."""
    head = "| variant | the controller takes the correction | online, default | online, learned |\n|---|---|---|---|\n"

    def cell(r: dict[str, float]) -> str:
        return f"{r['rms_mm']:.2f} / {r['max_mm']:.2f} ({r['less_offset_rms_mm']:.2f}; {r['away_rms_mm']:.2f})"

    lines = []
    for row in rows:
        nominal = cell(row["nominal"])
        lines.append(f"| {row['variant']} | nominal, no correction | {nominal} | {nominal} |")
        lines += [f"| {row['variant']} | {i} | {cell(row[f'{i} | default'])} | {cell(row[f'{i} | learned'])} |"
                  for i in INTERFACES]
    return head + "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--variants", default="groove-default,cone-default")
    parser.add_argument("--doc", type=Path, help="a page whose egm-table markers get the table")
    args = parser.parse_args()
    rows = [interface_study(args.out / name, name) for name in args.variants.split(",")]
    (args.out / "egm_interface.json").write_text(json.dumps(rows, indent=1))
    md = table(rows)
    if args.doc is not None:
        text = args.doc.read_text()
        start = text.index("<!-- egm-table:begin")
        begin, end = text.index("-->", start) + 3, text.index("<!-- egm-table:end")
        args.doc.write_text(text[:begin] + "\n" + md + text[end:])
    print(md)


if __name__ == "__main__":
    main()
