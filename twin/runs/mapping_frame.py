"""An import mapping's tracker frame (`[tracker.frame]`): the tracker-to-sheet transform, given or fitted to
reference points, each problem named by its key (`twin.runs.mapping`)."""

from __future__ import annotations

import numpy as np

from twin.errors import InputError
from twin.runs.registration import Registration, fit_rigid, given_transform
from twin.runs.toml_keys import RegistrationError, TomlReader

#: Length units of the frame's translation and points (as `twin.runs.mapping.LENGTH_UNITS`).
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "µm": 1e-6, "um": 1e-6}


def rotation(reader: TomlReader, dotted: str, R: np.ndarray) -> np.ndarray:
    """The 3x3 matrix at `dotted`, refused unless a proper rotation."""
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise reader.error(
            dotted, f"is not a proper rotation (R^T R = I, det = +1 within 1e-6): {R.tolist()}"
        )
    return R


def registration(r: TomlReader) -> Registration:
    """The tracker-to-sheet transform: `tracker.frame.T_sheet_tracker`, or fitted to reference points."""
    length = r.unit("tracker.frame.unit", LENGTH_UNITS, "mm")
    T = r.matrix("tracker.frame.T_sheet_tracker", (4, 4), None)
    p_sheet = r.matrix("tracker.frame.points_sheet", None, None)
    p_tracker = r.matrix("tracker.frame.points_tracker", None, None)
    if T is not None:
        if p_sheet is not None or p_tracker is not None:
            raise r.error("tracker.frame.T_sheet_tracker", "give either T_sheet_tracker or reference points")
        T = T.copy()
        T[:3, 3] *= length
        try:
            return given_transform(T)
        except InputError as exc:
            raise r.error("tracker.frame.T_sheet_tracker", str(exc), RegistrationError) from None
    if p_sheet is None or p_tracker is None:
        raise r.error(
            "tracker.frame.points_sheet",
            "the tracker frame needs T_sheet_tracker (4x4) or points_sheet and points_tracker (>= 3 each)",
            RegistrationError,
        )
    if p_sheet.shape != p_tracker.shape:
        raise r.error(
            "tracker.frame.points_tracker",
            f"has {len(p_tracker)} points, points_sheet has {len(p_sheet)}: expected the same points",
            RegistrationError,
        )
    if len(p_sheet) < 3:
        raise r.error(
            "tracker.frame.points_sheet",
            f"has {len(p_sheet)} reference point(s), expected at least 3 (not collinear)",
            RegistrationError,
        )
    try:
        return fit_rigid(p_tracker * length, p_sheet * length)
    except InputError as exc:
        raise r.error("tracker.frame.points_sheet", str(exc), RegistrationError) from None
