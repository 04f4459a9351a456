"""CLI-level speed ratios of `tx200-twin bench`: `compensate --method twin` and `place` over `replay` of one path,
each a fresh `tx200-twin` process as a user runs it, after the fixed costs.

The workload: a 45° cone written by `tx200-twin path --shape cone` (Ø 160 mm, 40 mm deep: 80 641 samples; Ø 20 mm,
2 mm deep for a smoke run) and one nominal lab run of it (`tx200-twin lab --commanded`, seed 1), the run the
replay replays. The three commands are

    tx200-twin replay RUN
    tx200-twin compensate --method twin --ideal cone.csv --out cmd.csv
    tx200-twin place --ideal cone.csv

Fixed costs: each command's start-up, imports and path load, timed as a fresh interpreter that builds the CLI's
parser (what every command does first), imports the twin (`twin.sim.quasi_static`: MuJoCo, numba) and the
command's task modules, and reads the command's input (`read_run` of the run; `ideal_path` of the cone) and
stops there (`FIXED`). A ratio is (command − its fixed cost) / (replay − the replay's fixed cost): the work of the
command in replays' worth (the issue's targets: compensate at most 4, place at most 20). Each round runs the six
processes interleaved (a load on the machine weighs on all alike); medians of the rounds are reported. A round
that is not a smoke run is preceded by one untimed run of each command (compiled kernels cached).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from twin.errors import InputError

#: `tx200-twin ARGS` in a fresh interpreter, as the console script runs it.
CLI = "import sys; from twin.cli import main; sys.argv[0] = 'tx200-twin'; sys.exit(main(sys.argv[1:]))"
_START = ("import sys; from pathlib import Path; from twin.cli import build_parser; build_parser(); "
          "import twin.sim.quasi_static; ")
_IDEAL = "from twin.apps.tasks.inputs import ideal_path; ideal_path(Path(sys.argv[1]))"
#: Each command's fixed costs in a fresh interpreter (its argument: the run, or the cone's CSV).
FIXED = {
    "replay": _START + "import twin.apps.tasks.replay; from twin.runs.read import read_run; read_run(Path(sys.argv[1]))",
    "compensate": _START + "import twin.apps.tasks.compensate, twin.analysis.check; " + _IDEAL,
    "place": _START + "import twin.apps.tasks.place; " + _IDEAL,
}


def _workload_in_process(work: Path, top_width_m: float, depth_m: float) -> None:
    """The cone and its nominal run written in this process (a smoke run: two start-ups less), by the tasks the
    `path` and `lab` commands run."""
    from twin.apps.tasks.lab import LabRequest, lab_task
    from twin.apps.tasks.path import PathRequest, path_task

    path_task(PathRequest(work / "cone.csv", "cone", depth_mm=1e3 * depth_m, top_width_mm=1e3 * top_width_m))
    lab_task(LabRequest("nominal", work / "run", 1, commanded=work / "cone.csv"))


def _python(code: str, *args: str | Path, cwd: Path) -> float:
    """Wall time of `python -c code args` in `cwd` [s]; a failing command raises (its stderr in the message)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          check=False)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"tx200-twin bench: `{' '.join(map(str, args))}` failed: {done.stderr.strip()[-2000:]}")
    return wall


def cli_ratios(top_width_m: float = 0.16, depth_m: float = 0.04, repeats: int = 3, *, smoke: bool = False) -> dict[str, Any]:
    """Time the three commands and their fixed costs on a cone (module docstring).

    Args:
        top_width_m: The cone's top diameter [m].
        depth_m: Its depth [m].
        repeats: Timed rounds (>= 1); medians reported.
        smoke: No untimed warm-up round (a quick check of the keys).

    Returns:
        `cli`: samples, rounds, the median wall time of each command and of its fixed costs [s], the commands;
        `cli_compensate_over_replay` and `cli_place_over_replay` [-].
    """
    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    with tempfile.TemporaryDirectory(prefix="tx200-bench-cli-") as tmp:
        work = Path(tmp)
        setup: list[tuple[str, ...]] = [
            ("path", "--shape", "cone", "--top-width-mm", f"{1e3 * top_width_m:g}", "--depth-mm", f"{1e3 * depth_m:g}",
             "--out", str(work / "cone.csv")),
            ("lab", "--scenario", "nominal", "--commanded", str(work / "cone.csv"), "--seed", "1", "--out",
             str(work / "run")),
        ]
        if smoke:  # the workload, untimed
            _workload_in_process(work, top_width_m, depth_m)
        else:
            for step in setup:
                _python(CLI, *step, cwd=work)
        commands: dict[str, tuple[str, ...]] = {
            "replay": ("replay", "run"),
            "compensate": ("compensate", "--method", "twin", "--ideal", "cone.csv", "--out", "cmd.csv"),
            "place": ("place", "--ideal", "cone.csv"),
        }
        inputs = {"replay": "run", "compensate": "cone.csv", "place": "cone.csv"}
        if not smoke:
            for args in commands.values():
                _python(CLI, *args, cwd=work)
        times: dict[str, list[float]] = {f"{k}{s}": [] for k in commands for s in ("_s", "_fixed_s")}
        for _ in range(repeats):
            for key, args in commands.items():
                times[f"{key}_fixed_s"].append(_python(FIXED[key], inputs[key], cwd=work))
                times[f"{key}_s"].append(_python(CLI, *args, cwd=work))
        samples = sum(1 for _ in (work / "cone.csv").open()) - 1
    med = {key: statistics.median(values) for key, values in times.items()}
    replay_work = med["replay_s"] - med["replay_fixed_s"]
    return {
        "cli": {"samples": samples, "rounds": repeats, **med,
                "commands": {key: "tx200-twin " + " ".join(args) for key, args in commands.items()}},
        "cli_compensate_over_replay": (med["compensate_s"] - med["compensate_fixed_s"]) / replay_work,
        "cli_place_over_replay": (med["place_s"] - med["place_fixed_s"]) / replay_work,
    }
