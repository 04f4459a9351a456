"""The README is a map: short, no history, its numbers generated, its Python example runs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from twin.apps.readme import DEMO_BLOCK, SPEED_BLOCK, Block, speed_table
from twin.errors import InputError

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text(encoding="utf-8")


def test_the_readme_is_a_short_map_without_history() -> None:
    assert len(README.splitlines()) <= 150
    dated = re.findall(r".*(?:20\d\d-\d\d-\d\d|[Ss]ince 20\d\d|[Ee]arlier runs gave|issue #?\d+).*", README)
    assert dated == [], f"history belongs in CHANGELOG.md: {dated}"
    assert (REPO / "CHANGELOG.md").is_file()


def test_the_changelog_is_versioned_with_a_short_unreleased_section() -> None:
    """History is cut into versions: the newest version heading is the package's, and what is not yet released
    stays short (issue #46: 113 lines had piled up under Unreleased)."""
    import tomllib

    changelog = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    sections = re.split(r"^## ", changelog, flags=re.M)[1:]
    assert sections[0].startswith("Unreleased")
    assert len(sections[0].splitlines()) <= 40, "cut a version: Unreleased holds more than 40 lines"
    newest = re.match(r"(\d+\.\d+\.\d+) ", sections[1])
    version = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert newest is not None and newest.group(1) == version


def test_the_readme_speed_table_is_the_one_the_shipped_bench_results_give() -> None:
    results = json.loads((REPO / "benchmarks" / "results.json").read_text())
    assert SPEED_BLOCK.extract(README) == speed_table(results), (
        "README's speed table is stale: run `make bench` (tx200-twin bench --json benchmarks/results.json "
        "--readme README.md)"
    )


def test_every_number_outside_the_generated_blocks_is_not_a_measurement() -> None:
    text = README
    for block in (DEMO_BLOCK, SPEED_BLOCK):
        text = text.replace(block.extract(text), "")
    measured = re.findall(r"\d+(?:\.\d+)?\s*(?:ms|µs|mm rms|x real time|N rms)\b", text)
    assert measured == [], f"a measured number typed by hand: {measured}"


def test_a_block_refuses_missing_marks(tmp_path: Path) -> None:
    block = Block("<!-- a -->", "<!-- b -->")
    assert block.replace("x <!-- a -->\nold\n<!-- b --> y", "new\n") == "x <!-- a -->\nnew\n<!-- b --> y"
    with pytest.raises(InputError, match="missing or out of order"):
        block.replace("<!-- b --> <!-- a -->", "new\n")


def test_the_python_example_runs() -> None:
    code = re.search(r"```python\n(.*?)```", README, re.S)
    assert code is not None
    namespace: dict[str, object] = {}
    exec(compile(code.group(1), "README.md", "exec"), namespace)
    assert 0.05 < float(namespace["replay"](namespace["lab_run"], namespace["spec"]).metrics["position_rms_mm"]) < 1.0  # type: ignore[operator,index]
