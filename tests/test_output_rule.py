"""Outputs never over inputs, in every command (`twin.base.outputs.check_outputs`, called by `twin.cli.main`), and
outputs with the umask's permissions.

Each case builds the inputs in a temporary folder, runs the command with an output over an input (or over another
output) and asserts exit 2, a message that names the option as typed and the path, and every file unchanged.
"""

from __future__ import annotations

import argparse
import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

from twin.base.csvio import swap_in_directory, temporary_folder, write_table
from twin.base.jsonio import write_json
from twin.cli import OUTPUT_OPTIONS, build_parser, main
from twin.errors import DataFileError

RUN = {"RUN/meta.json": "{}\n", "RUN/commanded.csv": "t_s,x_mm,y_mm,z_mm\n0,0,0,0\n"}
PATH_CSV = {"p.csv": "t_s,x_mm,y_mm,z_mm\n0,0,0,0\n1,1,0,0\n"}

# command -> (argv with files relative to the test folder, files to make, the option the message must name)
CASES: dict[str, list[tuple[list[str], dict[str, str], str]]] = {
    "info": [(["--robot", "r.toml", "--json", "r.toml"], {"r.toml": "x = 1\n"}, "--json r.toml")],
    "path": [
        (["--gcode", "g.nc", "--out", "g.nc"], {"g.nc": "G1 X0 Y0 Z0\n"}, "--out g.nc"),
        (["--out", "a.csv", "--gcode-out", "a.csv"], {}, "--gcode-out a.csv"),
        (["--out", "a.csv", "--stl-out", "s.stl", "--design-stl", "s.stl"], {}, "--design-stl s.stl"),
        (["--process", "p.toml", "--out", "a.csv", "--json", "p.toml"], {"p.toml": "x = 1\n"}, "--json p.toml"),
    ],
    "fe-history": [(["--out", "f.csv", "--json", "f.csv"], {}, "--json f.csv")],
    "identify": [
        (["--method", "2", "RUN", "--json", "RUN/meta.json"], RUN, "--json RUN/meta.json"),
        (["--method", "2", "RUN", "--write-model", "RUN/commanded.csv"], RUN, "--write-model RUN/commanded.csv"),
        (["--method", "1", "--loads", "l.csv", "--json", "l.csv"], {"l.csv": "fx_n\n1\n"}, "--json l.csv"),
    ],
    "reproduce": [(["--markdown", "r.md", "--json", "r.md"], {}, "--json r.md")],
    "force-validation": [(["--markdown", "r.md", "--json", "r.md"], {}, "--json r.md")],
    "springback-scans": [(["--markdown", "r.md", "--json", "r.md"], {}, "--json r.md")],
    "lab": [
        (["--scenario", "compensated", "--commanded", "c.csv", "--seed", "1", "--out", "c.csv"],
         {"c.csv": "t_s,x_mm,y_mm,z_mm\n"}, "--out c.csv"),
        (["--scenario", "compensated", "--commanded", "D/c.csv", "--seed", "1", "--out", "D", "--overwrite"],
         {"D/c.csv": "t_s,x_mm,y_mm,z_mm\n"}, "--out D"),
        (["--scenario", "nominal", "--seed", "1", "--out", "o", "--json", "o"], {}, "--json o"),
    ],
    "learn": [
        (["RUN", "--write-model", "RUN/meta.json"], RUN, "--write-model RUN/meta.json"),
        (["RUN", "--write-model", "m.json", "--json", "m.json"], RUN, "--json m.json"),
    ],
    "replay": [
        (["RUN", "--json", "RUN/meta.json"], RUN, "--json RUN/meta.json"),
        (["RUN", "--rrd", "RUN/commanded.csv"], RUN, "--rrd RUN/commanded.csv"),
    ],
    "compensate": [
        (["--method", "twin", "--ideal", "i.csv", "--out", "i.csv"], {"i.csv": "t_s\n"}, "--out i.csv"),
        (["--method", "formula", "--stiffness", "k.json", "--out", "c.csv", "--json", "k.json"],
         {"k.json": "{}\n"}, "--json k.json"),
    ],
    "check": [
        (["RUN", "--json", "RUN/meta.json"], RUN, "--json RUN/meta.json"),
        (["RUN", "--ideal", "i.csv", "--figure", "i.csv"], {**RUN, "i.csv": "t_s\n"}, "--figure i.csv"),
    ],
    "bench": [(["--json", "b.json", "--readme", "b.json"], {}, "--readme b.json")],
    "sweep": [
        (["--ideal", "i.csv", "--json", "i.csv"], {"i.csv": "t_s\n"}, "--json i.csv"),
        (["--figure", "f.png", "--json", "f.png"], {}, "--json f.png"),
    ],
    "place": [
        (["--ideal", "i.csv", "--json", "i.csv"], {"i.csv": "t_s\n"}, "--json i.csv"),
        (["--ideal", "i.csv", "--figure", "m.png", "--json", "m.png"], {"i.csv": "t_s\n"}, "--json m.png"),
    ],
    "discrepancy": [
        (["RUN", "--model-out", "RUN/meta.json"], RUN, "--model-out RUN/meta.json"),
        (["RUN", "--report", "RUN"], RUN, "--report RUN"),
    ],
    "demo": [(["--out", "D", "--readme", "D"], {}, "--readme D")],
    "import": [
        (["--mapping", "m.toml", "--out", "r", "--json", "m.toml"], {"m.toml": "x = 1\n"}, "--json m.toml"),
        (["--mapping", "cell/m.toml", "--out", "cell"], {"cell/m.toml": "x = 1\n"}, "--out cell"),
    ],
    "export": [
        (["p.csv", "--out", "p.csv"], PATH_CSV, "--out p.csv"),
        (["p.csv", "--json", "X", "--out", "X"], PATH_CSV, "--out X"),
        (["p.csv", "--run", "RUN", "--out", "RUN/commanded.csv"], {**PATH_CSV, **RUN}, "--out RUN/commanded.csv"),
    ],
    "robots": [(["--file", "r.toml", "--markdown", "r.toml"], {"r.toml": "x = 1\n"}, "--markdown r.toml")],
    "materials": [(["--file", "m.toml", "--json", "m.toml"], {"m.toml": "x = 1\n"}, "--json m.toml")],
    "online": [(["--serve", "rsi", "--port", "0", "--model", "m.json", "--json", "m.json"], {"m.json": "{}"},
                "--json m.json")],
}
NO_CASE = {"calibrate": "its only path is its one output, --json"}


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_every_command_with_an_output_has_a_case() -> None:
    with_output = {name for name, sub in _commands().items()
                   if any(a.option_strings and a.option_strings[-1] in OUTPUT_OPTIONS for a in sub._actions)}
    assert with_output == set(CASES) | set(NO_CASE)


def test_every_option_that_writes_is_an_output_option() -> None:
    for name, sub in _commands().items():
        for action in sub._actions:
            words = (action.help or "").lower()
            writes = words.startswith(("write", "also write", "also save", "output", "compensated path"))
            option = action.option_strings[-1] if action.option_strings else action.dest
            assert not writes or option in OUTPUT_OPTIONS, (name, option, action.help)


@pytest.mark.parametrize(
    ("command", "argv", "files", "named"),
    [(command, *case) for command, cases in CASES.items() for case in cases],
    ids=[f"{command}-{i}" for command, cases in CASES.items() for i in range(len(cases))],
)
def test_an_output_over_an_input_or_another_output_is_refused(
    command: str, argv: list[str], files: dict[str, str], named: str, tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    before = _digests(tmp_path)
    assert main([command, *argv]) == 2
    err = capsys.readouterr().err
    assert f"tx200-twin {command}: error: " in err and named in err, err
    assert "Traceback" not in err
    assert _digests(tmp_path) == before  # nothing replaced, nothing new


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_atomic_outputs_take_the_umask_mode(mask: int, tmp_path: Path) -> None:
    old = os.umask(mask)
    try:
        table = write_table(tmp_path / "new" / "t.csv", {"x_mm": np.arange(3.0)})
        document = write_json(tmp_path / "j.json", {"a": 1})
        plain = tmp_path / "plain.txt"
        plain.write_text("x")
        plain_folder = tmp_path / "plain_folder"
        plain_folder.mkdir()
        assert main(["lab", "--scenario", "loadtest", "--seed", "1", "--out", str(tmp_path / "load.csv")]) == 0
        folder = temporary_folder(tmp_path / "swapped")  # how run directories and VAL3 folders are written
        swap_in_directory(folder, tmp_path / "swapped")
    finally:
        os.umask(old)
    for file in (table, document, tmp_path / "load.csv"):
        assert file.stat().st_mode & 0o777 == plain.stat().st_mode & 0o777 == 0o666 & ~mask
    for made in (tmp_path / "new", tmp_path / "swapped"):
        assert made.stat().st_mode & 0o777 == plain_folder.stat().st_mode & 0o777 == 0o777 & ~mask


def test_a_failed_write_names_the_target_not_the_temporary(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("a file where a folder should be")
    for write in (lambda target: write_table(target, {"x_mm": np.arange(2.0)}),
                  lambda target: write_json(target, {"a": 1})):
        target = tmp_path / "f" / "out.csv"
        with pytest.raises(DataFileError) as info:
            write(target)
        assert info.value.path == target and ".tmp" not in str(info.value) and "expected a writable" in str(info.value)
    with pytest.raises(DataFileError, match="is a folder; expected a file name"):
        write_json(tmp_path, {"a": 1})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]
