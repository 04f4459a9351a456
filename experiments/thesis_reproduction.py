"""Reproduce the thesis's experiment on the twin, step by step (the same code `make demo` runs).

Run:  .venv/bin/python experiments/thesis_reproduction.py [OUT_DIR]

Read `twin/apps/demo.py` for the stages; each is a call into the public API (`run_lab`, `replay`,
`fit_kr_load_cases`, `method2`, `compensate_formula`, `check_run`, `find_discrepancy`, `compensate_twin`).
Copy it and change the hidden effects, seeds or the FE history to try another study.
"""

import sys

from twin.apps.demo import run_demo

if __name__ == "__main__":
    run_demo(sys.argv[1] if len(sys.argv) > 1 else "out/thesis_reproduction")
