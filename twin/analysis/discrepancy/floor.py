"""The floor a learned cell leaves on its own clean runs, against which a later run's change is judged (issue #47).

A twin learned from a cell does not replay that cell's next clean run to its noise: it leaves a floor (the
reversal transients a quasi-static twin does not hold, what the sheet learner has no term for). A discrepancy
search judged against the noise alone then throws right answers away: a family that finds the hidden change
with its right size explains only part of the run's excess and leaves the floor's slow structure, so it is not
named. `measure_floor` measures that floor the way the search measures a run (each stream's residual over its
noise estimate, `twin.analysis.discrepancy.residuals.ResidualModel`): per element, the excess over noise
(Σ v² − n) / n and the structured excess of `twin.analysis.discrepancy.consistency` (its moving average), both
in noise units, so that they carry over to a run of another length. `learn`, given two runs or more, measures
it on each run with the twin learned from the others (a clean run the twin did not fit: predicted, not fitted)
and records their mean in the model file; `discrepancy RUN --model M.json` takes it (`find_discrepancy`'s
`floor`): a family's share is counted of the excess over the floor, and what it leaves of the slow structure
over the floor's. Without a recorded floor, the search is judged against the noise as before.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from twin.analysis.discrepancy.consistency import structured_excess
from twin.analysis.discrepancy.effect_model import context
from twin.analysis.discrepancy.families import FAMILIES
from twin.analysis.discrepancy.fitting import Fitter
from twin.analysis.discrepancy.residuals import ResidualModel, measured_streams
from twin.analysis.discrepancy.scan import scan_miss
from twin.analysis.discrepancy.selection import single_gains
from twin.errors import InputError
from twin.runs.format import Run
from twin.sim.effects import Effects
from twin.sim.spec import TwinSpec

STREAMS = ("position", "force", "profile")
#: A run whose excess over noise lies within this share of the floor's shows no change the floor would not: the
#: floor itself moves by 1-6 % between a learned cell's clean runs (a TX200 groove and a KR210 cone, the cells of
#: tests/plant_changes.py, measured on their clean runs only), and a change adding less cannot be told from it.
OBSERVABLE_SHARE = 0.10
#: Units of each stream's noise in words.
UNITS = {"position": (1e3, "mm"), "force": (1.0, "N"), "profile": (1e3, "mm")}


class Floor(NamedTuple):
    """A learned cell's floor on its clean runs, per stream, per element, in noise units (module docstring).

    Attributes:
        excess: Stream -> (Σ v² − n) / n of the residual over its noise, >= 0.
        structure: Stream -> the structured excess (`consistency.structured_excess`) / n, >= 0.
        runs: The runs it was measured on (each with a twin learned from the others).
        family_gain: Family -> the held-out gain it finds alone on those runs, per element [noise units²]: what a
            family takes of the floor's own structure (a lost motion of the reversal transients), which
            `discrepancy` takes off its gain on a later run (`selection.forward_select`'s `offsets`).
        scan_bias_m: The mean of the part scan less the twin's part over the formed region (`scan.scan_miss`) [m],
            None where the runs have no scan or the force model keeps no surface.
        scan_spread_m: The rms of that miss about its mean [m], None likewise.
    """

    excess: Mapping[str, float]
    structure: Mapping[str, float]
    runs: tuple[str, ...] = ()
    family_gain: Mapping[str, float] = MappingProxyType({})
    scan_bias_m: float | None = None
    scan_spread_m: float | None = None

    def offsets(self, sizes: Mapping[str, int]) -> dict[str, float]:
        """Each family's floor gain over a run of these stream sizes (elements) [noise units²]."""
        n = sum(sizes.values())
        return {name: g * n for name, g in self.family_gain.items()}

    def excess_on(self, sizes: Mapping[str, int]) -> float:
        """The floor's excess over a run's streams of these sizes (elements) [noise units²]."""
        return float(sum(self.excess.get(s, 0.0) * n for s, n in sizes.items()))

    def observable(self, excess: float, sizes: Mapping[str, int]) -> bool:
        """Whether a run's excess over noise [noise units², whole run] rises above the floor by more than
        OBSERVABLE_SHARE of it."""
        return excess - self.excess_on(sizes) > OBSERVABLE_SHARE * self.excess_on(sizes)

    def unobservable_words(self, excess: float, sizes: Mapping[str, int], sigma: Mapping[str, float]) -> str:
        """Why nothing is named, and the size of a change that would be observable: per stream, the rms a change
        alone in that stream must reach to add OBSERVABLE_SHARE of the floor."""
        floor = self.excess_on(sizes)
        least = []
        for s, n in sizes.items():
            scale, unit = UNITS[s]
            rms = scale * sigma[s] * float(np.sqrt(OBSERVABLE_SHARE * floor / max(n, 1)))
            least.append(f"{s} {rms:.3g} {unit} rms")
        return (f"no change observable on this run above the cell's floor: its excess over noise is "
                f"{excess / max(floor, 1e-12):.2f} x the floor's (within {1 + OBSERVABLE_SHARE:.2f} x, what the floor "
                f"moves between clean runs); a change would be observable from about {', '.join(least)}")

    def to_json(self) -> dict[str, Any]:
        """As the model file records it (`floor`)."""
        scan = {} if self.scan_bias_m is None or self.scan_spread_m is None else {
            "scan_bias_mm": 1e3 * self.scan_bias_m, "scan_spread_mm": 1e3 * self.scan_spread_m}
        return {"excess_per_element": dict(self.excess), "structure_per_element": dict(self.structure),
                "family_gain_per_element": dict(self.family_gain), "runs": list(self.runs), **scan,
                "note": "what the learned cell leaves on its own clean runs, predicted (learned from the others)"}

    @classmethod
    def from_json(cls, entry: Any, where: str) -> Floor:
        """The model file's `floor` object.

        Raises:
            InputError: Not the object `to_json` writes (naming `where`).
        """
        if not isinstance(entry, Mapping):
            raise InputError(f"{where}: floor = {entry!r}: expected an object")
        parts = []
        for key in ("excess_per_element", "structure_per_element"):
            values = entry.get(key)
            if not isinstance(values, Mapping) or not all(
                    s in STREAMS and isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)
                    and v >= 0 for s, v in values.items()):
                raise InputError(f"{where}: floor.{key} = {values!r}: expected stream ({', '.join(STREAMS)}) -> "
                                 "a finite number >= 0")
            parts.append({str(s): float(v) for s, v in values.items()})
        runs = entry.get("runs", [])
        gains = entry.get("family_gain_per_element", {})
        if not isinstance(gains, Mapping) or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v) and v >= 0
                for v in gains.values()):
            raise InputError(f"{where}: floor.family_gain_per_element = {gains!r}: expected family -> a finite "
                             "number >= 0")
        scan = []
        for key, low in (("scan_bias_mm", -np.inf), ("scan_spread_mm", 0.0)):
            value = entry.get(key)
            if value is not None and (not isinstance(value, int | float) or isinstance(value, bool)
                                      or not np.isfinite(value) or value < low):
                raise InputError(f"{where}: floor.{key} = {value!r}: expected a finite number"
                                 + (" >= 0" if low == 0.0 else "") + " [mm], or no entry")
            scan.append(None if value is None else 1e-3 * float(value))
        if (scan[0] is None) != (scan[1] is None):
            raise InputError(f"{where}: floor has one of scan_bias_mm and scan_spread_mm: expected both or neither")
        return cls(parts[0], parts[1], tuple(str(r) for r in runs) if isinstance(runs, list) else (),
                   {str(k): float(v) for k, v in gains.items()}, scan[0], scan[1])


def excess_by_stream(model: ResidualModel, effects: Effects) -> dict[str, tuple[float, int]]:
    """Stream -> (Σ v² − n, n): the excess over noise of the residual measured - predicted (`model.streams`) over
    the noise the run shows, as the search measures it, and its number of elements."""
    sigma = model.noise.by_stream
    out = {}
    for s, raw in model.streams(effects).items():
        v = np.ravel(raw) / sigma[s]
        out[s] = (float(v @ v) - v.size, v.size)
    return out


def measure_floor(run: Run, spec: TwinSpec) -> Floor:
    """The floor `spec` leaves on `run` (a clean run it did not learn from), measured as the search measures."""
    model = ResidualModel(run, spec)
    noise = model.noise
    sigma = noise.by_stream
    excess, structure = {}, {}
    for s, (total, n) in excess_by_stream(model, spec.effects).items():
        excess[s] = max(total, 0.0) / n
    for s, raw in model.streams(spec.effects).items():
        structure[s] = max(structured_excess(raw, sigma[s]), 0.0) / raw.size
    ctx = context(model, spec.effects)
    fitter = Fitter(ctx, measured_streams(run), sigma, model.folds())
    sizes = {s: fitter.raw[s].size for s in fitter.streams}
    families = [f for f in FAMILIES.values() if f.applicable(ctx)]
    n = sum(sizes.values())
    gains = {name: g / n for name, g in single_gains(fitter, families, sizes).items()}
    miss = scan_miss(model, spec.effects)
    bias, spread = (None, None) if miss is None else (float(np.mean(miss)), float(np.std(miss)))
    return Floor(excess, structure, (str(run.directory),), gains, bias, spread)


def mean_floor(floors: Sequence[Floor]) -> Floor:
    """The mean of floors measured on several runs (each stream over the runs that have it)."""
    if not floors:
        raise InputError("mean_floor needs at least one floor")

    def mean(key: str) -> dict[str, float]:
        streams = {s for f in floors for s in getattr(f, key)}
        return {s: float(np.mean([getattr(f, key)[s] for f in floors if s in getattr(f, key)])) for s in streams}

    scans = [(f.scan_bias_m, f.scan_spread_m) for f in floors if f.scan_bias_m is not None]
    bias, spread = (float(np.mean([b for b, _ in scans])), float(np.mean([s for _, s in scans]))) if scans else (
        None, None)
    return Floor(mean("excess"), mean("structure"), tuple(r for f in floors for r in f.runs), mean("family_gain"),
                 bias, spread)
