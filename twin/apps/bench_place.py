"""Benchmark of the placement search (`tx200-twin bench`): its wall time over one `Twin.simulate` of the part.

`place_cost` runs `twin.analysis.placement_search.search_placement` (defaults: 512 candidates, the best 5
confirmed, every usable core) on a 45° cone on the ISF model, and one `Twin.simulate` of the same cone at the
default placement on a warm twin (IK included: the cone is shifted by a nanometre per repeat, so no IK is reused),
each the median of `repeats`. The ratio `over_simulation` is the issue's "simulations' worth of time" (target: at
most 20). It also reports the best confirmed placement's simulated error against the default placement's.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

from twin.analysis.placement_search import search_placement
from twin.errors import InputError
from twin.process.description import Process
from twin.process.toolpath.shapes import PartSpec, part_path
from twin.sim.spec import TwinSpec


def place_cost(top_width_m: float, depth_m: float, repeats: int = 3, candidates: int = 512) -> dict[str, Any]:
    """The placement search of a cone against one simulation of it (module docstring).

    Args:
        top_width_m: The cone's top diameter [m].
        depth_m: Its depth [m].
        repeats: Timed runs of each (>= 1); medians reported.
        candidates: Candidate placements of the search.

    Returns:
        samples, candidates, feasible, workers, place_s and simulate_s [s], their ratio `over_simulation` [-],
        the default's and the best confirmed placement's simulated rms error [mm] and their ratio
        `best_over_default_rms`, the best placement (`PlacementSearch.summary`), and the search's stage times [s].
    """
    if repeats < 1:
        raise InputError(f"repeats = {repeats!r}: expected >= 1")
    cone = part_path(PartSpec(depth_m=depth_m, top_half_width_m=top_width_m / 2.0))
    spec = TwinSpec(process=Process(force_model="isf"))
    twin = spec.build()
    twin.simulate(cone.t_s[:50], cone.p_sheet_m[:50])  # compile and warm the loop outside the timings
    sims, places = [], []
    for k in range(1, repeats + 1):
        start = time.perf_counter()
        twin.simulate(cone.t_s, cone.p_sheet_m + 1e-9 * k)
        sims.append(time.perf_counter() - start)
        start = time.perf_counter()
        result = search_placement(cone, spec, candidates=candidates, seed=0)
        places.append(time.perf_counter() - start)
    summary = result.summary()
    place_s, simulate_s = statistics.median(places), statistics.median(sims)
    best = summary["best"]
    return {
        "samples": len(cone.t_s), "candidates": candidates, "feasible": summary["feasible"],
        "workers": summary["where"], "place_s": place_s, "simulate_s": simulate_s,
        "over_simulation": place_s / simulate_s,
        "default_simulated_rms_mm": summary["default"]["simulated_rms_mm"],
        "best_simulated_rms_mm": None if best is None else best["simulated_rms_mm"],
        "best_over_default_rms": summary["best_over_default_rms"], "best": best, "stages_s": result.timings_s,
    }
