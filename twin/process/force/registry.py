"""The registry of force models: name -> how to build the `ForceField` from an FE history and the process.

Every stage that needs the sheet's force builds it here, by the name the process declares
(`twin.process.description.Process.force_model`); the CLI's `--force-model` choices, the name recorded in runs
and model files, and the compiled loop's kernel (a capability the model declares, `ForceField.compiled_kernel`)
all come from the model, never from its type. Shipped models:

* `table`: the per-pass field of the groove's FE history (`twin.process.force.table.SheetForceField`): exact along the
  history's own path, for the groove and commands near it;
* `isf`: the height-map ISF model (`twin.process.force.isf.IsfForceField`) at the process's own force level
  (Aerens et al.'s formula for its material, sheet and tool, `twin.process.force.isf_params.params_for`): any part and
  path. The FE history sets no level of its own; a history given beside the process's (scaled by the
  `force_scale` effect, or a reference export read with another symmetry) scales the level by the ratio of the
  two histories' mean Fz. Outside the formula's published range it warns (`twin.errors.ExtrapolationWarning`).

A new model registers itself with `register_force_model` when its module is imported (a test defines one inside
the test). `auto_force_model` picks, for a path, the first registered model that says it applies.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from twin.base.registry import Registry
from twin.errors import ExtrapolationWarning, InputError
from twin.process.description import Process
from twin.process.fe.load import ForceHistory
from twin.process.force.aerens import validity_warnings
from twin.process.force.base import ForceField
from twin.process.force.isf import IsfForceField
from twin.process.force.isf_params import IsfForceParams, params_for
from twin.process.force.learned import (
    ON_PRIOR_KEYS,
    RADIAL_RISE_KEY,
    WEIGHT_KEYS,
    LearnedForceField,
    LearnedWeights,
)
from twin.process.force.span import SPAN_KEYS
from twin.process.force.table import SheetForceField
from twin.process.toolpath.groove import label_passes

#: The table field is a section of the sheet along y = 0 (`twin.process.force.table`): it applies to commands within
#: this distance of that section [m].
TABLE_SECTION_HALF_WIDTH_M = 1e-3
#: ... and within this distance, in x-z, of the history's own samples of the same pass [m] (a compensated
#: groove's command moves by up to about 3.5 mm).
TABLE_PATH_TOLERANCE_M = 5e-3

#: (physical FE history, process) -> the model's field.
Builder = Callable[[ForceHistory, Process], ForceField]
#: (history, process, commanded path (n, 3) [m]) -> whether the model applies to that path.
Applies = Callable[[ForceHistory, Process, np.ndarray], bool]


@dataclass(frozen=True)
class ForceModel:
    """One registered force model.

    Attributes:
        name: Registry key: the `--force-model` choice and the name runs and model files record.
        description: One line, for `--help`.
        build: Builds the field from the (physical) FE history and the process.
        applies: Whether the model suits a commanded path (`auto_force_model`); None: any path.
    """

    name: str
    description: str
    build: Builder
    applies: Applies | None = None


#: The force models, by name (`twin.base.registry.Registry`); "auto" is reserved for the CLI's choice.
FORCE_MODELS: Registry[ForceModel] = Registry("force model", reserved=("auto",))


def register_force_model(model: ForceModel) -> ForceModel:
    """Add `model` to the registry (names are unique)."""
    return FORCE_MODELS.register(model)


def unregister_force_model(name: str) -> None:
    """Remove a registered model (a test's own)."""
    FORCE_MODELS.unregister(name)


def force_model(name: str) -> ForceModel:
    """The registered model `name`.

    Raises:
        InputError: Unknown name (the message lists the registered ones).
    """
    return FORCE_MODELS.get_named(name)


def build_force_field(process: Process, history: ForceHistory | None = None) -> ForceField:
    """The process's force field, fitted to `history` (default: the process's own history).

    Args:
        process: The declared process (its `force_model` names the model).
        history: The physical history to fit to (e.g. scaled by a `force_scale` effect); None: the process's.
    """
    return force_model(process.force_model).build(history or process.force_history(), process)


def auto_force_model(process: Process, p_sheet_m: np.ndarray) -> str:
    """The first registered model that applies to the commanded path (`ForceModel.applies`).

    Args:
        process: The process (its history and tool).
        p_sheet_m: The commanded path, sheet frame [m], shape (n, 3).
    """
    path = np.asarray(p_sheet_m, dtype=float)
    history = process.force_history()
    for model in FORCE_MODELS.values():
        if model.applies is None or model.applies(history, process, path):
            return model.name
    raise InputError(f"no registered force model applies to this path; registered: {sorted(FORCE_MODELS)}")


def follows_history(history: ForceHistory, process: Process, p_sheet_m: np.ndarray) -> bool:
    """Whether a path lies in the table field's domain: no more passes than the history, every sample within
    `TABLE_SECTION_HALF_WIDTH_M` of the section y = 0 and within `TABLE_PATH_TOLERANCE_M` (in x-z) of the
    history's samples of the same pass.

    Args:
        history: The FE history (its path and passes).
        process: The process (unused: the domain is the history's).
        p_sheet_m: The commanded path, sheet frame [m], shape (n, 3).
    """
    from scipy.spatial import cKDTree

    del process
    if len(p_sheet_m) == 0 or float(np.max(np.abs(p_sheet_m[:, 1]))) > TABLE_SECTION_HALF_WIDTH_M:
        return False
    passes, _ = label_passes(p_sheet_m[:, 0])
    history_passes, _ = history.pass_labels()
    if int(passes.max()) > int(history_passes.max()):
        return False
    for k in np.unique(passes):
        own = history.p_sheet_m[history_passes == k][:, [0, 2]]
        distance, _ = cKDTree(own).query(p_sheet_m[passes == k][:, [0, 2]])
        if float(np.max(distance)) > TABLE_PATH_TOLERANCE_M:
            return False
    return True


def _table(history: ForceHistory, process: Process) -> ForceField:
    fit = dict(process.force_fit)
    if set(fit) - {"scale"}:
        raise InputError(f"the table force model takes only 'scale' from Process.force_fit; got {sorted(fit)}")
    if "scale" in fit:
        if not fit["scale"] > 0:
            raise InputError(f"the table force model's scale {fit['scale']!r}: expected a number > 0")
        history = replace(history, f_sheet_n=fit["scale"] * history.f_sheet_n)
    return SheetForceField(history, tool_radius_m=process.tool_radius_m)


def history_ratio(history: ForceHistory, reference: ForceHistory) -> float:
    """Mean Fz of `history` over that of `reference` [-]: 1 for the same history, k for one scaled by k."""
    if history is reference:
        return 1.0
    return float(np.mean(history.f_sheet_n[:, 2]) / np.mean(reference.f_sheet_n[:, 2]))


def in_plane_ratio(history: ForceHistory, reference: ForceHistory) -> float:
    """Mean in-plane force of `history` over that of `reference`, over their Fz ratio [-]: 1 for a history scaled
    alike on every axis, r for one whose in-plane force is scaled r times more (a per-axis `force_scale`)."""
    if history is reference:
        return 1.0
    plane, ref = (float(np.mean(np.linalg.norm(h.f_sheet_n[:, :2], axis=1))) for h in (history, reference))
    r = plane / ref / history_ratio(history, reference) if ref > 0.0 else 1.0
    return 1.0 if abs(r - 1.0) < 1e-9 else r


def _in_plane_scaled(params: IsfForceParams, r: float) -> IsfForceParams:
    """The ISF constants with the in-plane ratios μ_t, μ_r scaled by `r` (`in_plane_ratio`)."""
    return params if r == 1.0 else replace(params, mu_eff=r * params.mu_eff, mu_radial=r * params.mu_radial)


def _isf(history: ForceHistory, process: Process) -> ForceField:
    for sentence in validity_warnings(process.thickness_m, process.tool_radius_m):
        warnings.warn(sentence, ExtrapolationWarning, stacklevel=3)
    fit = dict(process.force_fit)
    reference = process.force_history()
    scale = history_ratio(history, reference) * fit.pop("scale", 1.0)
    return IsfForceField(_in_plane_scaled(params_for(process, scale=scale, **fit), in_plane_ratio(history, reference)))


def _learned(history: ForceHistory, process: Process) -> ForceField:
    for sentence in validity_warnings(process.thickness_m, process.tool_radius_m):
        warnings.warn(sentence, ExtrapolationWarning, stacklevel=3)
    fit = dict(process.force_fit)
    ratio = history_ratio(history, process.force_history())
    weights = {key: ratio * fit.pop(key) if key not in ON_PRIOR_KEYS else fit.pop(key)
               for key in WEIGHT_KEYS if key in fit}
    fit["scale"] = ratio * fit.get("scale", 1.0)  # the prior's level: the prior weight multiplies it
    plane = in_plane_ratio(history, process.force_history())
    radial_rise = plane * fit.pop(RADIAL_RISE_KEY, 0.0)  # an in-plane ratio, scaled as μ_t and μ_r are
    for key in SPAN_KEYS:  # what it was learned over (`twin.process.force.span`), no constant of its force
        fit.pop(key, None)
    return LearnedForceField(_in_plane_scaled(params_for(process, **fit), plane), LearnedWeights(**weights),
                             radial_rise=radial_rise)


register_force_model(ForceModel(
    "table", "the per-pass field of the groove's FE history (the history's own path and commands near it)",
    _table, follows_history,
))
register_force_model(ForceModel(
    "isf", "the height-map ISF model at the process's published force level (any part and path)", _isf,
))
register_force_model(ForceModel(
    "learned", "the ISF model with terms of the formed state chosen and fitted from a cell's F/T stream (`tx200-twin learn`)",
    _learned, lambda _h, _process, _p: False,  # never from a path alone: it needs a cell's fitted weights
))
