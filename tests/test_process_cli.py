"""The process as the user's: process files, `--process/--material/--thickness-mm/--tool-radius-mm` on `path`, `lab`
(both plants), `compensate`, `replay` and `discrepancy`, the process recorded in runs and model files, and every
bad input ending the command with exit code 2 and a message naming the option or the key."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from twin.base.csvio import write_table
from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.process.description import Process
from twin.process.force.isf_params import steady_fz_n
from twin.process.material.file import material
from twin.process.process_file import process_for, read_process_file
from twin.process.toolpath.groove import groove_path
from twin.runs.format import run_process
from twin.sim.model_file import read_model_file, write_model_file
from twin.sim.spec import TwinSpec

ALU_15 = {"material": "AA1050-O", "tensile_strength_mpa": 77.0, "thickness_mm": 1.5, "tool_radius_mm": 7.5,
          "tool_friction": 0.1}
USER_MATERIALS = """
[materials.MyAl]
tensile_strength_mpa = 180.0
poisson_ratio = 0.33
"""


def run_json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    """Run `tx200-twin ARGV --json -` (exit 0) and return the JSON."""
    capsys.readouterr()
    assert main([*argv, "--json", "-"]) == 0
    payload: dict[str, Any] = json.loads(capsys.readouterr().out)
    return payload


def fails(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run `tx200-twin ARGV`, expect exit code 2 and a message (no traceback); return stderr."""
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tx200-twin {argv[0]}: error: ") and "Traceback" not in err, err
    return err


def process_file(folder: Path, text: str, name: str = "process.toml") -> Path:
    path = folder / name
    path.write_text('format = "tx200-twin-process/1"\n' + text)
    return path


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("process")


@pytest.fixture(scope="module")
def cone(work: Path) -> Path:
    out = work / "cone.csv"
    assert main(["path", "--shape", "cone", "--depth-mm", "3", "--top-width-mm", "30", "--no-reach-check",
                 "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def short_groove(work: Path) -> Path:
    """The groove's first pass as a commanded path (cheap)."""
    path = groove_path()
    keep = path.pass_index == 1
    out = work / "short.csv"
    write_table(out, {"t_s": path.t_s[keep], **{f"{a}_mm": 1e3 * path.p_sheet_m[keep, i] for i, a in enumerate("xyz")}})
    return out


@pytest.fixture(scope="module")
def cnc_run(work: Path, cone: Path) -> Path:
    """A cone formed on the rigid CNC in AA1050-O, 1.5 mm."""
    out = work / "cnc_cone"
    assert main(["lab", "--scenario", "cnc", "--commanded", str(cone), "--material", "AA1050-O", "--thickness-mm",
                 "1.5", "--seed", "1", "--out", str(out), "--json", str(work / "cnc.json")]) == 0
    return out


# ---------------------------------------------------------------- the lab records, the replay reads
def test_the_cnc_forms_any_path_with_the_declared_process(cnc_run: Path, work: Path) -> None:
    meta = json.loads((cnc_run / "meta.json").read_text())
    assert meta["process"] == ALU_15
    assert meta["force_model"] == "isf" and meta["scenario"] == "cnc"
    assert (cnc_run / "part_scan.csv").is_file() and (cnc_run / "part_profile.csv").is_file()
    summary = json.loads((work / "cnc.json").read_text())
    assert summary["process"] == {**ALU_15, "force_model": "isf"} and summary["formed_depth_mm"] > 1.0


def test_replay_uses_the_recorded_process_and_flags_override_it(
    cnc_run: Path, work: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_json(["replay", str(cnc_run)], capsys)["process"] == {**ALU_15, "force_model": "isf"}
    thinner = run_json(["replay", str(cnc_run), "--thickness-mm", "1.2"], capsys)["process"]
    assert thinner["material"] == "AA1050-O" and thinner["thickness_mm"] == 1.2
    steel = process_file(work, 'material = "AISI 304"\ntool_radius_mm = 5\n', "steel.toml")
    declared = run_json(["replay", str(cnc_run), "--process", str(steel)], capsys)["process"]
    assert declared == {**ALU_15, "material": "AISI 304", "tensile_strength_mpa": 505.0, "tool_radius_mm": 5.0,
                        "force_model": "isf"}
    flags_win = run_json(["replay", str(cnc_run), "--process", str(steel), "--material", "dc04"], capsys)["process"]
    assert flags_win["material"] == "DC04" and flags_win["tool_radius_mm"] == 5.0


def test_a_run_without_a_recorded_process_still_replays(cnc_run: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    old = tmp_path / "old_run"
    old.mkdir()
    for file in cnc_run.iterdir():
        (old / file.name).write_bytes(file.read_bytes())
    meta = json.loads((old / "meta.json").read_text())
    del meta["process"]
    (old / "meta.json").write_text(json.dumps(meta))
    replayed = run_json(["replay", str(old)], capsys)["process"]
    assert replayed["material"] == "AA5086-H111" and replayed["thickness_mm"] == 1.0
    assert run_process(meta, Process(thickness_m=2e-3)) == Process(thickness_m=2e-3)


def test_a_bad_recorded_process_names_the_key(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match=r"meta.json: process.thickness_mm = -1: expected a finite length > 0"):
        run_process({"process": {"thickness_mm": -1}}, Process(), tmp_path / "meta.json")


def test_lab_nominal_on_both_plants_records_a_process_file(
    work: Path, short_groove: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    declared = process_file(work, 'material = "AA5754-O"\nthickness_mm = 0.8\ntool_friction = 0.15\n', "alu.toml")
    for plant in ([], ["--plant", "dynamic", "--neutral"]):
        out = work / f"nominal{len(plant)}"
        capsys.readouterr()
        assert main(["lab", *plant, "--scenario", "nominal", "--commanded", str(short_groove), "--seed", "1",
                     "--process", str(declared), "--out", str(out)]) == 0
        assert "note: the 'table' force model plays back the FE history's forces" in capsys.readouterr().err
        meta = json.loads((out / "meta.json").read_text())
        assert meta["process"] == {"material": "AA5754-O", "tensile_strength_mpa": 190.0, "thickness_mm": 0.8,
                                   "tool_radius_mm": 7.5, "tool_friction": 0.15}


def test_compensate_path_and_discrepancy_take_the_process(
    work: Path, short_groove: Path, cnc_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    declared = process_file(work, 'material = "AA6061-T6"\nforce_model = "isf"\n', "isf.toml")
    summary = run_json(["compensate", "--method", "twin", "--ideal", str(short_groove), "--out",
                        str(work / "cmd.csv"), "--process", str(declared), "--tool-radius-mm", "6"], capsys)
    assert summary["force_model"] == "isf"  # the file's force model, for `--force-model auto`
    assert summary["process"] == {"material": "AA6061-T6", "tensile_strength_mpa": 310.0, "thickness_mm": 1.0,
                                  "tool_radius_mm": 6.0, "tool_friction": 0.1}
    path = run_json(["path", "--shape", "cone", "--depth-mm", "2", "--top-width-mm", "30", "--no-reach-check",
                     "--material", "Ti Gr 2", "--tool-radius-mm", "5", "--out", str(work / "p.csv")], capsys)
    assert path["process"]["material"] == "Ti Grade 2" and path["process"]["tool_radius_mm"] == 5.0
    assert path["steady_fz_n"] == [pytest.approx(steady_fz_n(process_for("Ti Grade 2", tool_radius_m=5e-3),
                                                           1e-3 * path["step_down_mm"], 45.0))] * 2
    vwa = run_json(["path", "--shape", "vwa-cone", "--depth-mm", "2", "--no-reach-check", "--material", "DC04",
                    "--out", str(work / "v.csv")], capsys)
    top, bottom = vwa["steady_fz_n"]
    assert top == pytest.approx(steady_fz_n(process_for("DC04"), 1e-3 * vwa["step_down_mm"], vwa["wall_angle_deg"][0]))
    assert bottom != top
    assert "steady_fz_n" not in run_json(["path", "--out", str(work / "g.csv"), "--no-reach-check"], capsys)
    found = run_json(["discrepancy", str(cnc_run), "--thickness-mm", "1.4"], capsys)
    assert found["process"] == {**ALU_15, "thickness_mm": 1.4, "force_model": "isf"}


# ---------------------------------------------------------------- bad input: exit code 2, the option or the key named
@pytest.mark.parametrize(("flags", "message"), [
    (["--material", "Unobtainium"], "--material Unobtainium: unknown material 'Unobtainium'"),
    (["--thickness-mm", "0"], "--thickness-mm = 0.0: expected a finite length > 0"),
    (["--tool-radius-mm", "-7.5"], "--tool-radius-mm = -7.5: expected a finite length > 0"),
    (["--tool-radius-mm", "0.8"], "tool radius 0.8 mm (--tool-radius-mm 0.8) is not larger than the sheet thickness"),
    (["--thickness-mm", "8"], "(--thickness-mm 8): a tool smaller than the sheet is thick"),
])
@pytest.mark.parametrize("command", ["path", "lab", "compensate", "replay", "discrepancy"])
def test_bad_flags_exit_2_naming_the_option(
    command: str, flags: list[str], message: str, work: Path, cnc_run: Path, short_groove: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = {
        "path": ["path", "--out", str(work / "never.csv"), "--no-reach-check"],
        "lab": ["lab", "--scenario", "nominal", "--commanded", str(short_groove), "--seed", "1", "--out",
                str(work / "never_run")],
        "compensate": ["compensate", "--method", "twin", "--ideal", str(short_groove), "--out", str(work / "never.csv")],
        "replay": ["replay", str(cnc_run)],
        "discrepancy": ["discrepancy", str(cnc_run)],
    }[command]
    assert message in fails([*argv, *flags], capsys)
    assert not (work / "never.csv").exists() and not (work / "never_run").exists()


@pytest.mark.parametrize(("text", "message"), [
    ('material = "AA1050-O"\nthickness = 1.5\n', "unknown key(s) ['thickness']; a process file takes ['format', "
                                                 "'material', 'material_file', 'thickness_mm'"),
    ('material = "Unobtainium"\n', "material: unknown material 'Unobtainium'; known: AA1050-O"),
    ("thickness_mm = -1\n", "thickness_mm = -1: expected a finite length > 0"),
    ("tool_radius_mm = 0.5\n", "process.toml: tool_radius_mm) is not larger than the sheet thickness 1 mm (the "
                                "thesis's process): a tool smaller than the sheet is thick"),
    ("tool_friction = -0.1\n", "tool_friction = -0.1: expected a finite friction coefficient >= 0"),
    ('force_model = "magic"\n', "force_model = 'magic': expected 'auto' or a registered force model"),
    ('material = { name = "Mine", tensile_strength_mpa = 275e6 }\n',
     "material.tensile_strength_mpa = 275000000.0: looks like Pa; expected MPa"),
    ('material = { tensile_strength_mpa = 275 }\n', "an inline material needs a name"),
    ('material = "MyAl"\nmaterial_file = "missing.toml"\n', "missing.toml: file not found"),
    ('material_file = "mine.toml"\n', "say which one with material = NAME"),
])
def test_bad_process_files_exit_2_naming_the_file_and_the_key(
    text: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = process_file(tmp_path, text)
    err = fails(["path", "--out", str(tmp_path / "p.csv"), "--no-reach-check", "--process", str(file)], capsys)
    assert message in err and str(tmp_path) in err


def test_a_bad_user_material_in_a_material_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "mine.toml").write_text("[materials.MyAl]\ntensile_strength_mpa = 180.0\npoisson_ratio = 0.7\n")
    file = process_file(tmp_path, 'material = "MyAl"\nmaterial_file = "mine.toml"\n')
    err = fails(["path", "--out", str(tmp_path / "p.csv"), "--no-reach-check", "--process", str(file)], capsys)
    assert "mine.toml: materials.MyAl.poisson_ratio = 0.7: expected Poisson's ratio in (0, 0.5)" in err
    file.write_text("format = 'tx200-twin-process/0'\n")
    assert "format = 'tx200-twin-process/0': expected 'tx200-twin-process/1'" in fails(
        ["path", "--out", str(tmp_path / "p.csv"), "--process", str(file)], capsys)


def test_the_load_test_has_no_sheet(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = fails(["lab", "--scenario", "loadtest", "--seed", "1", "--material", "DC01", "--out",
                 str(tmp_path / "l.csv")], capsys)
    assert "--scenario loadtest" in err and "--material" in err


# ---------------------------------------------------------------- the process file and the model file
def test_a_process_file_with_a_user_material_file_and_an_inline_material(tmp_path: Path) -> None:
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "mine.toml").write_text(USER_MATERIALS)
    declared = process_file(tmp_path, 'material = "myal"\nmaterial_file = "lib/mine.toml"\nthickness_mm = 0.5\n'
                                      'tool_radius_mm = 4\nforce_model = "isf"\n')
    process = read_process_file(declared)
    assert (process.material, process.tensile_strength_mpa, process.force_model) == ("MyAl", 180.0, "isf")
    assert process.thickness_m == pytest.approx(0.5e-3) and process.tool_radius_m == pytest.approx(4e-3)
    inline = process_file(tmp_path, 'material = { name = "Coil 7", tensile_strength_mpa = 199.5, '
                                    'hardening = { kind = "swift", k_mpa = 400, eps0 = 0.01, n = 0.2 } }\n', "in.toml")
    base = Process(thickness_m=2e-3, force_model="isf")
    process = read_process_file(inline, base)
    assert process == Process(material="Coil 7", tensile_strength_mpa=199.5, thickness_m=2e-3, force_model="isf")


def test_process_for_builds_a_process_of_a_material() -> None:
    process = process_for("EN AW-7075-O", thickness_m=1.2e-3, tool_radius_m=5e-3, force_model="isf")
    assert (process.material, process.tensile_strength_mpa) == ("AA7075-O", 228.0)
    assert process_for(material("DC04")).thickness_m == Process().thickness_m
    with pytest.raises(InputError, match=r"thickness_m=0.01\): a tool smaller than the sheet is thick"):
        process_for("DC04", thickness_m=10e-3)
    with pytest.raises(InputError, match="a tool smaller than the sheet is thick"):
        Process(thickness_m=8e-3)


def test_the_model_file_round_trips_a_user_material(tmp_path: Path) -> None:
    inline = process_file(tmp_path, 'material = { name = "Coil 7", tensile_strength_mpa = 199.5 }\nthickness_mm = 1.2\n')
    spec = TwinSpec(process=read_process_file(inline))
    back = read_model_file(write_model_file(tmp_path / "model.json", spec))
    assert back.process == spec.process
    assert (back.process.material, back.process.tensile_strength_mpa) == ("Coil 7", 199.5)


def test_a_model_file_names_a_library_material_alone(tmp_path: Path) -> None:
    model = tmp_path / "model.json"
    model.write_text(json.dumps({"format": "tx200-twin-model/2", "process": {"material": "AISI 304"}}))
    process = read_model_file(model).process
    assert (process.material, process.tensile_strength_mpa) == ("AISI 304", 505.0)
    model.write_text(json.dumps({"format": "tx200-twin-model/2", "process": {"material": "Coil 7"}}))
    with pytest.raises(DataFileError, match=r"process.material: unknown material 'Coil 7'.*process.tensile_strength_mpa"):
        read_model_file(model)
    model.write_text(json.dumps({"format": "tx200-twin-model/2", "process": {"tensile_strength_mpa": 2.75e8}}))
    with pytest.raises(DataFileError, match=r"process\.tensile_strength_mpa = 275000000\.0: looks like Pa"):
        read_model_file(model)


def test_the_documented_examples_read() -> None:
    examples = Path(__file__).resolve().parents[1] / "docs" / "examples"
    process = read_process_file(examples / "process.toml")
    assert (process.material, process.tensile_strength_mpa, process.force_model) == ("Coil 2026-17", 182.0, "isf")
    assert process.thickness_m == pytest.approx(1.2e-3) and process.tool_radius_m == pytest.approx(6e-3)
