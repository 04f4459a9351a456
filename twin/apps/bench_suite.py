"""The test suite's own time: what every developer waits for at each step (`make bench` records it).

`make test` runs the suite on two workers (pytest-xdist, one test file per worker at a time); its target is 150 s on a
quiet 2-core machine. This module runs its two steps, the warm-up (`twin.apps.warm`) and that very command, in child
processes, parses pytest's closing line and records the wall times, the counts and the machine, so the number sits
beside the speed ratios of `benchmarks/results.json` instead of in a developer's memory.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from twin.apps.machine import machine_info
from twin.errors import InputError

#: The suite command of the Makefile's `test` target (without its interpreter).
SUITE_ARGS = ("-m", "pytest", "-q", "-n", "2", "--dist", "loadfile", "--no-loadscope-reorder", "-p", "no:cacheprovider")
_COUNT = re.compile(r"(\d+) (passed|failed|skipped|xfailed|xpassed|errors?|deselected)")
_SECONDS = re.compile(r" in ([0-9.]+)s")


def parse_summary(line: str) -> dict[str, Any]:
    """The counts and seconds of pytest's closing line (`1172 passed, 1 skipped, 9 xfailed in 126.85s (0:02:06)`).

    Raises:
        InputError: The line is not a pytest summary (names it).
    """
    counts = {kind.rstrip("s") if kind.startswith("error") else kind: int(n) for n, kind in _COUNT.findall(line)}
    seconds = _SECONDS.search(line)
    if not counts or seconds is None:
        raise InputError(f"not a pytest summary line: {line!r}; expected e.g. '12 passed in 3.4s'")
    return {"counts": counts, "pytest_s": float(seconds.group(1))}


def time_suite(root: str | Path) -> dict[str, Any]:
    """Run the suite in `root` as `make test` does, its warm-up first, and time both.

    Returns:
        `warm_s` (`make test`'s first step, `twin.apps.warm`: the compiled kernels into numba's cache), `wall_s`
        (the suite's child process, start-up included), `pytest_s` (pytest's own), the counts, the exit code and the
        machine (`twin.apps.machine.machine_info`).
    """
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    start = time.perf_counter()
    warmed = subprocess.run([sys.executable, "-m", "twin.apps.warm"], cwd=root, capture_output=True, text=True,
                            env=env, check=False)
    warm = time.perf_counter() - start
    if warmed.returncode != 0:
        raise InputError(f"the warm-up in {root} failed (exit {warmed.returncode}): {warmed.stderr[-400:]}")
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *SUITE_ARGS], cwd=root, capture_output=True, text=True, env=env, check=False)
    wall = time.perf_counter() - start
    lines = [line for line in done.stdout.splitlines() if _SECONDS.search(line) and _COUNT.search(line)]
    if not lines:
        raise InputError(f"the suite in {root} printed no pytest summary (exit {done.returncode}): "
                         f"{done.stdout[-400:]}{done.stderr[-400:]}")
    return {"command": "pytest " + " ".join(SUITE_ARGS[2:]), "warm_s": round(warm, 1), "wall_s": round(wall, 1),
            **parse_summary(lines[-1]), "exit_code": done.returncode, "machine": machine_info()}


def main(argv: list[str] | None = None) -> int:
    """`python -m twin.apps.bench_suite OUT.json`: time the suite of the current directory into OUT.json."""
    from twin.base.jsonio import write_json

    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m twin.apps.bench_suite OUT.json", file=sys.stderr)
        return 2
    record = time_suite(Path.cwd())
    write_json(args[0], record)
    print(f"suite: {record['counts']} in {record['wall_s']} s wall on {record['machine']['cpu_affinity']} cores "
          f"-> {args[0]}")
    return 0 if record["exit_code"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
