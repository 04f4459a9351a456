"""Shared, session-scoped fixtures: one nominal twin, one clean lab run and its replay; the dynamic plant's
neutral groove runs and the cell learned from two of them (`made_once`: made by one xdist worker, read by both).

A full twin simulation of the groove takes ~0.5 s, so the expensive objects are built once per session and
shared. Tests must not mutate them (no `set_joint_stiffness` on `twin_nominal.model`, no writes into
`clean_run_dir` or a folder `made_once` gives): copy first.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Callable
from pathlib import Path

#: One BLAS thread per test process, set before numpy loads OpenBLAS (xdist's workers inherit it): `make test` runs
#: a worker per core, and two workers of 2 OpenBLAS threads each on 2 cores spin against each other (the discrepancy
#: search, the sheet learner: 2-5x slower per test, ~30 % more CPU time over the suite). A value set outside is kept.
#: The doc guards run again under the machine's thread count and another kernel (tests/test_doc_guards_blas.py).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import pytest
from cli_refusal import cli_out

from twin.analysis.replay import ReplayResult, replay
from twin.cli import main
from twin.lab.virtual import nominal_commanded
from twin.process.toolpath.groove import groove_path
from twin.runs.format import Run
from twin.runs.read import read_run
from twin.sim.quasi_static import Twin
from twin.sim.spec import TwinSpec

CLEAN_SEED = 1


@pytest.fixture(scope="session")
def twin_nominal() -> Twin:
    """The nominal twin (no effects, model stiffness). Shared: do not change its model."""
    return Twin(TwinSpec())


@pytest.fixture(scope="session")
def nominal_path() -> tuple[np.ndarray, np.ndarray]:
    """The thesis groove as a commanded path: times [s] and sheet-frame tool tip [m]."""
    return nominal_commanded()


@pytest.fixture(scope="session")
def first_pass_path() -> tuple[np.ndarray, np.ndarray]:
    """Only the first pass of the groove (142 samples, 70 mm stroke, 1 mm down): a cheap commanded path."""
    path = groove_path()
    keep = path.pass_index == 1
    return path.t_s[keep].copy(), path.p_sheet_m[keep].copy()


@pytest.fixture(scope="session")
def clean_seed() -> int:
    """Seed of the shared clean lab run."""
    return CLEAN_SEED


@pytest.fixture(scope="session")
def clean_run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A lab nominal run without effects, seed 1, written once through `tx200-twin lab`. Read-only."""
    out = tmp_path_factory.mktemp("lab") / "clean"
    code = main(["lab", "--scenario", "nominal", "--seed", str(CLEAN_SEED), "--out", str(out)])
    assert code == 0
    return out


@pytest.fixture(scope="session")
def clean_run(clean_run_dir: Path) -> Run:
    """The clean run, read back with `read_run`."""
    return read_run(clean_run_dir)


@pytest.fixture(scope="session")
def clean_replay(clean_run: Run, twin_nominal: Twin) -> ReplayResult:
    """The clean run replayed on the nominal twin (its `sim` is the twin's simulation of the groove)."""
    return replay(clean_run, twin=twin_nominal)


def _shared_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder every worker of this `pytest -n` run sees (the run's base temp, above each worker's own); the
    base temp itself without xdist."""
    base = tmp_path_factory.getbasetemp()
    root = (base.parent if "PYTEST_XDIST_WORKER" in os.environ else base) / "made-once"
    root.mkdir(parents=True, exist_ok=True)
    return root


@contextlib.contextmanager
def _locked(path: Path):
    """An exclusive lock on `path` across processes (POSIX `flock`; without it, none: each worker makes its own)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def made_once(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str, Callable[[Path], None]], Path]:
    """`made_once(name, make)`: the folder `make(folder)` filled, made once per test session by whichever xdist
    worker asks first (the other waits for it, then reads it). Read-only to the tests: copy before editing. The
    makers are deterministic (the plant and `learn` are), so which worker made it does not matter."""
    root = _shared_root(tmp_path_factory)

    def made(name: str, make: Callable[[Path], None]) -> Path:
        folder = root / name
        with _locked(root / f"{name}.lock"):
            if not (folder / ".made").exists():
                shutil.rmtree(folder, ignore_errors=True)
                folder.mkdir(parents=True)
                make(folder)
                (folder / ".made").write_text("")
        return folder

    return made


@pytest.fixture(scope="session")
def neutral_groove_runs(made_once) -> Callable[[int], Path]:
    """`neutral_groove_runs(seed)`: the dynamic plant's nominal groove run with neutral knobs and that seed
    (`lab --plant dynamic --neutral --scenario nominal --seed SEED`), one per session. Read-only."""

    def run(seed: int) -> Path:
        def make(folder: Path) -> None:
            cli_out(["lab", "--plant", "dynamic", "--neutral", "--scenario", "nominal", "--seed", str(seed),
                     "--out", str(folder / "run")])

        return made_once(f"neutral-groove-{seed}", make) / "run"

    return run


@pytest.fixture(scope="session")
def neutral_groove_cell(made_once, neutral_groove_runs) -> tuple[Path, str]:
    """The cell learned from the neutral groove runs of seeds 1 and 2 (`learn RUN1 RUN2 --write-model cell.json
    --json learn.json`: with the floor it leaves on its own clean runs), once per session: its folder and what
    `learn` printed. Read-only."""
    runs = [str(neutral_groove_runs(seed)) for seed in (1, 2)]

    def make(folder: Path) -> None:
        printed = cli_out(["learn", *runs, "--write-model", str(folder / "cell.json"),
                           "--json", str(folder / "learn.json")])
        (folder / "printed.txt").write_text(printed)

    folder = made_once("neutral-groove-cell-1-2", make)
    return folder, (folder / "printed.txt").read_text()


@pytest.fixture(scope="session")
def lab_cone_run(made_once) -> Path:
    """A 1.5 mm deep cone 30 mm across in 6 levels of 0.25 mm (11 passes), formed in the quasi-static lab, seed 2
    (its tip lags its command), once per session. Read-only."""

    def make(folder: Path) -> None:
        cli_out(["path", "--shape", "cone", "--top-width-mm", "30", "--depth-mm", "1.5", "--step-down-mm", "0.25",
                 "--out", str(folder / "cone.csv")])
        cli_out(["lab", "--scenario", "nominal", "--commanded", str(folder / "cone.csv"), "--seed", "2",
                 "--out", str(folder / "run")])

    return made_once("lab-cone-1.5mm", make) / "run"


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    """A four-sample path CSV in tmp_path (`cli_refusal.TINY`)."""
    from cli_refusal import TINY

    path = tmp_path / "tiny.csv"
    path.write_text(TINY)
    return path


#: The order files start in under xdist (`make test`: `--dist loadfile --no-loadscope-reorder`): first the file
#: that compiles the replay kernels (`twin.sim.compiled`, ~17 s cold on a fresh clone), then files that never run
#: them in this process (measured: their process ends with `replay_loop` uncompiled), longest first, so that the
#: other worker is busy while one compiles and then loads them from numba's cache; then `HEAVY_FILES`; the rest by
#: size, largest first (xdist's own reorder). A file listed here that starts using the kernels only costs that saving.
WARM_FIRST = "tests/test_compiled_replay.py"
NO_KERNEL_FILES = (
    "tests/test_identify_forces_chatter.py", "tests/test_program_structure.py", "tests/test_bad_input_46.py",
    "tests/test_plant_sheet_law2.py", "tests/test_force_validation.py", "tests/test_no_answer.py",
    "tests/test_online_input.py", "tests/test_scan_learning.py", "tests/test_layout.py", "tests/test_clock_sigma.py",
)
#: Files of few but long tests (15-55 s each on the 2-core machine), longest first: ranked by their test count they
#: came last, and the worker left with one ran it alone while the other had nothing left. Early, the many short files
#: after them fill both workers to the end. test_learn.py makes the session's neutral groove runs and cell
#: (`made_once`) before test_sheet_learner.py and test_learning_stacks.py read them, not while they wait on its lock.
HEAVY_FILES = (
    "tests/test_plant_changes.py", "tests/test_learn.py", "tests/test_discrepancy.py", "tests/test_scans.py",
    "tests/test_part_compensation.py", "tests/test_dynamic_twin.py", "tests/test_sheet_learner.py",
    "tests/test_bench.py", "tests/test_cli_any_part.py", "tests/test_doc_guards_blas.py", "tests/test_isf_force.py",
    "tests/test_learning_stacks.py",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under xdist, the file order `WARM_FIRST`, `NO_KERNEL_FILES` and `HEAVY_FILES` describe (a fresh clone's numba
    kernels compiled once, by one worker, while the other works; the long files before the short): each file's
    tests keep their order."""
    if not hasattr(config, "workerinput"):
        return
    counts: dict[str, int] = {}
    for item in items:
        counts[item.nodeid.split("::")[0]] = counts.get(item.nodeid.split("::")[0], 0) + 1
    first = [WARM_FIRST, *NO_KERNEL_FILES, *HEAVY_FILES]

    def rank(item: pytest.Item) -> tuple[int, int]:
        name = item.nodeid.split("::")[0]
        return (first.index(name), 0) if name in first else (len(first), -counts[name])

    items.sort(key=rank)
