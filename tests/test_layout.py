"""The package layout: stages import only stages before them, and nobody imports another module's private names.

The stages, in data-flow order (README "Layout"). A module may import its own stage, any earlier stage and
`twin.errors`; `twin/__init__.py` (the public API) may import anything.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import twin

STAGES = ("base", "robot", "process", "sim", "runs", "lab", "analysis", "viz", "apps", "cli")
PACKAGE_DIR = Path(twin.__file__).resolve().parent
MAX_MODULE_LINES = 330


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE_DIR.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _stage(module: str) -> str | None:
    """Stage of `twin.<stage>...`; None for `twin` itself and `twin.errors`."""
    parts = module.split(".")
    if len(parts) < 2 or parts[1] == "errors":
        return None
    return parts[1]


def _twin_imports(path: Path) -> list[tuple[int, str, list[str]]]:
    """(line, imported module, imported names) of every `twin` import in a file, lazy ones included."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found: list[tuple[int, str, list[str]]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "twin" or node.module.startswith("twin."):
                names = [alias.name for alias in node.names]
                if node.module == "twin":  # `from twin import recording`: a submodule import
                    for name in names:
                        found.append((node.lineno, f"twin.{name}", []))
                else:
                    found.append((node.lineno, node.module, names))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("twin."):
                    found.append((node.lineno, alias.name, []))
    return found


def _package_files() -> list[Path]:
    return sorted(PACKAGE_DIR.rglob("*.py"))


def _violations(files: list[Path]) -> list[str]:
    bad: list[str] = []
    for path in files:
        module = _module_name(path)
        if module == "twin":
            continue
        own = _stage(module)
        for line, target, names in _twin_imports(path):
            where = f"{path.relative_to(PACKAGE_DIR.parent)}:{line}"
            if target == "twin":
                bad.append(f"{where}: imports the top-level package (the public API) from inside it")
                continue
            their = _stage(target)
            if own is None and their is not None:
                bad.append(f"{where}: twin.errors must not import {target}")
            elif own is not None and their is not None:
                if own not in STAGES or their not in STAGES:
                    bad.append(f"{where}: unknown stage in {module} -> {target}; stages are {STAGES}")
                elif STAGES.index(their) > STAGES.index(own):
                    bad.append(f"{where}: upward import, stage '{own}' imports '{their}' ({target})")
            for name in names:
                if name.startswith("_") and not target.startswith(module):
                    bad.append(f"{where}: imports the private name {name} of {target}")
    return bad


def test_every_module_belongs_to_a_known_stage() -> None:
    unknown = [
        str(p.relative_to(PACKAGE_DIR))
        for p in _package_files()
        if _stage(_module_name(p)) not in (*STAGES, None)
    ]
    assert unknown == [], f"modules outside the stages {STAGES}: {unknown}"


def test_imports_flow_one_way_and_respect_private_names() -> None:
    violations = _violations(_package_files())
    assert violations == [], "\n".join(violations)


def test_the_check_catches_an_upward_import_and_a_private_name(tmp_path: Path) -> None:
    bad = PACKAGE_DIR / "robot" / "_layout_probe_tmp.py"
    bad.write_text("from twin.analysis.replay import replay\nfrom twin.base.csvio import _private\n")
    try:
        violations = _violations([bad])
    finally:
        bad.unlink()
    assert len(violations) == 2, violations
    assert "upward import" in violations[0]
    assert "private name _private" in violations[1]


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_says_what_it_takes_and_gives(stage: str) -> None:
    init = PACKAGE_DIR / stage / "__init__.py"
    doc = ast.get_docstring(ast.parse(init.read_text())) if init.is_file() else None
    assert doc, f"twin/{stage}/__init__.py needs a docstring saying what the stage takes and gives"


def test_no_module_is_much_longer_than_one_concept_needs() -> None:
    long = {
        str(p.relative_to(PACKAGE_DIR)): n
        for p in _package_files()
        if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES
    }
    assert long == {}, f"split these by concept (> {MAX_MODULE_LINES} lines): {long}"
