"""Runs: the run format `tx200-twin-run/1` — the seam between a lab (virtual or real) and everything after it.

Takes run directories (commanded path, tracker, forces, optional profile); gives validated `Run` objects
(`format`: the format, `Stream`, `Run`; `read`: reading and validation), and writes them atomically without
ever overwriting an input (`write`).
"""
