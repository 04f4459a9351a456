"""The package layout: stages import only stages before them, and nobody imports another module's private names.

The stages, in data-flow order (README "Layout"). A module may import its own stage, any earlier stage and
`twin.errors`; `twin/__init__.py` (the public API) may import anything.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import numpy as np
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


def _type_checking_only(tree: ast.AST) -> set[int]:
    """ids of the nodes inside `if TYPE_CHECKING:` blocks (imports for annotations, never run)."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        test = node.test if isinstance(node, ast.If) else None
        if (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
                isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"):
            inside |= {id(inner) for stmt in node.body for inner in ast.walk(stmt)}
    return inside


@functools.cache
def _parsed_text(text: str, filename: str) -> ast.Module:
    return ast.parse(text, filename=filename)


def _parsed(path: Path) -> ast.Module:
    """`path` parsed, once per text a session reads (several checks walk every module; none edits a tree)."""
    return _parsed_text(path.read_text(), str(path))


def _twin_imports(path: Path, *, type_checking: bool = True) -> list[tuple[int, str, list[str]]]:
    """(line, imported module, imported names) of every `twin` import in a file, lazy ones included
    (`type_checking=False`: without those of `if TYPE_CHECKING:` blocks)."""
    tree = _parsed(path)
    skip = set() if type_checking else _type_checking_only(tree)
    found: list[tuple[int, str, list[str]]] = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
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


def _import_graph(files: list[Path]) -> dict[str, set[str]]:
    """Module -> the package modules it imports when it runs (top-level and lazy; `if TYPE_CHECKING:` left out).
    `from pkg import name` is an edge to the submodule `pkg.name` where there is one, else to `pkg`."""
    modules = {_module_name(p) for p in _package_files()} | {_module_name(p) for p in files}
    graph: dict[str, set[str]] = {}
    for path in files:
        edges = graph.setdefault(_module_name(path), set())
        for _, target, names in _twin_imports(path, type_checking=False):
            submodules = {f"{target}.{name}" for name in names} & modules
            edges |= submodules
            if (not names or len(submodules) < len(names)) and target in modules:
                edges.add(target)
    return graph


def _import_circles(files: list[Path]) -> list[str]:
    """One "import circle: a -> b -> a" per strongly connected group of modules of the graph (Tarjan)."""
    graph = _import_graph(files)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    groups: list[set[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        for target in sorted(graph.get(module, ())):
            if target not in index:
                visit(target)
                low[module] = min(low[module], low[target])
            elif target in stack:
                low[module] = min(low[module], index[target])
        if low[module] == index[module]:
            group = set()
            while not group or module not in group:
                group.add(stack.pop())
            if len(group) > 1 or module in graph.get(module, ()):
                groups.append(group)

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return [f"import circle: {' -> '.join(_circle_in(group, graph))}" for group in groups]


def _circle_in(group: set[str], graph: dict[str, set[str]]) -> list[str]:
    """A shortest circle through the first module of a strongly connected group, back to it."""
    start = min(group)
    paths = {start: [start]}
    queue = [start]
    while queue:
        module = queue.pop(0)
        for target in sorted(graph.get(module, set()) & group):
            if target == start:
                return [*paths[module], start]
            if target not in paths:
                paths[target] = [*paths[module], target]
                queue.append(target)
    return sorted(group)  # unreachable for a strongly connected group


def test_no_module_imports_itself_round_a_circle() -> None:
    circles = _import_circles(_package_files())
    assert circles == [], "\n".join(circles)


def test_the_circle_check_catches_a_lazy_circle_and_skips_type_checking() -> None:
    one, two = PACKAGE_DIR / "robot" / "_circle_probe_a_tmp.py", PACKAGE_DIR / "robot" / "_circle_probe_b_tmp.py"
    one.write_text("from twin.robot import _circle_probe_b_tmp\n")
    two.write_text("from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    from twin.robot.dh import dh_fk\n\n\n"
                   "def f():\n    from twin.robot._circle_probe_a_tmp import g\n")
    try:
        circles = _import_circles([one, two])
        graph = _import_graph([one, two])
    finally:
        one.unlink()
        two.unlink()
    assert circles == ["import circle: twin.robot._circle_probe_a_tmp -> twin.robot._circle_probe_b_tmp -> "
                       "twin.robot._circle_probe_a_tmp"], circles
    assert graph["twin.robot._circle_probe_b_tmp"] == {"twin.robot._circle_probe_a_tmp"}


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


# ---------------------------------------------------------------- a robot is data
ROBOT_STAGE = PACKAGE_DIR / "robot"


def _robot_facts() -> tuple[set[str], set[float]]:
    """The names and numbers the shipped robots' descriptions state: no module outside `twin.robot` may write one."""
    from twin.robot.description import load_robot, shipped_robots

    names: set[str] = set()
    numbers: set[float] = set()
    for name in shipped_robots():
        robot = load_robot(name)
        names |= {*robot.joints, *robot.actuators, robot.flange_site, robot.tool_site, robot.ft_site,
                  robot.ft_force_sensor, robot.home_keyframe, *(s for s in (robot.sheet_site,) if s)}
        numbers |= {round(robot.tool_length_m, 9), round(1e3 * robot.tool_length_m, 6)}
        numbers |= {round(v, 9) for v in robot.q_home_rad} | {round(float(np.degrees(v)), 2) for v in robot.q_home_rad}
    return names, numbers - {0.0}


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring nodes of a module, its classes and functions."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def _joint_count_literal(node: ast.AST) -> bool:
    """`(6,)`, `range(6)`, `range(1, 7)`, `np.zeros(6)` / `ones` / `empty` / `full(6, ...)`, `x[:6]`, `x[6:12]`."""
    def is_(n: ast.AST | None, *values: int) -> bool:
        return isinstance(n, ast.Constant) and type(n.value) is int and n.value in values

    if isinstance(node, ast.Tuple) and len(node.elts) == 1 and is_(node.elts[0], 6):
        return True
    if isinstance(node, ast.Call):
        func = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        args = node.args
        if func == "range" and ((len(args) == 1 and is_(args[0], 6)) or (len(args) == 2 and is_(args[1], 7))):
            return True
        if func in ("zeros", "ones", "empty", "full") and args and is_(args[0], 6):
            return True
    return isinstance(node, ast.Slice) and (is_(node.lower, 6, 12) or is_(node.upper, 6, 12))


def _robot_violations(files: list[Path]) -> list[str]:
    names, numbers = _robot_facts()
    bad: list[str] = []
    for path in files:
        if ROBOT_STAGE in path.parents:
            continue
        tree = _parsed(path)
        docs = _docstrings(tree)
        where = str(path.relative_to(PACKAGE_DIR.parent))
        for node in ast.walk(tree):
            line = getattr(node, "lineno", 0)
            if isinstance(node, ast.Constant) and id(node) not in docs:
                if isinstance(node.value, str) and node.value in names:
                    bad.append(f"{where}:{line}: names the robot's {node.value!r} (ask twin.robot.description)")
                elif isinstance(node.value, float) and round(node.value, 9) in numbers:
                    bad.append(f"{where}:{line}: writes the robot's number {node.value!r} (ask twin.robot.description)")
            elif isinstance(node, ast.JoinedStr) and any(
                isinstance(v, ast.Constant) and isinstance(v.value, str) and v.value.rstrip("_").endswith(("joint", "actuator"))
                for v in node.values
            ):
                bad.append(f"{where}:{line}: builds a joint or actuator name (use RobotDescription.joints/.actuators)")
            elif _joint_count_literal(node):
                bad.append(f"{where}:{line}: a joint count written as a number (use RobotDescription.dof)")
    return bad


def test_only_the_robot_stage_names_a_robot() -> None:
    violations = _robot_violations(_package_files())
    assert violations == [], "\n".join(violations)


def test_the_robot_check_catches_a_joint_name_a_tool_length_and_a_joint_count() -> None:
    bad = PACKAGE_DIR / "sim" / "_robot_probe_tmp.py"
    bad.write_text('"""Docstrings may say joint2 and 0.27494."""\nimport numpy as np\n'
                   'J = "joint2"\nL = 0.27494\nK = np.zeros(6)\nA = [f"actuator{i}" for i in range(1, 7)]\n')
    try:
        violations = _robot_violations([bad])
    finally:
        bad.unlink()
    assert len(violations) == 5, violations
    assert "'joint2'" in violations[0] and "0.27494" in violations[1] and "joint count" in violations[2]


# ---------------------------------------------------------------- stages say what they hold
def _stage_modules(stage: str) -> list[str]:
    folder = PACKAGE_DIR / stage
    modules = [p.stem for p in folder.glob("*.py") if p.stem != "__init__"]
    packages = [p.name + "/" for p in folder.iterdir() if p.is_dir() and (p / "__init__.py").is_file()]
    return sorted(modules + packages)


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_docstring_names_its_modules(stage: str) -> None:
    doc = ast.get_docstring(ast.parse((PACKAGE_DIR / stage / "__init__.py").read_text())) or ""
    missing = [m for m in _stage_modules(stage) if f"`{m}`" not in doc and f"`{m.rstrip('/')}`" not in doc]
    assert missing == [], f"twin/{stage}/__init__.py's docstring does not name its module(s) {missing}"


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_exports_its_own_public_names(stage: str) -> None:
    import importlib

    package = importlib.import_module(f"twin.{stage}")
    if stage == "cli":
        assert callable(package.main)
        return
    names = getattr(package, "__all__", None)
    assert names, f"twin.{stage} has no __all__"
    for name in names:
        assert getattr(package, name) is not None, f"twin.{stage}.{name}"


def test_the_analysis_never_imports_a_lab() -> None:
    bad = [
        f"{p.relative_to(PACKAGE_DIR.parent)}:{line}: imports {target}"
        for p in _package_files()
        if _stage(_module_name(p)) == "analysis"
        for line, target, _ in _twin_imports(p)
        if _stage(target) == "lab"
    ]
    assert bad == [], "the analysis must not share a lab's code (what the twin knows lives in its stages):\n" + "\n".join(bad)


def test_the_public_api_resolves() -> None:
    assert len(twin.__all__) < 60
    for name in twin.__all__:
        assert getattr(twin, name) is not None, name


CLI_MAX_LINES = 1800
CLI_MAX_FUNCTION_LINES = 40


def test_the_cli_is_thin() -> None:
    """twin/cli only parses options and prints reports: the work lives in the stages (`twin/apps/tasks/`)."""
    files = sorted((PACKAGE_DIR / "cli").glob("*.py"))
    total = sum(len(f.read_text().splitlines()) for f in files)
    assert total <= CLI_MAX_LINES, f"twin/cli has {total} lines; move work into a task (twin/apps/tasks/)"
    long = []
    for f in files:
        for node in ast.walk(_parsed(f)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                if length > CLI_MAX_FUNCTION_LINES:
                    long.append(f"{f.name}:{node.lineno} {node.name} ({length} lines)")
    assert long == [], f"functions over {CLI_MAX_FUNCTION_LINES} lines in twin/cli: {long}"
