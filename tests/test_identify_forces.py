"""Forces learned from the cell (`identify --forces`, twin/analysis/identify/forces.py): a first part formed on a
sheet 25 % stronger than declared (the lab's hidden `force_scale`; the fit never reads truth.json), the level
fitted from its F/T stream, and a second part compensated with and without that step, as a user types it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from doc_numbers import quoted

from twin.cli import main
from twin.sim.model_file import read_model_file

#: docs/any-part.md's row for this test: scale, then rms declared / learned [mm].
ANCHOR = "| a sheet 25 % stronger than declared, fitted from a first part's F/T stream | scale"


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("forces")
    first, second = base / "first.csv", base / "second.csv"
    assert main(["path", "--shape", "cone", "--depth-mm", "6", "--top-width-mm", "50", "--out", str(first)]) == 0
    assert main(["path", "--shape", "pyramid", "--depth-mm", "6", "--top-width-mm", "40", "--out", str(second)]) == 0
    assert main(["lab", "--scenario", "nominal", "--commanded", str(first), "--effect", "force_scale=1.25",
                 "--seed", "1", "--out", str(base / "first_run")]) == 0
    assert main(["identify", "--forces", str(base / "first_run"), "--write-model", str(base / "cell.json"),
                 "--json", str(base / "fit.json")]) == 0
    for name, model in (("declared", []), ("learned", ["--model", str(base / "cell.json")])):
        assert main(["compensate", "--method", "twin", "--ideal", str(second), *model, "--out",
                     str(base / f"cmd_{name}.csv")]) == 0
        assert main(["lab", "--scenario", "compensated", "--commanded", str(base / f"cmd_{name}.csv"), "--effect",
                     "force_scale=1.25", "--seed", "2", "--out", str(base / f"run_{name}")]) == 0
        main(["check", str(base / f"run_{name}"), "--ideal", str(second), "--json", str(base / f"check_{name}.json")])
    return {"base": base, "second": second}


def test_the_level_of_a_stronger_sheet_is_found_from_the_f_t_stream(cell: dict[str, Path]) -> None:
    """Measured: the scale docs/any-part.md quotes (hidden 1.25); force rms falls under a fifth."""
    fit = json.loads((cell["base"] / "fit.json").read_text())
    assert fit["force_model"] == "isf"
    assert fit["force_fit"]["scale"] == pytest.approx(1.25, rel=0.02)
    quoted("any-part.md", ANCHOR, 1)[0].check(fit["force_fit"]["scale"])
    assert fit["force_rms_after_n"] < 0.2 * fit["force_rms_before_n"]
    spec = read_model_file(cell["base"] / "cell.json")
    assert dict(spec.process.force_fit)["scale"] == pytest.approx(fit["force_fit"]["scale"])


def test_the_second_part_compensated_with_the_learned_forces_lands_closer(cell: dict[str, Path]) -> None:
    """Measured (seed 2, a pyramid 40 mm across, 6 mm deep): the rms docs/any-part.md quotes, declared / learned."""
    declared = json.loads((cell["base"] / "check_declared.json").read_text())["residual_rms_mm"]
    learned = json.loads((cell["base"] / "check_learned.json").read_text())["residual_rms_mm"]
    print(f"\nsecond part: declared forces {declared:.3f} mm rms, learned forces {learned:.3f} mm rms")
    assert learned < 0.5 * declared
    doc = quoted("any-part.md", ANCHOR, 3)
    doc[1].check(declared)
    doc[2].check(learned)


def test_a_run_without_forces_is_a_clear_error(cell: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    run = cell["base"] / "first_run"
    bare = cell["base"] / "bare_run"
    bare.mkdir()
    for name in ("meta.json", "commanded.csv", "tracker.csv"):
        (bare / name).write_bytes((run / name).read_bytes())
    assert main(["identify", "--forces", str(bare)]) == 2
    assert "forces.csv: file not found" in capsys.readouterr().err
