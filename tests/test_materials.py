"""The material library and a user's materials file: every number cited, names as people write them, bad input
named by its key; the hardening laws."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from doc_numbers import quoted

from twin.cli import main
from twin.errors import DataFileError, InputError
from twin.process.description import Process
from twin.process.material.file import material, read_material_file, shipped_library, shipped_materials
from twin.process.material.hardening import HardeningLaw
from twin.process.material.library import NUMBER_FIELDS, Material

LIBRARY = ("AA1050-O", "AA3003-O", "AA5086-H111", "AA5754-O", "AA6061-T6", "AA7075-O", "DC01", "DC04", "AISI 304",
           "Ti Grade 2")


def test_the_library_holds_the_ten_materials() -> None:
    assert list(shipped_materials()) == list(LIBRARY)


def test_every_number_of_the_library_names_a_source_of_its_bibliography() -> None:
    library = shipped_library()
    for item in library.materials.values():
        assert item.given(), item.name
        for name in item.given():
            key = item.source_of(name)
            assert key is not None, f"{item.name}.{name} has no source"
            source = library.sources[key]
            assert source.citation and source.where, key
    assert library.cited() == sorted(library.sources), "every entry of [sources] is cited (a number or a note)"


def test_the_library_is_plausible() -> None:
    for item in shipped_materials().values():
        if item.yield_strength_mpa is not None:
            assert item.yield_strength_mpa <= item.tensile_strength_mpa
        if item.hardening is not None:  # the law rises with strain
            sigma = item.hardening.stress_mpa(np.array([0.01, 0.1, 0.3]))
            assert np.all(np.diff(sigma) > 0), item.name


def test_the_process_default_is_the_librarys_aa5086_h111() -> None:
    assert material("AA5086-H111").tensile_strength_mpa == Process().tensile_strength_mpa == 275.0
    assert Process().material == "AA5086-H111"


@pytest.mark.parametrize("name", ["AA5086-H111", "5086-H111", "EN AW-5086-H111", "AA 5086 H111", "aa5086h111",
                                  "EN AW 5086 H111", "en-aw-5086-h111"])
def test_aluminium_dialects_name_one_material(name: str) -> None:
    assert material(name).name == "AA5086-H111"


@pytest.mark.parametrize(("name", "expected"), [("ais i304", "AISI 304"), ("AISI-304", "AISI 304"),
                                                ("ti grade 2", "Ti Grade 2"), ("dc04", "DC04"), ("1050-O", "AA1050-O")])
def test_other_spellings(name: str, expected: str) -> None:
    assert material(name).name == expected


def test_an_unknown_material_lists_the_library() -> None:
    with pytest.raises(InputError, match="unknown material 'Unobtainium'") as caught:
        material("Unobtainium")
    assert all(name in str(caught.value) for name in LIBRARY)
    with pytest.raises(InputError, match="did you mean AA6061-T6"):
        material("AA6061")


# ---------------------------------------------------------------- hardening laws
def test_the_three_laws() -> None:
    assert HardeningLaw("hollomon", k_mpa=400.0, n=0.2).stress_mpa(0.1) == pytest.approx(400 * 0.1**0.2)
    assert HardeningLaw("swift", k_mpa=400.0, eps0=0.01, n=0.2).stress_mpa(0.1) == pytest.approx(400 * 0.11**0.2)
    voce = HardeningLaw("voce", sigma0_mpa=100.0, q_mpa=200.0, b=5.0)
    assert voce.m == 1.0 and voce.stress_mpa(0.0) == 100.0
    assert voce.stress_mpa(0.2) == pytest.approx(100 + 200 * (1 - math.exp(-1.0)))
    assert voce.stress_mpa(np.array([0.0, 1e3])) == pytest.approx([100.0, 300.0])
    assert "exp(-5·ε)" in voce.formula()


@pytest.mark.parametrize(("table", "message"), [
    ({"kind": "ludwik"}, "expected one of"),
    ({"kind": "hollomon", "k_mpa": 400.0}, "needs n"),
    ({"kind": "hollomon", "k_mpa": 400.0, "n": 0.2, "b": 3.0}, "takes no"),
    ({"kind": "hollomon", "k_mpa": 4e8, "n": 0.2}, "looks like Pa; expected MPa"),
    ({"kind": "swift", "k_mpa": 400.0, "eps0": -0.1, "n": 0.2}, "> 0"),
    ({"kind": "voce", "sigma0_mpa": 100.0, "q_mpa": 200.0, "b": 5.0, "m": 2.0}, r"\(0, 1\]"),
])
def test_bad_laws_name_the_parameter(table: dict[str, object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        HardeningLaw.from_mapping(table)


def test_a_negative_strain_is_refused() -> None:
    with pytest.raises(InputError, match="strain"):
        HardeningLaw("hollomon", k_mpa=400.0, n=0.2).stress_mpa(-0.1)


# ---------------------------------------------------------------- a user's materials file
USER = """
[sources.mine]
citation = "Our lab, tensile tests of coil 42, 2026"
where = "report TT-42, table 1"

[materials.MyAl]
tensile_strength_mpa = 180.0
yield_strength_mpa = 90.0
hardening = { kind = "hollomon", k_mpa = 350.0, n = 0.22 }
[materials.MyAl.sources]
tensile_strength_mpa = "mine"

[materials."My Steel"]
tensile_strength_mpa = 320
aliases = ["MS-1"]
"""


def test_a_user_file_with_several_materials_and_optional_fields_left_out(tmp_path: Path) -> None:
    file = tmp_path / "mine.toml"
    file.write_text(USER)
    mine = read_material_file(file)
    assert list(mine) == ["MyAl", "My Steel"]
    assert mine["MyAl"].yield_strength_mpa == 90.0 and mine["MyAl"].youngs_modulus_gpa is None
    assert mine["MyAl"].source_of("tensile_strength_mpa") == "mine" and mine["MyAl"].source_of("hardening") is None
    assert material("ms1", mine) is mine["My Steel"]
    assert material("AA5086-H111", mine).tensile_strength_mpa == 275.0  # the library behind the user's


@pytest.mark.parametrize(("table", "message"), [
    ("yield_strength_mpa = 90.0", "missing tensile_strength_mpa"),
    ("tensile_strength_mpa = 180e6", r"materials.X.tensile_strength_mpa = 180000000.0: looks like Pa; expected MPa"),
    ("tensile_strength_mpa = -180.0", "materials.X.tensile_strength_mpa = -180.0: expected a number > 0"),
    ("tensile_strength_mpa = 0", "materials.X.tensile_strength_mpa = 0: expected a number > 0"),
    ("tensile_strength_mpa = 180.0\npoisson_ratio = 0.6", r"materials.X.poisson_ratio = 0.6: expected Poisson's ratio in \(0, 0.5\)"),
    ("tensile_strength_mpa = 180.0\npoisson_ratio = 0.0", "materials.X.poisson_ratio"),
    ("tensile_strength_mpa = 180.0\nyoungs_modulus_gpa = 70000.0", "youngs_modulus_gpa = 70000.0: looks like MPa"),
    ("tensile_strength_mpa = 180.0\ndensity_kg_m3 = 2.7", "density_kg_m3 = 2.7: looks like g/cm³"),
    ("tensile_strength_mpa = 180.0\nyield_strength_mpa = 200.0", "R_p0.2 <= R_m"),
    ("tensile_strength_mpa = 180.0\nyield_strenght_mpa = 90.0", r"unknown key\(s\) \['yield_strenght_mpa'\]"),
    ("tensile_strength_mpa = '180'", "expected a finite number"),
    ("tensile_strength_mpa = 180.0\nhardening = { kind = 'hollomon', k_mpa = 350.0 }", "materials.X.hardening: .*needs n"),
    ("tensile_strength_mpa = 180.0\nsources = { tensile_strength_mpa = 'nowhere' }", "not an entry of \\[sources\\]"),
    ("tensile_strength_mpa = 180.0\nsources = { density_kg_m3 = 'mine' }", "does not give"),
])
def test_bad_user_materials_name_the_file_and_the_key(tmp_path: Path, table: str, message: str) -> None:
    file = tmp_path / "bad.toml"
    file.write_text(f'[sources.mine]\ncitation = "c"\nwhere = "w"\n\n[materials.X]\n{table}\n')
    with pytest.raises(DataFileError, match=message) as caught:
        read_material_file(file)
    assert str(caught.value).startswith(str(file))


def test_a_file_without_materials_or_toml(tmp_path: Path) -> None:
    file = tmp_path / "empty.toml"
    file.write_text("[sources]\n")
    with pytest.raises(DataFileError, match=r"no \[materials.NAME\] table"):
        read_material_file(file)
    file.write_text("materials = [")
    with pytest.raises(DataFileError, match="not valid TOML"):
        read_material_file(file)
    with pytest.raises(DataFileError, match="file not found"):
        read_material_file(tmp_path / "missing.toml")


def test_a_material_in_python_is_validated() -> None:
    with pytest.raises(InputError, match=r"tensile_strength_mpa = 275000000\.0: looks like Pa; expected MPa"):
        Material("X", 275e6)
    with pytest.raises(InputError, match="poisson_ratio"):
        Material("X", 275.0, poisson_ratio=0.5)
    with pytest.raises(InputError, match="does not give"):
        Material("X", 275.0, sources=(("density_kg_m3", "mine"),))
    assert hash(Material("X", 275.0)) == hash(Material("X", 275))


# ---------------------------------------------------------------- the command
def test_materials_json_lists_the_library_with_its_sources(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["materials", "--json", "-"]) == 0
    captured = capsys.readouterr()
    payload = json.loads(captured.out)
    assert [m["name"] for m in payload["materials"]] == list(LIBRARY)
    for item in payload["materials"]:
        assert set(NUMBER_FIELDS) <= set(item) and "hardening" in item
        for name, key in item["sources"].items():
            assert item[name] is not None and key in payload["sources"]
        assert item["tensile_strength_mpa"] is not None
    assert all(entry["citation"] and entry["where"] for entry in payload["sources"].values())
    assert "R_m [MPa]" in captured.err and "sources:" in captured.err  # the table, on stderr beside JSON on stdout


def test_materials_lists_a_user_file_and_refuses_a_bad_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    file = tmp_path / "mine.toml"
    file.write_text(USER)
    assert main(["materials", "--file", str(file)]) == 0
    out = capsys.readouterr().out
    assert "MyAl" in out and "180 [mine]" in out and "[mine] Our lab" in out
    file.write_text("[materials.X]\ntensile_strength_mpa = 2.7e8\n")
    assert main(["materials", "--file", str(file)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tx200-twin materials: error: ") and "materials.X.tensile_strength_mpa" in err
    assert "looks like Pa; expected MPa" in err and "Traceback" not in err


def test_the_thesis_voce_law_necks_where_the_docs_say() -> None:
    """docs/process.md: the thesis's Voce law (AA5086-H111's hardening) necks at an engineering R_m of about
    288 MPa: the largest true stress × exp(-true strain) (Considère), on a grid written here."""
    law = material("AA5086-H111").hardening
    assert law is not None
    strain = np.linspace(0.0, 2.0, 200_001)
    r_m = float(np.max(law.stress_mpa(strain) * np.exp(-strain)))
    quoted("process.md", "the thesis's Voce law necks at about", 1)[0].check(r_m)
