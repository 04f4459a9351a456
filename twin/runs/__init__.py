"""Runs: the run format `tx200-twin-run/1`, the seam between a lab (virtual or real) and everything after it.

Modules: `format` (the format, `Stream`, `Run`, `meta.json`), `read` (reading and validation), `write` (atomic
writing, never over an input), and the importers of real data: `mapping` (an import mapping file, read with
`toml_keys`; its tracker frame in `mapping_frame`), `raw_tables` (vendor exports), `clock` (clock alignment), `registration` (tracker frame to sheet
frame), `gravity` (tool weight removal), `importer` (the import itself), `scan_file` (a scanner's point cloud
of the formed part: PLY, XYZ, CSV) and `contact` (whether a run's F/T stream saw any forming).

Takes run directories and raw cell exports; gives validated `Run` objects.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "Run": "twin.runs.format",
    "Stream": "twin.runs.format",
    "run_meta": "twin.runs.format",
    "run_placement": "twin.runs.format",
    "run_process": "twin.runs.format",
    "read_run": "twin.runs.read",
    "read_commanded_csv": "twin.runs.read",
    "write_run": "twin.runs.write",
    "ImportMapping": "twin.runs.mapping",
    "load_mapping": "twin.runs.mapping",
    "ImportResult": "twin.runs.importer",
    "import_run": "twin.runs.importer",
    "import_to_directory": "twin.runs.importer",
    "read_scan": "twin.runs.scan_file",
    "MappingError": "twin.runs.toml_keys",
    "ClockError": "twin.runs.toml_keys",
    "RegistrationError": "twin.runs.toml_keys",
})
