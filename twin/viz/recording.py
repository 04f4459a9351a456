"""Rerun recordings (`.rrd`, headless) of replayed runs: the file, its blueprint (one tab per run) and the runs.

Each run's entities (robot, paths, deflection, forces, groove, plots, README) are logged by
`twin.viz.recording_layers.log_replay`, under the prefix `<name>/` when several runs share a file.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from twin.errors import InputError, ModelError
from twin.process.toolpath.placement import Placement
from twin.robot.description import load_robot
from twin.robot.model import build_model
from twin.viz.recording_layers import checked_points, log_replay
from twin.viz.rrd_file import save_recording

if TYPE_CHECKING:
    from twin.analysis.replay import ReplayResult
    from twin.runs.format import Run

_NAME = re.compile(r"^[A-Za-z0-9_\-]+$")


def _blueprint(prefixes: Sequence[str]) -> rrb.Blueprint:
    tabs = []
    for prefix in prefixes:
        plots = [
            rrb.TimeSeriesView(origin=f"/{prefix}plots/{name}", name=name)
            for name in (*(f"deflection_{axis}_mm" for axis in "xyz"), *(f"force_{axis}_n" for axis in "xyz"))
        ]
        tabs.append(
            rrb.Horizontal(
                rrb.Vertical(
                    rrb.Spatial3DView(origin=f"/{prefix}world", name="cell"),
                    rrb.TextDocumentView(origin=f"/{prefix}README", name="notes"),
                    row_shares=[4, 1],
                ),
                rrb.Vertical(*plots),
                column_shares=[3, 2],
                name=prefix.rstrip("/") or "replay",
            )
        )
    return rrb.Blueprint(rrb.Tabs(*tabs), collapse_panels=True)


def _sheet_origin(model: mujoco.MjModel) -> np.ndarray:
    name = load_robot().sheet_site or ""
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
    if site < 0:
        raise ModelError(f"the model has no sheet site {name!r}; pass p_base_sheet_origin")
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return data.site_xpos[site].copy()


def _checked_names(items: Sequence[tuple[str, Run, ReplayResult]]) -> list[str]:
    """The run names of `items`: at least one, unique, letters/digits/`_`/`-` (or a single ""); InputError."""
    if not items:
        raise InputError("items is empty; expected at least one (name, run, replay)")
    names = [name for name, _, _ in items]
    valid = [bool(_NAME.match(n)) or (n == "" and len(items) == 1) for n in names]
    if len(set(names)) != len(names) or not all(valid):
        raise InputError(
            f"run names must be unique and match [A-Za-z0-9_-]+ (or one unnamed run), got {names}"
        )
    return names


def _checked_origin(
    model: mujoco.MjModel, p_base_sheet_origin: np.ndarray | None, placement: Placement | None
) -> np.ndarray:
    """The sheet origin in the base frame [m], shape (3,): as given, else the placement's, else the model's site.

    Raises:
        InputError: Not 3 finite values.
    """
    if p_base_sheet_origin is None and placement is not None and placement.origin_base_m is not None:
        p_base_sheet_origin = np.asarray(placement.origin_base_m, dtype=float)
    if p_base_sheet_origin is None:
        origin = _sheet_origin(model)
    else:
        origin = np.asarray(p_base_sheet_origin, dtype=float)
    if origin.shape != (3,) or not np.all(np.isfinite(origin)):
        raise InputError(f"p_base_sheet_origin must be 3 finite values [m], got {origin!r}")
    return origin


def record_runs(
    path: str | Path,
    items: Sequence[tuple[str, Run, ReplayResult]],
    *,
    ideal_sheet_m: np.ndarray | None = None,
    twin_model: mujoco.MjModel | None = None,
    p_base_sheet_origin: np.ndarray | None = None,
    application_id: str = "tx200-twin",
    placement: Placement | None = None,
) -> Path:
    """Record several replayed runs into one `.rrd`, each under its own prefix `<name>/` (one tab each).

    Args:
        path: The `.rrd` file to write (atomically: temporary sibling, then renamed).
        items: (name, run, replay) triples; names are unique, letters/digits/`_`/`-`; a single item may
            have the name "" (no prefix).
        ideal_sheet_m: Ideal (FE) tool-tip path, sheet frame [m], shape (k, 3), drawn for every run.
        twin_model: The twin's compiled model (`Twin.model`); default `twin.robot.model.build_model()`.
        p_base_sheet_origin: Sheet origin in the base frame [m]; default the placement's, else the model's
            sheet site (`RobotDescription.sheet_site`).
        application_id: Rerun application id.
        placement: Where the sheet was (`Twin.placement`): its origin (unless `p_base_sheet_origin` is given) and
            yaw; default the cell's.

    Returns:
        The path written.

    Raises:
        InputError: Bad names, shapes that do not match the run, or a model whose nq differs from
            the replay's.
    """
    names = _checked_names(items)
    if twin_model is None:
        twin_model = build_model()
    R_base_sheet = None if placement is None else placement.R_base_sheet
    origin = _checked_origin(twin_model, p_base_sheet_origin, placement)
    ideal = None if ideal_sheet_m is None else checked_points("ideal_sheet_m", ideal_sheet_m)
    prefixes = [f"{name}/" if name else "" for name in names]

    def log(rec: rr.RecordingStream) -> None:
        for prefix, (_, run, replay) in zip(prefixes, items, strict=True):
            log_replay(rec, prefix, run, replay, ideal, twin_model, origin, R_base_sheet)

    return save_recording(path, _blueprint(prefixes), log, application_id=application_id)


def record_replay(
    path: str | Path,
    run: Run,
    replay_result: ReplayResult,
    *,
    ideal_sheet_m: np.ndarray | None = None,
    twin_model: mujoco.MjModel | None = None,
    p_base_sheet_origin: np.ndarray | None = None,
    application_id: str = "tx200-twin",
    placement: Placement | None = None,
) -> Path:
    """Record one replayed run into a `.rrd` (entities without prefix: `world/...`, `plots/...`, `README`).

    Args:
        path: The `.rrd` file to write (atomically).
        run: The measured run (sheet frame, SI).
        replay_result: Its replay on the twin (`twin.analysis.replay.replay`).
        ideal_sheet_m: Ideal (FE) tool-tip path, sheet frame [m], shape (k, 3).
        twin_model: The twin's compiled model (`Twin.model`); default `twin.robot.model.build_model()`.
        p_base_sheet_origin: Sheet origin in the base frame [m]; default the placement's, else the model's
            sheet site (`RobotDescription.sheet_site`).
        application_id: Rerun application id.
        placement: Where the sheet was (`Twin.placement`): its origin (unless `p_base_sheet_origin` is given) and
            yaw; default the cell's.

    Returns:
        The path written.
    """
    return record_runs(
        path,
        [("", run, replay_result)],
        ideal_sheet_m=ideal_sheet_m,
        twin_model=twin_model,
        p_base_sheet_origin=p_base_sheet_origin,
        application_id=application_id,
        placement=placement,
    )
