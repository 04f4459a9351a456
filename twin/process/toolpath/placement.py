"""Placement of the sheet in the robot base and the reachability check of a whole tool path.

A path lives in the sheet frame; the placement puts that frame in the robot base frame: origin `origin_base_m`
(default: the cell's `sheet_origin` site, the tool tip at the machining pose of thesis Table 4.1) and a yaw
about the base z axis (the sheet stays horizontal; the tool stays vertical, `Kinematics.R_tool_down`):

    p_base = origin_base + Rz(yaw) · p_sheet.

`check_reach` solves the inverse kinematics along the whole path (warm-started, `Kinematics.ik_path`) and
raises on the first sample that is out of reach, outside a joint range or closer to a singularity than
`Kinematics.det_j_min`, naming the sample, its time and its sheet-frame position. The twin
(`twin.sim.spec.TwinSpec.placement`) and the labs take a placement too; a run records it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from twin.errors import DataFileError, InputError, SingularityError, UnreachableError
from twin.process.toolpath.groove import ToolPath

if TYPE_CHECKING:  # MuJoCo loads only when a placement is checked
    from twin.robot.kinematics import Kinematics


@dataclass(frozen=True)
class Placement:
    """The sheet frame in the robot base frame.

    Attributes:
        origin_base_m: Sheet-frame origin in the base frame (3,) [m]; None for the cell's `sheet_origin`.
        yaw_rad: Rotation of the sheet frame about the base z axis [rad].
    """

    origin_base_m: tuple[float, float, float] | None = None
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        if self.origin_base_m is not None:
            o = np.asarray(self.origin_base_m, dtype=float)
            if o.shape != (3,) or not np.all(np.isfinite(o)):
                raise InputError(f"Placement.origin_base_m = {self.origin_base_m!r}: expected 3 finite coordinates [m]")
        if not math.isfinite(self.yaw_rad):
            raise InputError(f"Placement.yaw_rad = {self.yaw_rad!r}: expected a finite angle [rad]")

    @property
    def R_base_sheet(self) -> np.ndarray:
        """Orientation of the sheet frame in the base frame, Rz(yaw) (3, 3)."""
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def origin_in(self, kinematics: Kinematics) -> np.ndarray:
        """The sheet origin in the base frame (3,) [m]: `origin_base_m`, else the cell's `sheet_origin`."""
        if self.origin_base_m is None:
            return np.asarray(kinematics.p_base_sheet_origin, dtype=float).copy()
        return np.asarray(self.origin_base_m, dtype=float)

    @property
    def is_default(self) -> bool:
        """The cell's own placement: its `sheet_origin`, yaw 0."""
        return self.origin_base_m is None and self.yaw_rad == 0.0

    def to_base(self, p_sheet_m: np.ndarray, kinematics: Kinematics) -> np.ndarray:
        """Sheet-frame points (n, 3) [m] -> base-frame points (n, 3) [m]."""
        return self.origin_in(kinematics) + np.asarray(p_sheet_m, dtype=float) @ self.R_base_sheet.T

    def to_json(self) -> dict[str, Any]:
        """As files record it (a run's `meta.json`, a model file): the origin [mm] (null: the cell's), yaw [deg]."""
        origin = None if self.origin_base_m is None else [1e3 * float(v) for v in self.origin_base_m]
        return {"origin_base_mm": origin, "yaw_deg": math.degrees(self.yaw_rad)}

    @classmethod
    def from_json(cls, entry: Any, source: str | Path) -> Placement:
        """The placement a file records (`to_json`); None: the cell's, yaw 0.

        Raises:
            DataFileError: The entry is not {"origin_base_mm": null or 3 numbers, "yaw_deg": a number} (names
                `source`).
        """
        if entry is None:
            return cls()
        expected = 'expected "placement": {"origin_base_mm": null or [x, y, z], "yaw_deg": number}'
        if not isinstance(entry, Mapping) or set(entry) - {"origin_base_mm", "yaw_deg"}:
            raise DataFileError(source, f"placement = {entry!r}: {expected}")
        origin, yaw = entry.get("origin_base_mm"), entry.get("yaw_deg", 0.0)
        ok_origin = origin is None or (
            isinstance(origin, list | tuple) and len(origin) == 3
            and all(isinstance(v, int | float) and math.isfinite(v) for v in origin)
        )
        if not ok_origin or not isinstance(yaw, int | float) or not math.isfinite(yaw):
            raise DataFileError(source, f"placement = {entry!r}: {expected}")
        base = None if origin is None else (origin[0] / 1e3, origin[1] / 1e3, origin[2] / 1e3)
        return cls(origin_base_m=base, yaw_rad=math.radians(yaw))


@dataclass(frozen=True)
class ReachReport:
    """Joint solutions along a path and their margins.

    Attributes:
        q_rad: Joint angles at every sample (n, 6) [rad].
        min_abs_det_j: Smallest |det J| along the path [m^3] (distance to singularity).
        min_det_sample: Sample index of that minimum.
        joint_margin_rad: Smallest distance of each joint to its range limits along the path (6,) [rad].
    """

    q_rad: np.ndarray
    min_abs_det_j: float
    min_det_sample: int
    joint_margin_rad: np.ndarray


def check_reach(
    path: ToolPath, placement: Placement | None = None, kinematics: Kinematics | None = None,
    *, q_near: np.ndarray | None = None,
) -> ReachReport:
    """Solve the IK along the whole path and report its margins.

    Args:
        path: Tool-tip path in the sheet frame.
        placement: Sheet placement; None for the default (cell sheet origin, yaw 0).
        kinematics: Robot kinematics; None loads the cell scene.
        q_near: Joint angles near the solution at every sample (n, dof) [rad] to seed the IK (`Kinematics.ik_path`).

    Raises:
        UnreachableError: A sample is out of reach or outside a joint range (names the first such sample).
        SingularityError: A sample's solution has |det J| below `kinematics.det_j_min` (names it).
    """
    from twin.robot.kinematics import Kinematics

    kin = Kinematics() if kinematics is None else kinematics
    P = (placement or Placement()).to_base(path.p_sheet_m, kin)
    try:
        Q = kin.ik_path(P, q_near=q_near)
    except (UnreachableError, SingularityError) as exc:
        raise _first_bad_sample(kin, P, path) from exc
    dets = np.abs(np.linalg.det(kin.jacobians(Q)))
    i_min = int(np.argmin(dets))
    margin = np.minimum(Q - kin.q_min, kin.q_max - Q).min(axis=0)
    return ReachReport(q_rad=Q, min_abs_det_j=float(dets[i_min]), min_det_sample=i_min, joint_margin_rad=margin)


def _first_bad_sample(
    kin: Kinematics, P: np.ndarray, path: ToolPath
) -> UnreachableError | SingularityError:
    """Walk the path point by point (warm-started) and build the error of the first sample that fails."""
    q = kin.q_home.copy()
    for i, p in enumerate(P):
        try:
            q = kin.ik(p, q_seed=q)
        except (UnreachableError, SingularityError) as exc:
            where = (
                f"path sample {i} of {len(P)} (t = {path.t_s[i]:.3f} s, sheet-frame position "
                f"{np.array2string(path.p_sheet_m[i] * 1e3, precision=3)} mm)"
            )
            return type(exc)(f"{where}: {exc}")
    return UnreachableError("inverse kinematics failed along the path but no single sample fails on its own")
