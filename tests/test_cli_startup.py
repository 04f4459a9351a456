"""`tx200-twin` starts without the heavy libraries: building the parser and parsing a light command's options
import none of MuJoCo, numba, scipy, matplotlib, rerun or Dask (each in a fresh interpreter; no timings here, the
ratio to `import numpy` is in `tx200-twin bench`)."""

from __future__ import annotations

import ast
import subprocess
import sys

import pytest

HEAVY = ("mujoco", "numba", "scipy", "matplotlib", "rerun", "dask", "distributed")


def _loaded_after(code: str) -> list[str]:
    """The heavy libraries a fresh interpreter has executed after `code` (a lazy placeholder does not count)."""
    probe = (
        f"import sys\n{code}\n"
        "loaded = [m for m in sys.modules if m.split('.')[0] in " + repr(HEAVY) + "\n"
        "          and getattr(sys.modules[m], '__spec__', None) is not None\n"
        "          and type(sys.modules[m].__spec__.loader).__name__ != 'LazyLoader']\n"
        "print(sorted({m.split('.')[0] for m in loaded}))"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return list(ast.literal_eval(done.stdout.strip().splitlines()[-1]))


def test_building_the_parser_imports_no_heavy_library() -> None:
    assert _loaded_after("from twin.cli import build_parser; build_parser()") == []


@pytest.mark.parametrize("argv", [
    ["path", "--shape", "cone", "--top-width-mm", "80", "--depth-mm", "20", "--out", "c.csv"],
    ["export", "c.csv", "--format", "csv", "--out", "c_out.csv"],
    ["import", "--mapping", "cell/mapping.toml", "--out", "runs/cell1"],
    ["compensate", "--method", "twin", "--ideal", "c.csv", "--out", "x.csv"],
    ["place", "--ideal", "c.csv", "--scheduler", "tcp://127.0.0.1:8786", "--json", "p.json"],
])
def test_parsing_a_command_imports_no_heavy_library(argv: list[str]) -> None:
    code = f"from twin.cli import build_parser; args = build_parser().parse_args({argv!r}); assert args._run"
    assert _loaded_after(code) == []


def test_help_lists_every_command_and_the_public_api_is_still_there(capsys: pytest.CaptureFixture[str]) -> None:
    from twin.cli import COMMANDS, main

    with pytest.raises(SystemExit) as done:
        main(["--help"])
    assert done.value.code == 0
    shown = capsys.readouterr().out
    assert all(name in shown for name in COMMANDS)
    import twin

    assert callable(twin.compensate_twin) and callable(twin.replay)


def test_version_names_the_installed_package_and_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    from importlib import metadata

    from twin.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"tx200-twin {metadata.version('tx200-twin')}\n"
    assert "importlib.metadata" not in _loaded_after_names("from twin.cli import build_parser; build_parser()")


def _loaded_after_names(code: str) -> list[str]:
    """Every module a fresh interpreter holds after `code`."""
    done = subprocess.run([sys.executable, "-c", f"import sys\n{code}\nprint(sorted(sys.modules))"],
                          capture_output=True, text=True, check=True)
    return list(ast.literal_eval(done.stdout.strip().splitlines()[-1]))
