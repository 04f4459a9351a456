"""A catalogue of bad inputs: each is refused with exit 2 and a message that names the file, row or option and what
was expected; no input changes and nothing is written (no partial output, no hidden temporary left).

Each case is an argv and the files it needs, made in a fresh folder: `@run` copies a lab run there as `RUN`,
`@cell` the synthetic cell of `test_import_mapping` (its raw exports and `mapping.toml`) with text replaced.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path
from typing import NamedTuple

import pytest
from test_import_mapping import cell  # noqa: F401  (the synthetic cell's fixture)

from twin.cli import main

LATIN1_MU = "x µm".encode("latin-1")  # b"x \xb5m": a Latin-1 vendor header
CSV = "t_s,x_mm,y_mm,z_mm\n0,0,0,0\n1,1,0,-0.5\n2,2,0,-1\n"


class Case(NamedTuple):
    """argv, files (name -> text or bytes; `@run`: a lab run as RUN; `@cell`: (old, new) replacements), needles."""

    argv: list[str]
    files: dict[str, str | bytes | list[tuple[str, str]]]
    needles: tuple[str, ...]


_STL = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 100 0 0\nvertex 0 100 0\nendloop\nendfacet\nendsolid t\n"


def _csv(*rows: str) -> str:
    return "t_s,x_mm,y_mm,z_mm\n" + "\n".join(rows) + "\n"


CASES: dict[str, Case] = {
    # options: the option as typed and its valid range
    "seed-negative": Case(["lab", "--scenario", "nominal", "--seed", "-1", "--out", "r"], {}, ("--seed", ">= 0")),
    "seed-not-integer": Case(["sweep", "--seed", "abc"], {}, ("--seed", "not an integer")),
    "draws-zero": Case(["sweep", "--draws", "0"], {}, ("--draws", ">= 1")),
    "place-candidates-zero": Case(["place", "--candidates", "0"], {}, ("--candidates", ">= 1")),
    "place-ideal-missing": Case(["place", "--ideal", "nope.csv", "--json", "p.json"], {}, ("nope.csv",)),
    "place-ideal-ill-formed": Case(["place", "--ideal", "p.csv", "--json", "p.json"], {"p.csv": "a,b\n1,2\n"},
                                   ("p.csv", "missing column")),
    "place-scheduler-bad": Case(["place", "--ideal", "p.csv", "--scheduler", "nonsense://x", "--json", "p.json"],
                                {"p.csv": CSV}, ("--scheduler nonsense://x", "unknown address scheme", "tcp://HOST")),
    "sweep-scheduler-bad": Case(["sweep", "--draws", "2", "--scheduler", "no-port", "--json", "s.json"], {},
                                ("--scheduler no-port", "missing port", "Dask scheduler")),
    "max-iter-zero": Case(["compensate", "--method", "twin", "--max-iter", "0", "--out", "c.csv"], {},
                          ("--max-iter", ">= 1")),
    "depth-negative": Case(["path", "--out", "p.csv", "--depth-mm", "-5"], {}, ("--depth-mm", "'-5'", "> 0")),
    "depth-1e300": Case(["path", "--out", "p.csv", "--depth-mm", "1e300"], {}, ("--depth-mm", "<= 10000")),
    "feed-nan": Case(["path", "--out", "p.csv", "--feed-mm-s", "nan"], {}, ("--feed-mm-s", "finite")),
    "feed-zero": Case(["path", "--out", "p.csv", "--feed-mm-s", "0"], {}, ("--feed-mm-s", "> 0")),
    "origin-inf": Case(["path", "--out", "p.csv", "--origin-mm", "0", "0", "inf"], {}, ("--origin-mm", "finite")),
    "passes-one": Case(["path", "--out", "p.csv", "--passes", "1"], {}, ("--passes 1", ">= 2")),
    "bottom-longer": Case(["path", "--out", "p.csv", "--bottom-length-mm", "80"], {},
                          ("--bottom-length-mm 80", "shorter than --top-length-mm 70")),
    "spacing-long": Case(["path", "--out", "p.csv", "--spacing-mm", "65"], {},
                         ("--spacing-mm 65", "--bottom-length-mm 61")),
    "wall-angle": Case(["path", "--shape", "cone", "--out", "p.csv", "--wall-angle-deg", "95"], {},
                       ("--wall-angle-deg 95", "(0, 90)")),
    "cone-closes": Case(["path", "--shape", "cone", "--out", "p.csv", "--top-width-mm", "20", "--depth-mm", "60"],
                        {}, ("--top-width-mm", "must exceed")),
    "thickness-zero": Case(["path", "--out", "p.csv", "--thickness-mm", "0"], {}, ("--thickness-mm = 0.0", "> 0")),
    "tool-smaller": Case(["path", "--out", "p.csv", "--thickness-mm", "2", "--tool-radius-mm", "1"], {},
                         ("--tool-radius-mm 1", "--thickness-mm 2", "expected tool radius > thickness")),
    "material": Case(["path", "--out", "p.csv", "--material", "unobtainium"], {},
                     ("--material unobtainium", "AA5086-H111")),
    "robot": Case(["path", "--out", "p.csv", "--robot", "nosuch"], {}, ("'nosuch'", "tx200")),
    "effect-huge": Case(["lab", "--scenario", "nominal", "--seed", "1", "--out", "r", "--effect",
                         "force_scale=1e12"], {}, ("--effect force_scale=1e12", "within [0, 100]")),
    "effect-nan": Case(["lab", "--scenario", "nominal", "--seed", "1", "--out", "r", "--effect", "lost_motion=nan"],
                       {}, ("--effect lost_motion=nan", "finite")),
    "effect-unknown": Case(["lab", "--scenario", "nominal", "--seed", "1", "--out", "r", "--effect", "bogus=1"],
                           {}, ("--effect 'bogus=1'", "unknown effect", "force_scale")),
    "effect-no-value": Case(["lab", "--scenario", "nominal", "--seed", "1", "--out", "r", "--effect",
                             "force_scale"], {}, ("--effect 'force_scale'", "NAME=VALUE")),
    "history-no-symmetry": Case(["compensate", "--method", "twin", "--history", "h.csv", "--out", "c.csv"],
                                {"h.csv": "x\n"}, ("--history h.csv", "--symmetry half|full")),
    "learn-without-stl": Case(["compensate", "--method", "twin", "--learn-from", "RUN", "--out", "c.csv"],
                              {"@run": []}, ("--learn-from", "--target-stl")),
    "learn-twin-without-ideal": Case(["compensate", "--method", "twin", "--target-stl", "d.stl", "--learn-from", "RUN",
                                      "--out", "c.csv"], {"@run": []}, ("--learn-at twin needs --ideal",)),
    "learn-gain-out-of-range": Case(["compensate", "--method", "twin", "--target-stl", "d.stl", "--learn-from", "RUN",
                                     "--learn-gain", "1.5", "--out", "c.csv"], {"@run": []}, ("--learn-gain 1.5",)),
    # outputs: never over an input or another output, never where they cannot be written
    "json-over-meta": Case(["replay", "RUN", "--json", "RUN/meta.json"], {"@run": []},
                           ("--json RUN/meta.json", "input folder RUN_DIR RUN")),
    "model-over-commanded": Case(["identify", "--method", "2", "RUN", "--write-model", "RUN/commanded.csv"],
                                 {"@run": []}, ("--write-model RUN/commanded.csv",)),
    "gcode-over-itself": Case(["path", "--gcode", "g.nc", "--out", "g.nc"], {"g.nc": "G1 X0 Y0 Z0 F600\n"},
                              ("--out g.nc", "input --gcode g.nc")),
    "export-json-over-out": Case(["export", "p.csv", "--json", "X", "--out", "X"], {"p.csv": CSV},
                                 ("--out X", "--json X", "same path")),
    "out-under-a-file": Case(["fe-history", "--out", "f/x.csv"], {"f": "a file\n"},
                             ("--out f/x.csv", "f is a file, not a folder")),
    "json-is-a-folder": Case(["fe-history", "--out", "h.csv", "--json", "d"], {"d/keep": "x\n"},
                             ("--json d is a folder", "expected a file name")),
    "lab-out-holds-input": Case(["lab", "--scenario", "compensated", "--commanded", "D/c.csv", "--seed", "1",
                                 "--out", "D", "--overwrite"], {"D/c.csv": CSV}, ("--out D", "--commanded D/c.csv")),
    # CSV paths: the file, the row and what was expected
    "csv-missing": Case(["export", "none.csv", "--out", "o.csv"], {}, ("none.csv", "file not found",
                                                                       "expected a CSV file")),
    "csv-is-a-folder": Case(["export", "d", "--out", "o.csv"], {"d/keep": "x\n"}, ("d: is a folder",
                                                                                    "expected a CSV file")),
    "csv-symlink-loop": Case(["export", "loop", "--out", "o.csv"], {"@loop": []}, ("loop", "expected a CSV file")),
    "csv-latin1": Case(["export", "p.csv", "--out", "o.csv"],
                       {"p.csv": b"# probe " + LATIN1_MU + b"\n" + CSV.encode()},
                       ("p.csv", "line 1", "b'\\xb5' is not UTF-8")),
    "csv-binary": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": b"\xff\xfe\x00\x01garbage\x80"},
                       ("p.csv", "is not UTF-8")),
    "csv-empty": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": ""}, ("p.csv", "empty", "t_s")),
    "csv-no-columns": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": "a,b\n1,2\n"},
                           ("p.csv", "missing column", "x_m")),
    "csv-text-value": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": _csv("0,0,0,0", "1,abc,0,0")},
                           ("p.csv, row 2", "'abc'", "expected a number")),
    "csv-inf": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": _csv("0,0,0,0", "1,inf,0,0")},
                    ("p.csv, row 2", "finite")),
    "csv-1e300": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": _csv("0,0,0,0", "1,1e300,0,0")},
                      ("p.csv, row 2", "x_mm", "within 100 m")),
    "csv-truncated": Case(["export", "p.csv", "--out", "o.csv"], {"p.csv": _csv("0,0,0,0", "1,1")},
                          ("p.csv, row 2", "truncated")),
    "csv-time-back": Case(["compensate", "--method", "formula", "--ideal", "p.csv", "--out", "c.csv"],
                          {"p.csv": _csv("0,0,0,0", "2,1,0,0", "1,2,0,0")}, ("p.csv", "t_s", "increasing")),
    "csv-both-units": Case(["export", "p.csv", "--out", "o.csv"],
                           {"p.csv": "t_s,x_mm,x_m,y_mm,z_mm\n0,0,0,0,0\n1,1,0.001,0,0\n"},
                           ("p.csv", "'x_mm' [mm] and 'x_m' [m]")),
    # stiffness files (compensate --method formula)
    "k-negative-definite": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                                {"k.json": '{"k_r_n_per_mm": [[-784, 0], [0, -1252]]}'},
                                ("k.json", "not positive definite", "eigenvalues > 0")),
    "k-asymmetric": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                         {"k.json": '{"k_r_n_per_mm": [[784, -900], [0, 1252]]}'},
                         ("k.json", "not symmetric", "within 0.25")),
    "k-nan": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                  {"k.json": '{"k_r_n_per_mm": [[NaN, 0], [0, 1]]}'}, ("k.json", "finite")),
    "k-shape": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                    {"k.json": '{"k_r_n_per_mm": [1, 2, 3]}'}, ("k.json", "expected 2x2")),
    "k-missing-key": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                          {"k.json": '{"k": 1}'}, ("k.json", "missing key 'k_r_n_per_mm'")),
    "k-not-json": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                       {"k.json": "{k_r: 1"}, ("k.json", "not valid JSON")),
    "k-list": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                   {"k.json": "[1, 2]"}, ("k.json", "expected a JSON object")),
    "k-deep": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                   {"k.json": "[" * 100000}, ("k.json", "not valid JSON")),
    "k-latin1": Case(["compensate", "--method", "formula", "--stiffness", "k.json", "--out", "c.csv"],
                     {"k.json": b'{"note": "' + LATIN1_MU + b'"}'}, ("k.json", "line 1", "not UTF-8")),
    # model, process and run files
    "model-list": Case(["compensate", "--method", "twin", "--model", "m.json", "--out", "c.csv"],
                       {"m.json": "[1]"}, ("m.json", "expected a JSON object")),
    "model-format": Case(["compensate", "--method", "twin", "--model", "m.json", "--out", "c.csv"],
                         {"m.json": '{"effects": {}}'}, ("m.json", "tx200-twin-model/1")),
    "process-format": Case(["path", "--out", "p.csv", "--process", "p.toml"], {"p.toml": "thickness_mm = 1\n"},
                           ("p.toml", "tx200-twin-process/1")),
    "process-not-toml": Case(["path", "--out", "p.csv", "--process", "p.toml"], {"p.toml": "= = =\n"},
                             ("p.toml", "not valid TOML")),
    "process-latin1": Case(["path", "--out", "p.csv", "--process", "p.toml"], {"p.toml": b"# " + LATIN1_MU},
                           ("p.toml",)),
    "run-missing": Case(["replay", "RUN"], {}, ("RUN", "run directory not found")),
    "run-meta-binary": Case(["replay", "RUN"], {"@run": [], "RUN/meta.json": b"\x89PNG\r\n\x1a\n\x00"},
                            ("meta.json", "not UTF-8")),
    "run-meta-broken": Case(["replay", "RUN"], {"@run": [], "RUN/meta.json": '{"format": '},
                            ("meta.json", "not valid JSON")),
    "run-commanded-text": Case(["replay", "RUN"], {"@run": [], "RUN/commanded.csv": _csv("0,0,0,0", "1,x,0,0")},
                               ("commanded.csv, row 2", "expected a number")),
    # G-code
    "gcode-binary": Case(["path", "--gcode", "g.nc", "--out", "p.csv"], {"g.nc": b"\x00\xff\xfe G1"},
                         ("g.nc", "not UTF-8")),
    "gcode-word": Case(["path", "--gcode", "g.nc", "--out", "p.csv"], {"g.nc": "G1 X0 Y0 Z0 F600\nG1 X10 Q7\n"},
                       ("g.nc", "line 2", "Q7", "expected")),
    "gcode-no-feed": Case(["path", "--gcode", "g.nc", "--out", "p.csv"], {"g.nc": "G2 X10 Y0 I5\n"},
                          ("g.nc", "line 1", "feed")),
    "gcode-empty": Case(["path", "--gcode", "g.nc", "--out", "p.csv"], {"g.nc": ""},
                        ("g.nc", "at least 2 moves")),
    # meshes and scans
    "stl-garbage": Case(["compensate", "--method", "twin", "--target-stl", "t.stl", "--out", "c.csv"],
                        {"t.stl": b"\x00\x01garbage"}, ("t.stl", "expected an STL")),
    "stl-empty": Case(["compensate", "--method", "twin", "--target-stl", "t.stl", "--out", "c.csv"],
                      {"t.stl": "solid x\nendsolid x\n"}, ("t.stl", "no triangles", "expected an STL")),
    "scan-text": Case(["check", "RUN", "--target-stl", "t.stl", "--scan", "s.xyz"],
                      {"@run": [], "t.stl": _STL, "s.xyz": "1 2 3\n4 five 6\n"}, ("s.xyz", "line 2", "x y z")),
    # import mappings (the synthetic cell)
    "map-misspelt-key": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                             {"@cell": [('delimiter = ";"', 'delimeter = ";"')]},
                             ("mapping.toml", "unknown key 'forces.delimeter'", "did you mean 'forces.delimiter'")),
    "map-unknown-table": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                              {"@cell": [("[run]", "[runn]")]}, ("unknown key 'runn.scenario'", "'run.scenario'")),
    "map-kn-for-n": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                         {"@cell": [('unit = "N"', 'unit = "kN"')]},
                         ("forces.csv", "forces.unit", "expected at most 50000 N")),
    "map-mm-for-m": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                         {"@cell": [('unit = "µm"', 'unit = "m"')]},
                         ("tracker.csv", "tracker.unit", "expected at most 10 m")),
    "map-latin1-undeclared": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                                  {"@cell": [("@latin1", "")]}, ("tracker.csv", "line 1", "not UTF-8", "encoding")),
    "map-bad-encoding": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                             {"@cell": [('delimiter = "tab"', 'delimiter = "tab"\nencoding = "klingon"')]},
                             ("tracker.encoding", "'klingon'", "latin-1")),
    "map-unit": Case(["import", "--mapping", "mapping.toml", "--out", "r"],
                     {"@cell": [('unit = "N"', 'unit = "lbf"')]}, ("forces.unit", "unknown unit 'lbf'")),
    "map-binary": Case(["import", "--mapping", "m.toml", "--out", "r"], {"m.toml": b"\xff\xfe[run]"},
                       ("m.toml", "not UTF-8")),
    "map-not-toml": Case(["import", "--mapping", "m.toml", "--out", "r"], {"m.toml": "[run\n"},
                         ("m.toml", "not valid TOML")),
    "map-missing": Case(["import", "--mapping", "m.toml", "--out", "r"], {}, ("m.toml", "not found")),
}


@pytest.fixture(scope="module")
def lab_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A nominal lab run (the groove, seed 1)."""
    folder = tmp_path_factory.mktemp("lab") / "RUN"
    assert main(["lab", "--scenario", "nominal", "--seed", "1", "--out", str(folder)]) == 0
    return folder


def _make(folder: Path, files: dict[str, str | bytes | list[tuple[str, str]]], run: Path, cell_mapping: Path) -> None:
    for name, content in files.items():
        if name == "@run":
            shutil.copytree(run, folder / "RUN")
        elif name == "@loop":
            os.symlink("loop2", folder / "loop")
            os.symlink("loop", folder / "loop2")
        elif name == "@cell":
            assert isinstance(content, list)
            _cell(folder, cell_mapping, content)
    for name, content in files.items():
        if name.startswith("@"):
            continue
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            target.write_bytes(content)
        else:
            assert isinstance(content, str)
            target.write_text(content, encoding="utf-8")


def _cell(folder: Path, mapping: Path, replacements: list[tuple[str, str]]) -> None:
    for name in ("cmd.csv", "tracker.csv", "forces.csv"):
        shutil.copy(mapping.parent / name, folder / name)
    text = mapping.read_text(encoding="utf-8")
    for old, new in replacements:
        if old == "@latin1":  # the tracker's x column header "x µm", written in Latin-1 (and no UTF-8 BOM)
            latin1_tracker(folder)
            text = text.replace('x = "x"\ny = "y"\nz = "z"\nunit = "µm"', 'x = "x µm"\ny = "y"\nz = "z"\nunit = "µm"')
            continue
        assert old in text, old
        text = text.replace(old, new, 1)
    (folder / "mapping.toml").write_text(text, encoding="utf-8")


def latin1_tracker(folder: Path) -> None:
    """Rewrite the cell's tracker export with a Latin-1 header `t, x µm, y, z` (a vendor's)."""
    lines = (folder / "tracker.csv").read_text(encoding="utf-8-sig").splitlines()
    lines[0] = "t\tx µm\ty\tz"
    (folder / "tracker.csv").write_bytes(("\n".join(lines) + "\n").encode("latin-1"))


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and not p.is_symlink()}


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input_is_refused_by_name_and_costs_no_data(
    name: str, tmp_path: Path, lab_run: Path, cell: Path,  # noqa: F811
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    case = CASES[name]
    _make(tmp_path, case.files, lab_run, cell)
    monkeypatch.chdir(tmp_path)
    before, listing = _digests(tmp_path), _listing(tmp_path)
    try:
        code = main(case.argv)
    except SystemExit as exc:  # argparse's own refusals
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and "np.float64" not in err
    for needle in case.needles:
        assert needle in err, (needle, err)
    assert _digests(tmp_path) == before  # every input unchanged
    assert _listing(tmp_path) == listing  # no output, no hidden temporary


def test_the_catalogue_has_at_least_60_cases() -> None:
    assert len(CASES) >= 60


def test_a_declared_latin1_export_imports(tmp_path: Path, cell: Path) -> None:  # noqa: F811
    _cell(tmp_path, cell, [("@latin1", ""), ('delimiter = "tab"', 'delimiter = "tab"\nencoding = "latin-1"')])
    assert main(["import", "--mapping", str(tmp_path / "mapping.toml"), "--out", str(tmp_path / "r")]) == 0
    assert (tmp_path / "r" / "tracker.csv").is_file()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_folder_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        assert main(["fe-history", "--out", str(folder / "h.csv")]) == 2
    finally:
        folder.chmod(0o755)
    err = capsys.readouterr().err
    assert f"--out {folder / 'h.csv'}" in err and "not writable" in err and ".tmp" not in err
    assert list(folder.iterdir()) == []
