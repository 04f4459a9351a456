"""The twin is judged on labs it did not build: nothing that makes a command, a model, a compensation or an online
correction may know the lab's answer. Outside `twin/lab/` only the modules that *run* a lab import it, no module
reads the lab's `truth.json` (one writes it, for the lab), and no module names a dynamic-plant knob except as
shared vocabulary (a run's or a cell file's own keys).

These are source checks (ast, no imports of the modules checked): a lazy import inside a function and an
import by name (`importlib`, the package's lazy table) count as imports.
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

from twin.lab.dynamic.knobs import KNOBS

ROOT = Path(__file__).resolve().parents[1]
TWIN = ROOT / "twin"

#: The modules outside twin/lab that import it, each because it runs a lab (and builds nothing from it).
ALLOWED: dict[str, str] = {
    "twin": "the package's lazy table re-exports the lab entry points (run_lab, load_test, run_dynamic_lab)",
    "twin.apps.tasks.lab": "the `lab` task: runs the virtual lab and the rigid CNC, writes their runs",
    "twin.apps.tasks.lab_cnc": "`lab --plant cnc`: runs the rigid CNC machine",
    "twin.apps.tasks.lab_dynamic": "`lab --plant dynamic`: runs the dynamic plant (the online compensator beside it "
                                   "gets the command and its record only)",
    "twin.apps.bench": "`bench`: times the labs' runs",
    "twin.apps.demo": "`demo`: makes lab runs for the twin to learn from and be checked against",
    "twin.apps.force_validation": "validates the force model against runs of the rigid CNC lab",
    "twin.apps.springback_validation": "validates the springback model against runs of the rigid CNC lab",
    "twin.apps.warm": "`make test`'s warm-up: drives the plant's sheets along a pass to compile their kernels, "
                      "reads nothing back",
}
#: Modules that may name `truth.json`: the run writer writes the lab's truth there (and nothing reads it back).
TRUTH_WRITERS = {"twin.runs.write": "write_run(..., truth=...) writes it for the lab; read_run never opens it"}
#: Knob names that are also the twin's own vocabulary: the same words, not the plant's values.
SHARED_NAMES = {
    "tracker_rate_hz": "a run's meta key (the rate its tracker measured at) and a cell file's [sensors] key",
    "ft_rate_hz": "a cell file's [sensors] key (the F/T sensor's datasheet rate)",
    "tracker_noise_mm": "a cell file's [sensors] key (the tracker's datasheet noise)",
    "ft_noise_n": "a cell file's [sensors] key (the F/T sensor's datasheet noise)",
    "friction_reversal_mm": "a model file's process key (the twin's own, fitted, tool friction's reversal)",
}
_LAB_MODULE = re.compile(r"twin\.lab(\.[A-Za-z_]\w*)*")


def _module(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def _outside_lab() -> dict[str, tuple[ast.Module, bool]]:
    """Every module under twin/ but twin/lab, parsed, and whether it is a package's __init__ (once per session: the
    checks only walk the trees)."""
    return {_module(p): (ast.parse(p.read_text(encoding="utf-8"), str(p)), p.name == "__init__.py")
            for p in sorted(TWIN.rglob("*.py")) if p.relative_to(TWIN).parts[0] != "lab"}


def _imported(name: str, tree: ast.Module, package: bool = False) -> set[str]:
    """The modules `tree` (module `name`; `package`: an __init__) imports, at any depth (lazy imports too), and the
    module names it gives as strings (importlib, the lazy table)."""
    here = name.split(".") if package else name.split(".")[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the package up
                base = ".".join([*here[: len(here) - node.level + 1], *([base] if base else [])])
            out.add(base)
            out.update(f"{base}.{alias.name}" for alias in node.names)  # `from twin import lab`
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and _LAB_MODULE.fullmatch(node.value):
            out.add(node.value)
    return out


def _code_strings(tree: ast.Module) -> list[tuple[int, str]]:
    """The string constants of a module that are not docstrings, with their lines (f-strings' parts included)."""
    docs = {id(node.body[0].value) for node in ast.walk(tree)
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body
            and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs]


def test_only_the_modules_that_run_a_lab_import_it() -> None:
    importers = {name for name, (tree, package) in _outside_lab().items()
                 if any(m == "twin.lab" or m.startswith("twin.lab.") for m in _imported(name, tree, package))}
    assert importers == set(ALLOWED), (f"import twin.lab where no lab is run: {sorted(importers - set(ALLOWED))}; "
                                       f"no longer importing it (drop from ALLOWED): {sorted(set(ALLOWED) - importers)}")


def test_no_module_reads_the_labs_truth() -> None:
    readers = sorted(f"{name}:{line}" for name, (tree, _) in _outside_lab().items() if name not in TRUTH_WRITERS
                     for line, text in _code_strings(tree) if text.endswith("truth.json"))
    assert not readers, f"name truth.json (the lab's hidden truth) outside its writer: {readers}"


def test_no_module_that_does_not_run_a_lab_names_a_plant_knob() -> None:
    """A knob's name as a string (knobs["..."]), an attribute or a keyword: the plant's value of it."""
    knobs = set(KNOBS) - set(SHARED_NAMES)
    found = []
    for name, (tree, _) in _outside_lab().items():
        if name in ALLOWED:
            continue
        found += [f"{name}:{line} {text}" for line, text in _code_strings(tree) if text in knobs]
        found += [f"{name}:{node.lineno} .{node.attr}" for node in ast.walk(tree)
                  if isinstance(node, ast.Attribute) and node.attr in knobs]
        found += [f"{name}: {node.arg}=" for node in ast.walk(tree) if isinstance(node, ast.keyword) and node.arg in knobs]
    assert not found, f"plant knobs named where no lab is run: {found}"
    assert set(SHARED_NAMES) <= set(KNOBS), "a shared name that is no longer a knob: drop it from SHARED_NAMES"


def test_the_online_compensator_beside_the_plant_gets_no_plant_internals() -> None:
    """`lab --online` on an offline command, and the online study's "both": the compensator's input is built from
    the command and its compensation record, not from the plant's re-timing (`twin.lab.dynamic.trajectory`) or its
    knobs (the controller's acceleration: when it stops at corners)."""
    for path in (TWIN / "apps" / "tasks" / "lab_dynamic.py", ROOT / "experiments" / "online_study.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        imported = _imported(_module(path), tree)
        assert not [m for m in imported if m.startswith("twin.lab.dynamic.trajectory")], path
        assert not [t for _, t in _code_strings(tree) if t.startswith("trajectory_")], path
        for call in ast.walk(tree):  # assumed_forces(record, commanded): nothing of the plant's
            if isinstance(call, ast.Call) and getattr(call.func, "id", None) == "assumed_forces":
                assert len(call.args) == 2 and not call.keywords, f"{path}:{call.lineno}"


def test_the_forces_assumed_are_the_commands_own() -> None:
    """What `lab --online` gives the compensator on top of an offline command: its tips at the record's samples
    and the record's forces, nothing else."""
    import numpy as np

    from twin.analysis.compensation_record import CompensationRecord
    from twin.apps.tasks.lab_dynamic import assumed_forces
    from twin.runs.format import Stream

    t = np.linspace(0.0, 1.0, 11)
    p = np.column_stack([t, 0.5 * t, -t])
    f = np.column_stack([10.0 * t, 0.0 * t, 100.0 + t])
    got = assumed_forces(CompensationRecord("twin", t, f), Stream(t, p))
    assert got is not None
    np.testing.assert_allclose(got.p_sheet_m, p)
    np.testing.assert_allclose(got.f_sheet_n, f)
    assert assumed_forces(None, Stream(t, p)) is None
