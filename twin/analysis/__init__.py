"""Analysis: what is done with runs, on the twin of a `TwinSpec`.

Modules: `resolve` (the one rule for which twin a task runs: the run's robot and placement, the declared
process, the force model; the tool it simulates in `tool_choice`), `replay` (a run replayed on the twin, with the gap), `identify/` (K_R by Methods 1 and 2, K_q from K_R
or by rollouts), `compensate` (offline compensation, formula or iterated on the twin, and its gain), `anderson` (the
acceleration of that iteration), `off_sheet` (where that iteration leaves the tool off the sheet the ideal path is
in), `compensate_dynamic` (the command iterated on the dynamic twin after it), `next_part` (the next part's
command from the last part's measured forces),
`part_compensation` (the formed part to the design, springback included), `scan_learning` (the next part's
command learned from the last part's scan, at the points each sample formed),
`compensation_record` (what a compensation used, carried with its command into its runs), `check` (the check of a
compensated run), `tracker_frame` (the tracker's registration to the sheet, fitted on a run's free moves and taken
off before `check` judges), `gain_cause` (a gain's cause, from that record and the measured forces), `surface_check` (a part
scan against its target or design mesh, by region; its vertical rays onto the design in `design_rays`),
`scan_registration` (a scanner's point cloud laid on its design by ICP), `placement_search` (where to put the
sheet for the least predicted error of a part) with its screen and confirmation in `placement_screen`, `learn/` (a twin of a cell it
did not build: its robot and sheet learned from the cell's nominal runs), `discrepancy/` (find,
name, add and shrink what the twin is missing) and `calibration/` (the twin's free parameters fitted to the
thesis's measurements). The analysis never imports a lab: what the twin knows lives in the twin's stages.

Takes runs and a twin; gives stiffnesses, compensated paths, gains, verdicts and augmented models.
"""

from twin.base.lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "PlacementSearch": "twin.analysis.placement_search",
    "SearchBox": "twin.analysis.placement_search",
    "search_placement": "twin.analysis.placement_search",
    "LearnResult": "twin.analysis.learn",
    "learn": "twin.analysis.learn",
    "split_gap": "twin.analysis.learn.split",
    "ReplayResult": "twin.analysis.replay",
    "replay": "twin.analysis.replay",
    "replay_metrics": "twin.analysis.replay",
    "Compensation": "twin.analysis.compensate",
    "compensate_formula": "twin.analysis.compensate",
    "compensate_twin": "twin.analysis.compensate",
    "compensation_gain": "twin.analysis.compensate",
    "compliance_from_stiffness": "twin.analysis.compensate",
    "gain_of": "twin.analysis.compensate",
    "CheckResult": "twin.analysis.check",
    "check_run": "twin.analysis.check",
    "diagnose_gain": "twin.analysis.check",
    "CompensationRecord": "twin.analysis.compensation_record",
    "GainCause": "twin.analysis.gain_cause",
    "name_cause": "twin.analysis.gain_cause",
    "SurfaceDeviation": "twin.analysis.surface_check",
    "read_target_mesh": "twin.analysis.surface_check",
    "surface_deviation": "twin.analysis.surface_check",
    "DesignIndex": "twin.analysis.surface_check",
    "RegionDeviation": "twin.analysis.surface_check",
    "region_deviation": "twin.analysis.surface_check",
    "ScanRegistration": "twin.analysis.scan_registration",
    "register_scan": "twin.analysis.scan_registration",
    "KrFit": "twin.analysis.identify.cartesian",
    "fit_kr_load_cases": "twin.analysis.identify.cartesian",
    "fit_kr_from_run": "twin.analysis.identify.cartesian",
    "fit_compliance": "twin.analysis.identify.cartesian",
    "load_cases_csv": "twin.analysis.identify.cartesian",
    "KqFit": "twin.analysis.identify.joint",
    "fit_diagonal_kq": "twin.analysis.identify.joint",
    "Method2Result": "twin.analysis.identify.method2",
    "method2": "twin.analysis.identify.method2",
    "KqRolloutFit": "twin.analysis.identify.rollouts",
    "kq_from_run": "twin.analysis.identify.rollouts",
    "kq_from_stiffness": "twin.analysis.identify.rollouts",
    "write_joint_stiffness": "twin.analysis.identify.rollouts",
    "DiscrepancyResult": "twin.analysis.discrepancy.search",
    "find_discrepancy": "twin.analysis.discrepancy.search",
    "result_summary": "twin.analysis.discrepancy.summary",
    "ResidualModel": "twin.analysis.discrepancy.residuals",
    "estimate_noise": "twin.analysis.discrepancy.residuals",
})
