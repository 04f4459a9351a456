"""Apps: the end-to-end jobs built from the stages.

Modules: `demo` (the thesis story) and its `report`, `reproduction` (the thesis-vs-twin table), `force_validation`
(the force model against the published measurements of `force_data`, and the springback against a published part's
section, `springback_validation`), `springback_scans` and `springback_page` (the formed part's springback against 32
scanned cones), `bench`, `bench_speed`, `bench_place` (the placement search's cost), `bench_cli` (`compensate` and
`place` over `replay`, fresh CLI processes), `bench_suite` (the test suite's own time), `bench_online` (the online
compensator's real-time figures), `warm` (the compiled kernels into numba's cache before a suite's processes
start) and `machine` (the speed ratios and the machine they ran on), `analytic_replay` (the replay with the linear
model, the physical floor), `sweep` (a Monte Carlo of the compensated groove) with its `uncertainty` and
`sweep_figure`, `readme` (the README's generated tables), `export/` (robot programs from a path), `online/` (the
online compensator behind a robot's real-time interface) and `tasks/` (each command as a typed request and report,
callable from Python).

Takes an output folder; gives reports, figures, recordings, programs and benchmark ratios.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "run_demo": "twin.apps.demo",
    "run_benchmarks": "twin.apps.bench",
    "analytic_replay": "twin.apps.analytic_replay",
    "run_sweep": "twin.apps.sweep",
    "validate_forces": "twin.apps.force_validation",
    "export_path": "twin.apps.export",
})
