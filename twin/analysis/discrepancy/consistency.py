"""Whether the named families account for the gap consistently: their own stream, and no structure left.

A family is named only when its evidence is consistent, checked for the first named family (the verdict) after
the selection and the effects' replay, on the streams it acts on (`Family.acts_on`: a robot-side family the tool
tip and the forces, its change reaching both through the loaded robot; a force-sensor family the forces; a
tracker family the tool tip; a part family the profile):

1. *Its evidence shows a gap*: the first of those streams carries a significant gap (a force gap alone is no
   evidence of a process force scale, which would have moved the tool tip too).
2. *No structure left where it acts*: in those of its streams that are the tool tip's or the forces', what the
   named families leave must not keep more than STRUCTURE_SHARE of the stream's slow structure. The slow
   structure is the excess over noise of the residual (divided by its noise) smoothed by a moving average over
   1/40 of the stream (~0.5 s of a groove run), times the window W: white noise gives ~0 (W var(mean of W) = 1
   per sample), a slow structure its energy times W. It is what a remainder keeps when a family takes the wrong
   shape out (a drift fitted to a step, a bias to a warm-up drift, a registration to a stroke-dependent tool
   error, a dead band to a one-sided stiffness whose forces it leaves). Only a significant remainder counts
   (above SIGNIFICANCE_SE standard errors of what white noise gives). Streams the family does not act on may
   carry another effect: they are described, not held against it. The part profile is not judged so: on the
   development set the families' linearised profile leaves 35-88 % of the profile's structure even for the
   library's own robot-side forms.
3. *No gap made where the data show none*: a tool-tip or force stream without a significant gap before must not
   be left with a significant slow structure by the named families together (a sensor gain taking a saturated
   F/T's forces, with a robot-side family beside it moving the tool tip the tracker shows unmoved).

Otherwise the verdict is `unexplained` and the raw gap is described (`signature`), with why the family was not
named.

STRUCTURE_SHARE was chosen on the DEVELOPMENT set of `tests/discrepancy_heldout.py` only, then frozen (the test
set was not consulted): where a family is named before this check, the development cases of the library's own
forms leave at most 0.045 of a stream's slow structure (a clamp-force rise); the outside forms that leave more
(and show a gap in their family's stream) leave at least 0.106 (a one-sided wrist stiffness taken as lost
motion). The threshold is their geometric mean, rounded: 0.07 (`chosen_threshold` in the test module recomputes
it from the development rows). One outside development case, a warm-up drift of the force sensor taken as
cross-talk, leaves 0.014 and is not caught. Since the families of issue #47 (`tracker_clock` takes the one-sided
wrist stiffness, leaving 0.046) the rule gives 0.05 on the same rows; the threshold stays frozen at 0.07, as the
test set has been seen since.

Over a learned cell's floor (`twin.analysis.discrepancy.floor`) the structure is counted above the floor's, raised
by FLOOR_STRUCTURE_SLACK: the floor is measured on the cell's own two clean runs, and a later clean run of the same
cell leaves up to 14 % more slow structure than it records (the third and fourth runs of the development cells of
`tests/plant_changes.py`: tool tip 0.94-1.14 x, forces 0.90-1.07 x; profile not judged). Without the slack a family
with the right size that leaves a clean run's structure failed rule 2 (an F/T gain of 1.10 on z, its gain found
within 0.3 %, leaving 10 % of the structure above the floor). The slack is 0.2, chosen on those clean runs alone.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from scipy.ndimage import uniform_filter1d

STRUCTURE_SHARE = 0.07  # chosen on the development set (module docstring); frozen
CHECKED_STREAMS = ("position", "force")
WINDOW_FRACTION = 1.0 / 40.0  # the moving average spans this share of a stream's samples (>= 3 samples)
SIGNIFICANCE_SE = 5.0  # an excess counts when above this many standard errors of white noise's
FLOOR_STRUCTURE_SLACK = 0.2  # a clean run's structure over the floor's, at most (module docstring); chosen on clean runs


class StreamCheck(NamedTuple):
    """One stream's measures before and after the named families (residual over its noise, summed)."""

    excess_before: float
    excess_after: float
    structured_before: float
    structured_after: float
    significant: bool
    structure_left: float
    failed: bool
    made: bool = False


class Consistency(NamedTuple):
    """The check's outcome: `consistent`, each stream's measures, and the evidence streams without a gap."""

    consistent: bool
    streams: dict[str, StreamCheck]
    no_gap: tuple[str, ...]
    judged: tuple[str, ...]

    def summary(self) -> dict[str, Any]:
        """JSON-ready."""
        return {"consistent": self.consistent, "no_gap": list(self.no_gap), "judged": list(self.judged),
                "streams": {s: {k: (bool(v) if isinstance(v, bool | np.bool_) else float(v))
                                for k, v in c._asdict().items()} for s, c in self.streams.items()}}


def _measures(values: np.ndarray, sigma: float) -> tuple[float, float, float, float]:
    """(excess, its white-noise standard error, structured excess, its standard error) of one stream."""
    v = np.asarray(values, dtype=float).reshape(len(values), -1) / sigma
    n = v.size
    window = max(3, round(WINDOW_FRACTION * len(v)))
    smooth = uniform_filter1d(v, size=window, axis=0, mode="nearest")
    return (float(np.sum(v**2)) - n, float(np.sqrt(2.0 * n)),
            window * float(np.sum(smooth**2)) - n, float(np.sqrt(2.0 * n * window)))


def structured_excess(values: np.ndarray, sigma: float) -> float:
    """The structured excess of one stream's residual over its noise `sigma` (module docstring) [noise units²]."""
    return _measures(values, sigma)[2]


def check(
    before: dict[str, np.ndarray], after: dict[str, np.ndarray], sigma: dict[str, float], acts_on: tuple[str, ...],
    floor: dict[str, float] | None = None,
) -> Consistency:
    """Whether the named families' evidence is consistent (module docstring).

    Args:
        before: Stream -> residual of the twin as given (SI: m or N), measured - predicted.
        after: Stream -> what is left after the named families (SI).
        sigma: Stream -> noise sigma per axis (SI).
        acts_on: The streams the first named family acts on, its evidence first (`Family.acts_on`).
        floor: Stream -> the structured excess a learned cell leaves on its own clean runs of this size
            (`twin.analysis.discrepancy.floor`): the structure left is counted above it (raised by
            FLOOR_STRUCTURE_SLACK), of the structure above it. None: none (judged against the noise).
    """
    streams = {}
    judged = tuple(s for s in acts_on if s in CHECKED_STREAMS and s in before)
    for name, raw in before.items():
        e0, se_e, s0, se_s = _measures(raw, sigma[name])
        e1, _, s1, _ = _measures(after[name], sigma[name])
        base = 0.0 if floor is None else min(max((1.0 + FLOOR_STRUCTURE_SLACK) * floor.get(name, 0.0), 0.0),
                                             0.9 * max(s0, 0.0))
        s0, s1 = s0 - base, s1 - base
        left = max(s1, 0.0) / s0 if s0 > SIGNIFICANCE_SE * se_s else 0.0
        failed = name in judged and left > STRUCTURE_SHARE and s1 > SIGNIFICANCE_SE * se_s
        made = name in CHECKED_STREAMS and e0 <= SIGNIFICANCE_SE * se_e and s1 > SIGNIFICANCE_SE * se_s
        streams[name] = StreamCheck(e0, e1, s0, s1, e0 > SIGNIFICANCE_SE * se_e, left, failed or made, made)
    evidence = acts_on[0]
    no_gap = (evidence,) if evidence in streams and not streams[evidence].significant else ()
    return Consistency(not no_gap and not any(c.failed for c in streams.values()), streams, no_gap, judged)
