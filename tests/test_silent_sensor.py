"""A run whose F/T sensor saw no forming (all-zero forces) is refused by every fit of forces, named, instead of
fitted to its bounds (issue #46: `identify --forces` fitted a force scale of 0.05; `discrepancy` stopped on
"IsfForceParams.scale = 0.0"; Method 2 on a cone stopped on the groove's "pass_index = 11")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_refusal import refused
from run_edits import with_forces

from twin.cli import main


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A small cone's nominal lab run, and its copy with the F/T stream zeroed."""
    root = tmp_path_factory.mktemp("silent")
    cone = root / "cone.csv"
    assert main(["path", "--shape", "cone", "--top-width-mm", "40", "--depth-mm", "4", "--out", str(cone)]) == 0
    run = root / "run"
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--commanded", str(cone), "--out", str(run)]) == 0
    return run, with_forces(run, root / "flat", np.zeros_like)


@pytest.mark.parametrize("argv", [["identify", "--forces"], ["identify", "--method", "2"], ["discrepancy"]])
def test_a_flat_force_stream_is_refused_by_name(argv: list[str], runs: tuple[Path, Path],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    refused([*argv, str(runs[1])], capsys, f"run {runs[1]}", "peaks at 0.0 N", "no forming contact")


def test_method_2_on_a_cone_takes_the_force_model_that_applies_to_it(runs: tuple[Path, Path],
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["identify", "--method", "2", str(runs[0])]) == 0  # was: the groove's table, "pass_index = 11"
    assert "pass_index" not in capsys.readouterr().err
