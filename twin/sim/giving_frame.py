"""A clamping frame that gives: the sheet's force field on a support that yields along the sheet's normal.

An ISF rig clamps the blank in a frame (a blank holder on columns or aluminium profiles). Pressed by the tool's
axial force F_z, the frame and the blank in it move down by c F_z, c the frame's compliance along the sheet's normal
[m/N] (the `frame_compliance` effect, in mm/kN). The sheet's own law is unchanged in the frame's coordinates, so
the frame is a spring in series with the sheet:

* the force at a tool tip p (sheet frame, the frame at rest) is f(p + delta e_z), delta = c f_z(p + delta e_z):
  the tip sits delta higher against the yielded sheet. Solved by Newton on the scalar delta (g'(delta) = 1 -
  c S_zz >= 1 while pressing deeper pushes back, S_zz = df_z/dz <= 0);
* its gradient: dF/dp = S + S e_z (d delta/dp)^T, d delta/dp = c S[2, :] / (1 - c S_zz);
* the surface formed is the sheet's, in the frame's coordinates: after unclamping the frame is back at rest, so a
  profile scan sees it as formed, while a tracker sees the tool tip where the yielded frame let it go.

A frame in series with the sheet acts like a robot softer along the sheet's normal for the force and the formed
depth, but not for the tracker (the tip really goes down with the frame). Lacking a published stiffness of an ISF
frame, the effect's range (0-5 mm/kN) is a choice: a stiff welded frame gives well under 0.1 mm at the 2 kN of
this cell; a frame of aluminium profiles, tenths of a millimetre.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from twin.process.force.base import FieldState, FieldWrapper, ForceField
from twin.sim.effects import Effects

#: Newton on the frame's give: at most this many steps, stopping below TOLERANCE_M.
ITERATIONS = 30
TOLERANCE_M = 1e-10


class GivingFrame(FieldWrapper):
    """A sheet force field on a frame that yields by c f_z along the sheet's normal (module docstring).

    Args:
        field: The sheet's own field (in the frame's coordinates).
        compliance_m_per_n: The frame's compliance c along the sheet's normal [m/N] (> 0).

    Its formed surface (in the frame's coordinates), tool radius, unloading stiffness and declared traits are the
    wrapped field's; the compiled loop solves it in its kernel (`twin.sim.compiled.sheet`).
    """

    def __init__(self, field: ForceField, compliance_m_per_n: float) -> None:
        if not (np.isfinite(compliance_m_per_n) and compliance_m_per_n > 0.0):
            raise ValueError(f"frame compliance {compliance_m_per_n!r} m/N: expected a finite value > 0")
        self.inner = field
        self.compliance = float(compliance_m_per_n)
        self.radius, self.k_unload = field.radius, field.k_unload
        self.tangential_from_command = field.tangential_from_command  # type: ignore[misc]
        self.steps_between_passes = field.steps_between_passes  # type: ignore[misc]
        self.extrapolated_start = field.extrapolated_start  # type: ignore[misc]

    def __getattr__(self, name: str) -> Any:
        """The wrapped field's attributes (its constants, `params`, `map`), read through the frame."""
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    def give(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> tuple[float, np.ndarray, np.ndarray]:
        """The frame's give delta [m] at tip `p_sheet_m`, and the sheet's force [N] and gradient [N/m] there; pure
        (Newton from delta = 0, as the compiled kernel)."""
        c, delta = self.compliance, 0.0
        shifted = np.array(p_sheet_m, dtype=float)
        z0 = shifted[2]
        for _ in range(ITERATIONS):
            shifted[2] = z0 + delta
            f, s = self.inner.force_and_stiffness(shifted, pass_index, direction)
            step = (delta - c * f[2]) / (1.0 - c * min(s[2, 2], 0.0))
            delta -= step
            if abs(step) < TOLERANCE_M:
                break
        shifted[2] = z0 + delta
        f, s = self.inner.force_and_stiffness(shifted, pass_index, direction)
        return delta, f, s

    def force(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        """The sheet's force on the tool with the frame given [N], (3,); pure."""
        return self.give(p_sheet_m, pass_index, direction)[1]

    def force_and_stiffness(
        self, p_sheet_m: np.ndarray, pass_index: int, direction: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """`force` [N] and its gradient through the frame's give [N/m] (module docstring); pure."""
        _, f, s = self.give(p_sheet_m, pass_index, direction)
        d_delta = self.compliance * s[2, :] / (1.0 - self.compliance * min(s[2, 2], 0.0))
        return f, s + np.outer(s[:, 2], d_delta)

    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None) -> None:
        """Commit the tip: the sheet formed where the tip met the yielded frame."""
        delta, _, _ = self.give(p_sheet_m, 1 if pass_index is None else pass_index, 1)
        shifted = np.array(p_sheet_m, dtype=float)
        shifted[2] += delta
        self.inner.advance(shifted, pass_index)

    def reset(self) -> None:
        """The wrapped field's reset."""
        self.inner.reset()

    @property
    def state(self) -> FieldState:
        """The wrapped field's state."""
        return self.inner.state

    def restore(self, state: FieldState) -> None:
        """Set the wrapped field's state."""
        self.inner.restore(state)


def frame_compliance_m_per_n(effects: Effects) -> float:
    """The effects' `frame_compliance` [mm/kN] in SI [m/N] (0: a rigid frame)."""
    return 1e-6 * effects.get("frame_compliance")


def with_frame(field: ForceField, effects: Effects) -> ForceField:
    """`field` on a frame that gives by the effects' `frame_compliance`; the field itself when it is 0."""
    c = frame_compliance_m_per_n(effects)
    return GivingFrame(field, c) if c > 0.0 else field
