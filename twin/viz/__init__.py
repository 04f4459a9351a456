"""Viz: figures and rerun recordings of runs and replays.

Modules: `path_figures`, `deflection_figures`, `stiffness_figures` and `surface_figures` (matplotlib PNG on the
shared `style`), `recording` (rerun recordings of runs and replays), with the layers of one replay in
`recording_layers` and the robot in `recording_robot`; `part_recording` (a part's stages on the way to its
design); `rrd_file` (every recording written atomically); `placement_figure` (a placement search's error map).

Takes runs and analysis results; gives PNG files and `.rrd` recordings.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "plot_path_xz": "twin.viz.path_figures",
    "plot_forces": "twin.viz.path_figures",
    "plot_replay": "twin.viz.path_figures",
    "plot_deflection_by_pass": "twin.viz.deflection_figures",
    "plot_residual_before_after": "twin.viz.deflection_figures",
    "plot_stiffness_ellipse": "twin.viz.stiffness_figures",
    "plot_surface_deviation": "twin.viz.surface_figures",
    "plot_part_stages": "twin.viz.surface_figures",
    "record_part": "twin.viz.part_recording",
    "record_runs": "twin.viz.recording",
    "record_replay": "twin.viz.recording",
})
