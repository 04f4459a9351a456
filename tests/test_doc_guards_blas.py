"""The doc guards hold under another floating-point set-up than the suite's own.

Machines of our kind differ in their BLAS kernel (`OPENBLAS_CORETYPE` is set on some) and in its threads; a documented
number that moves in its third digit between them must not fail a test. The suite runs with the machine's own kernel and
one BLAS thread per process (tests/conftest.py: a worker per core); this test runs the guards of the generated pages
(the force-validation page, whose springback number once failed on another machine, the robots page, a plant number: the
rigid groove's, the cheapest) again in a child process with the machine's thread count (at least 2), an older kernel
(x86: Prescott, SSE3; arm: ARMV8) and numpy's own SIMD kernels held to its baseline (`NPY_DISABLE_CPU_FEATURES`:
every dispatched feature this machine has; a sort's order of ties once moved the springback number by 0.13 mm between
machines), so every `make test` checks them under two set-ups (the tolerances: `tests/doc_numbers.py`).
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parent
GUARDS = (
    "test_doc_numbers.py",
    "test_force_validation.py::test_the_page_is_the_one_a_fresh_run_writes",
    "test_force_validation.py::test_the_springback_section_stands_beside_the_published_one",
    "test_robots.py::test_the_robots_page_is_the_one_a_fresh_run_writes",
    "test_plant_sheet.py::test_the_groove_force_builds_up_with_depth_to_the_documented_peak",
)


def _other_kernel() -> str:
    return "ARMV8" if platform.machine().lower() in ("aarch64", "arm64") else "Prescott"


def _numpy_simd_off() -> str:
    """The numpy SIMD features this machine dispatches to, to be disabled (naming one it lacks would warn)."""
    from numpy._core import _multiarray_umath as umath

    return " ".join(f for f in umath.__cpu_dispatch__ if umath.__cpu_features__.get(f))


def test_the_doc_guards_pass_with_other_blas_threads_and_another_kernel(tmp_path: Path) -> None:
    threads = str(max(2, os.cpu_count() or 1))  # the suite's own processes run one (tests/conftest.py)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": threads, "OPENBLAS_CORETYPE": _other_kernel(),
           "NPY_DISABLE_CPU_FEATURES": _numpy_simd_off(), "PYTHONDONTWRITEBYTECODE": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly", "-n", "0",
         "--basetemp", str(tmp_path / "t"), *(str(TESTS / g) for g in GUARDS)],
        cwd=TESTS.parent, env=env, capture_output=True, text=True, timeout=600, check=False,
    )
    set_up = f"{env['OPENBLAS_CORETYPE']}, {threads} threads, numpy SIMD off ({env['NPY_DISABLE_CPU_FEATURES']!r})"
    assert done.returncode == 0, f"doc guards under {set_up}:\n{done.stdout[-3000:]}"
    assert " passed" in done.stdout.splitlines()[-1] and "failed" not in done.stdout.splitlines()[-1]
