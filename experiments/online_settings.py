"""The online compensator's settings tried against its defaults on the dynamic plant (docs/online.md, "What is not
reached"): a faster rate limit, a faster filter and a latency prediction, each grid point one online run (seed 3,
the learned model) of a variant `online_study.py` wrote, its `check` rms less the mean (the tracker's offset).

    .venv/bin/python experiments/online_settings.py STUDY_OUT [--variants groove-default,cone-default]

Tried on groove-default and cone-default only; the held-out variants (the stronger sheets) were not looked at.
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
from pathlib import Path

import numpy as np


def online_rms_mm(variant_dir: Path, latency_s: float, rate_mm_s: float, filter_hz: float) -> float:
    """One online run with these settings and the variant's learned model: rms of check's residual less its mean."""
    from twin.analysis.check import check_run
    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.run import run_dynamic_lab
    from twin.process.description import Process
    from twin.runs.read import read_commanded_csv, read_run
    from twin.runs.write import write_run
    from twin.sim.model_file import read_model_file
    from twin.sim.online import OnlineCompensator, OnlineSettings

    ideal = read_commanded_csv(variant_dir / "ideal.csv")
    model = "table" if "groove" in variant_dir.name else "isf"
    settings = OnlineSettings(latency_s=latency_s, max_rate_mm_s=rate_mm_s, filter_hz=filter_hz)
    corrector = OnlineCompensator(read_model_file(variant_dir / "learned.json"), settings)
    strength = 1.3 if "stronger" in variant_dir.name else 1.0
    run, truth, _ = run_dynamic_lab(ideal.t_s, ideal.values, scenario="nominal", knobs=Knobs(), seed=3,
                                    process=Process(tensile_strength_mpa=strength * 275.0, force_model=model),
                                    declared=Process(force_model=model), corrector=corrector)
    with tempfile.TemporaryDirectory() as tmp:
        write_run(Path(tmp) / "run", run, truth=truth)
        residual = 1e3 * check_run(read_run(Path(tmp) / "run"), ideal.t_s, ideal.values).residual_m
    residual -= residual.mean(axis=0)
    return float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("study", type=Path, help="the OUT folder of experiments/online_study.py")
    parser.add_argument("--variants", default="groove-default,cone-default")
    args = parser.parse_args()
    for name in args.variants.split(","):
        for latency, rate, filter_hz in itertools.product((0.0, 0.016, 0.03), (20.0, 60.0), (10.0, 20.0)):
            rms = online_rms_mm(args.study / name, latency, rate, filter_hz)
            print(f"{name}: latency {latency} s, rate {rate} mm/s, filter {filter_hz} Hz: {rms:.3f} mm", flush=True)


if __name__ == "__main__":
    main()
