"""The demo part's numbers in docs/any-part.md are what `experiments/cone_demo.py` measures (slow: a 40 mm deep
cone, 603 s of machining, on both plants)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from doc_numbers import REPO, quoted

_SPEC = importlib.util.spec_from_file_location("cone_demo", REPO / "experiments" / "cone_demo.py")
assert _SPEC is not None and _SPEC.loader is not None
study = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(study)


@pytest.mark.slow
def test_the_demo_cones_table_is_what_the_study_measures(tmp_path: Path) -> None:
    result = study.cone_demo(tmp_path)
    path, checks = result["path"], result["checks"]
    text = " ".join((REPO / "docs" / "any-part.md").read_text(encoding="utf-8").split())
    assert f"({path['samples']:,} samples".replace(",", " ") in text
    length_m, duration_s = quoted("any-part.md", " samples,", 2)
    length_m.check(1e-3 * path["length_mm"])
    duration_s.check(path["duration_s"])
    quoted("any-part.md", "compensated by the twin (", 1)[0].check(result["compensation"]["iterations"])
    for (plant, name), c in checks.items():
        doc = quoted("any-part.md", f"| {plant} | {name} |", 5)
        for q, key in zip(doc, ("residual_rms_mm", "residual_max_mm", "surface_rms_mm", "surface_max_mm",
                                "surface_mean_mm"), strict=True):
            q.check(c[key])
