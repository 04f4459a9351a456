"""What a user waits for: the CLI replay of a Ø160 mm cone run and its parts, and the dynamic plant's real-time
factor on the groove and a cone (issue #38's measures).

    .venv/bin/python experiments/speed_parts.py WORKDIR

Makes the quasi-static lab run of a Ø160 mm, 40 mm deep cone on the ISF model (seed 1, 45 239 tracker samples)
in WORKDIR, then times (best of 3): `tx200-twin replay` as a subprocess (wall, imports included), reading the
run, the batched IK of its command, the twin's replay; and (best of 2) the dynamic plant on the groove and on an
Ø80 mm, 20 mm deep cone. Prints one line per measure; timings are this machine's.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path


def _best(f: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def main(work: Path) -> None:
    from twin.analysis.replay import replay
    from twin.analysis.resolve import resolve_spec
    from twin.lab.dynamic.knobs import Knobs
    from twin.lab.dynamic.run import run_dynamic_lab
    from twin.lab.virtual import run_lab
    from twin.process.description import Process
    from twin.process.toolpath.groove import groove_path
    from twin.process.toolpath.shapes import PartSpec, part_path
    from twin.runs.read import read_run
    from twin.runs.write import write_run
    from twin.sim.spec import TwinSpec

    run_dir = work / "cone160"
    if not run_dir.is_dir():
        path = part_path(PartSpec(depth_m=40e-3, top_half_width_m=80e-3))
        run, truth = run_lab(path.t_s, path.p_sheet_m, scenario="nominal", seed=1,
                             spec=TwinSpec(process=Process(force_model="isf")))
        write_run(run_dir, run, truth=truth)
    cli = [str(Path(sys.executable).parent / "tx200-twin"), "replay", str(run_dir)]
    print(f"CLI replay, wall: {_best(lambda: subprocess.run(cli, check=True, capture_output=True), 3):.2f} s")
    print(f"  reading the run: {_best(lambda: read_run(run_dir), 3):.2f} s")
    run = read_run(run_dir)
    twin = resolve_spec(run=run).build()
    p_base = twin.p_base_sheet_origin + run.commanded.values @ twin.R_base_sheet.T
    print(f"  IK of {len(p_base)} commanded samples: {_best(lambda: twin.kinematics.ik_path(p_base), 3):.2f} s")
    print(f"  replay on a ready twin (IK kept): {_best(lambda: replay(run, twin), 3):.2f} s")
    for name, path, process in (
        ("groove", groove_path(), None),
        ("cone 80x20", part_path(PartSpec(depth_m=20e-3, top_half_width_m=40e-3)), Process(force_model="isf")),
    ):
        wall = _best(lambda p=path, q=process: run_dynamic_lab(p.t_s, p.p_sheet_m, scenario="nominal",
                                                                knobs=Knobs(), seed=1, process=q), 2)
        machining = float(path.t_s[-1] - path.t_s[0])
        print(f"dynamic plant, {name}: {machining:.1f} s in {wall:.2f} s -> {machining / wall:.1f}x real time")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out/speed"))
