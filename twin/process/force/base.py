"""The force-model seam: what a model of the sheet's force on the tool gives the twin, the labs and the analysis.

A force field is the sheet's reaction at any tool position, with the forming state it keeps (what earlier passes
formed). Every force model is a `ForceField`; the registry (`twin.process.force.registry`) builds one by name from
an FE force history and the declared process. The twin's Newton solve asks `force_and_stiffness` at trial tool
positions (pure), commits each equilibrium with `advance`, and starts a run with `reset`.

What a model declares (class attributes), so that no stage looks at its type:

* `compiled_kernel`: the name of the compiled kernel that mirrors it in the twin's replay loop
  (`twin.sim.compiled`: `table`, `isf`), or None (the twin's Python loop, MuJoCo per Newton iteration). It is
  not inherited (`kernel()`): a subclass may change the physics, so it runs in Python unless it declares the
  kernel again;
* `tangential_from_command`: its in-plane force flips with the commanded travel direction, so the twin wraps
  it in the tool's sliding friction (`twin.process.force.tool_friction`), which makes the force follow the tool's
  real travel at reversals;
* `steps_between_passes`: its force steps from one pass to the next (per-pass tables): streams are not
  interpolated across a pass change (`twin.sim.result.SimResult.force_at`);
* `extrapolated_start`: the twin's Newton solve may start every joint, the frictional ones too, from the
  deflection extrapolated along the pass instead of holding the frictional links where they were
  (`twin.sim.equilibrium.EquilibriumSolver.solve`): about half the iterations, declared by a model whose
  equilibria that start reaches (`tests/test_speed_equilibrium.py`); the groove's table field does not (near
  its end walls that start lands on another equilibrium branch).

Its scalar forming state is a typed record (`FieldState` subclasses), read with `state` and set with `restore`
by a loop that advanced the model itself (the compiled replay).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from twin.process.toolpath.groove import ToolPath

if TYPE_CHECKING:
    from twin.process.part.heightmap import HeightMap


@dataclass(frozen=True)
class FieldState:
    """The scalar forming state of a force model (none for a model that keeps none); models subclass it."""


class ForceField(ABC):
    """Force of the sheet on the tool as a function of the tool position and what was formed before.

    Attributes:
        radius: Tool radius [m].
        k_unload: Elastic unloading stiffness of the formed sheet [N/m] (its springback after unclamping).
    """

    compiled_kernel: ClassVar[str | None] = None
    tangential_from_command: ClassVar[bool] = False
    steps_between_passes: ClassVar[bool] = False
    extrapolated_start: ClassVar[bool] = False
    radius: float
    k_unload: float

    @classmethod
    def kernel(cls) -> str | None:
        """The compiled kernel this very class declares (`compiled_kernel` of its own body; None for a subclass
        that does not declare one again)."""
        value = vars(cls).get("compiled_kernel")
        return value if isinstance(value, str) else None

    @abstractmethod
    def reset(self) -> None:
        """Back to a flat, unformed sheet."""

    @abstractmethod
    def force(self, p_sheet_m: np.ndarray, pass_index: int, direction: int) -> np.ndarray:
        """Force of the sheet on the tool [N], (3,), sheet frame; pure (the state is not changed).

        Args:
            p_sheet_m: Tool-tip position in the sheet frame [m], shape (3,).
            pass_index: Pass 1..N of the path the tool is in (models that need no pass labels ignore it).
            direction: Commanded travel direction along x, +1 or -1 (ignored by models that track the travel).
        """

    @abstractmethod
    def force_and_stiffness(
        self, p_sheet_m: np.ndarray, pass_index: int, direction: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """`force` [N] (3,) and its gradient ∂f/∂p [N/m] (3, 3) in one evaluation; pure."""

    @abstractmethod
    def advance(self, p_sheet_m: np.ndarray, pass_index: int | None = None) -> None:
        """Commit: the tool tip passed through `p_sheet_m` [m]; the formed surface under the tool is updated."""

    @property
    @abstractmethod
    def x_grid_m(self) -> np.ndarray:
        """Abscissae of `formed_z_m` [m]."""

    @property
    @abstractmethod
    def formed_z_m(self) -> np.ndarray:
        """Loaded formed surface along the section y = 0 [m] (a copy)."""

    @property
    def height_map(self) -> HeightMap | None:
        """The 2-D formed surface, for models that keep one (`twin.process.part.heightmap`); None otherwise."""
        return None

    @property
    def state(self) -> FieldState:
        """The model's scalar forming state (a typed record of its own)."""
        return FieldState()

    def restore(self, state: FieldState) -> None:
        """Set the scalar forming state (after a loop that advanced the model itself)."""
        del state

    def rigid_forces(self, path: ToolPath) -> np.ndarray:
        """Reset, then drive the field along `path` with a rigid robot: force at each sample, then advance.

        Args:
            path: Path with pass labels.

        Returns:
            Forces exerted by the sheet on the tool [N], shape (n, 3).
        """
        self.reset()
        out = np.empty((len(path), 3))
        passes = [int(v) for v in path.pass_index]
        dirs = [int(v) for v in path.direction]
        for i, p in enumerate(path.p_sheet_m):
            out[i] = self.force(p, passes[i], dirs[i])
            self.advance(p, passes[i])
        return out


class FieldWrapper(ForceField):
    """A force field around another one, `inner` (the tool's sliding friction, a clamping frame that gives): its
    profile, formed surface and height map are the inner field's."""

    inner: ForceField

    @property
    def x_grid_m(self) -> np.ndarray:
        """The wrapped field's profile abscissae [m]."""
        return self.inner.x_grid_m

    @property
    def formed_z_m(self) -> np.ndarray:
        """The wrapped field's formed profile [m]."""
        return self.inner.formed_z_m

    @property
    def height_map(self) -> HeightMap | None:
        """The wrapped field's height map, if any."""
        return self.inner.height_map
