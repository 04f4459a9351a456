"""Viz: figures (matplotlib) and rerun recordings of runs and replays.

Takes runs and analysis results; gives PNG files and `.rrd` recordings.
"""
