"""The JSON document of a discrepancy search (`tx200-twin discrepancy --json`)."""

from __future__ import annotations

from typing import Any

from twin.analysis.discrepancy.search import DiscrepancyResult
from twin.analysis.discrepancy.selection import ROUND_SHARE


def result_summary(result: DiscrepancyResult) -> dict[str, Any]:
    """Keys: `effect` (first named, `none` or `unexplained`), `effects` (all named, in order; a family that maps
    onto an effect of the vocabulary, which the model file uses, under the effect's name; the family names are in
    `families`),
    `families` (each with parameters, uncertainty, explained_fraction, ambiguous_with), `explained_fraction`,
    `remainder` (signature of what is left, in words and numbers), `parameters` (the model file's effects),
    `gap_before`, `gap_after`, `noise`, `candidates`, `rounds` and `scan_miss_mm` (family -> its rms miss of the part
    scan less the cell's floor bias, where the scan judged the first round's ambiguity)."""

    def candidate(c: Any) -> dict[str, Any]:
        return {
            "name": c.name, "score": c.gain, "explained_fraction": c.share, "bic_gain": c.bic_gain,
            "contradicted": c.contradicted,
            "parameters": {k: float(v) for k, v in zip(_names(c), c.fit.theta[c.name], strict=True)},
        }

    return {
        "effect": result.named[0].reported_name if result.named else result.verdict,
        "effects": [n.reported_name for n in result.named],
        "families": [n.summary() for n in result.named],
        "partial": [n.summary() for n in result.partial],
        "explained_fraction": result.explained_fraction,
        "significant_share": ROUND_SHARE,
        "remainder": result.remainder,
        "consistency": result.consistency,
        "floor": result.floor,
        "ambiguities": [
            {"named": n.name, "ambiguous_with": list(n.ambiguous_with)} for n in result.named if n.ambiguous_with
        ],
        "scan_miss_mm": result.scan,
        "parameters": result.effects.named_parameters(),
        "instruments": result.effects.instruments.changed(),
        "model_complete": result.model_complete,
        "confidence": result.confidence,
        "gap_before": result.gap_before,
        "gap_after": result.gap_after,
        "noise": result.noise,
        "reduced_chi2_before": result.chi2_before,
        "reduced_chi2_after": result.chi2_after,
        "candidates": [candidate(c) for c in result.rounds[0].candidates] if result.rounds else [],
        "rounds": [
            {"accepted": s.accepted, "candidates": [candidate(c) for c in s.candidates]} for s in result.rounds
        ],
    }


def _names(c: Any) -> tuple[str, ...]:
    from twin.analysis.discrepancy.families import FAMILIES

    return FAMILIES[c.name].parameters
