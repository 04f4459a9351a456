"""Base: utilities every stage uses.

Modules: `csvio` (atomic CSV and text I/O with precise errors), `jsonio` (strict JSON documents, `--json`), `outputs` (outputs never over inputs, the umask's
modes, write failures named), `units` (length columns read by their declared unit,
`_mm` or `_m`), `signals` (interpolation of sampled signals, sample clocks), `resources` (the lookup of shipped
models and data), `lazy` (a package's public names, imported on first use), `registry` (the one kind of registry of
every extension point) and `jobs` (independent jobs on this
process, every core, or a Dask cluster).

Takes files and arrays; gives validated arrays and paths. Imports nothing of the project but `twin.errors`.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "read_table": "twin.base.csvio",
    "read_json": "twin.base.jsonio",
    "write_table": "twin.base.csvio",
    "write_json": "twin.base.jsonio",
    "write_text": "twin.base.csvio",
    "emit_json": "twin.base.jsonio",
    "read_si_table": "twin.base.units",
    "interp_rows": "twin.base.signals",
    "uniform_times": "twin.base.signals",
    "models_dir": "twin.base.resources",
    "data_file": "twin.base.resources",
    "Jobs": "twin.base.jobs",
})
