"""Viz: figures (matplotlib: `path_figures`, `deflection_figures`, `stiffness_figures` on a shared `style`) and
rerun recordings of runs and replays (`recording`, with the layers of one replay in `recording_layers` and the
robot in `recording_robot`).

Takes runs and analysis results; gives PNG files and `.rrd` recordings.
"""
