"""Export formats (twin/apps/export): each program is parsed back and its path points equal the path to the printed
precision, between an approach point and a retract point at the safe height; the VAL3 application passes the
grammar check and the check rejects what the grammar forbids."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from twin.apps.export import FORMATS, export_path, krl
from twin.apps.export.program import CellSetup, default_cell, euler_xyz_deg, euler_zyx_deg, quaternion_wxyz
from twin.apps.export.val3_check import check_application
from twin.cli import main
from twin.errors import InputError, TwinError
from twin.process.toolpath.groove import GrooveSpec, groove_path
from twin.runs.read import read_commanded_csv
from twin.runs.write import write_path_csv

POSITION_TOL_MM = 0.5e-4 + 1e-9  # 4 decimals
FAST_FEED_MM_S = 2 * 2000.0 / 60.0  # the fixture's pass 2: twice the groove's 2 m/min


@pytest.fixture(scope="module")
def cell() -> CellSetup:
    """The thesis cell (sheet origin and tool from the MuJoCo scene)."""
    return default_cell(tool_mass_kg=3.2)


@pytest.fixture(scope="module")
def path_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 3-pass groove with a varying feed (faster on pass 2), written as `tx200-twin path` does."""
    path = groove_path(GrooveSpec(passes=3, bottom_length_m=0.066))
    t = path.t_s.copy()
    fast = path.pass_index == 2
    dt = np.diff(t, prepend=0.0)
    dt[fast] *= 0.5
    path = type(path)(np.cumsum(dt), path.p_sheet_m, path.pass_index, path.direction)
    return write_path_csv(path, tmp_path_factory.mktemp("path") / "compensated.csv")


@pytest.fixture(scope="module")
def expected(path_csv: Path) -> tuple[np.ndarray, np.ndarray]:
    """The path's points [mm] and the feed into each point [mm/s]."""
    stream = read_commanded_csv(path_csv)
    p = stream.values * 1e3
    feed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(stream.t_s)
    return p, np.concatenate([feed[:1], feed])


@pytest.fixture(scope="module")
def exported(
    path_csv: Path, cell: CellSetup, tmp_path_factory: pytest.TempPathFactory
) -> dict[str, list[Path]]:
    """Every format written once."""
    out = tmp_path_factory.mktemp("programs")
    names = {"val3": "isf", "krl": "isf.src", "rapid": "isf.mod", "gcode": "isf.ngc", "csv": "isf.csv",
             "krl-rsi": "isf_rsi.src", "rapid-egm": "isf_egm.mod", "val3-alter": "isf_alter",
             "rapid-egm-pose": "isf_pose.mod"}
    return {  # the process feed is the fast pass's, so that the program keeps the path's two feeds
        fmt: export_path(path_csv, fmt, out / names[fmt], cell=cell, process_feed_mm_s=FAST_FEED_MM_S).files
        for fmt in FORMATS
    }


def _numbers(text: str) -> list[float]:
    return [float(v) for v in re.findall(r"-?\d+\.?\d*(?:[eE][-+]?\d+)?", text)]


def parse_val3(files: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """pPath points [mm], their orientation [deg], and mPath tmax [mm/s] from the .dtx."""
    dtx = next(f for f in files if f.suffix == ".dtx")
    root = ET.parse(dtx).getroot()
    datas = {d.get("name"): d for d in root.iter() if d.tag.endswith("Data")}
    values = sorted(datas["pPath"], key=lambda v: int(v.get("key", "0")))
    p = np.array([[float(v.get(k, "nan")) for k in ("x", "y", "z")] for v in values])
    r = np.array([[float(v.get(k, "nan")) for k in ("rx", "ry", "rz")] for v in values])
    feeds = sorted(datas["mPath"], key=lambda v: int(v.get("key", "0")))
    return p, r, np.array([float(v.get("tmax", "nan")) for v in feeds])


def parse_krl(files: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """P_PATH[i] = {X, Y, Z, A, B, C} and V_PATH[i] [m/s] from the .dat, in index order (the first point's S and
    T, its configuration, are left out)."""
    dat = next(f for f in files if f.suffix == ".dat").read_text()
    points = dict(
        (int(i), [float(dict(re.findall(r"([XYZABC]) (-?[\d.]+)", body))[k]) for k in "XYZABC"])
        for i, body in re.findall(r"^P_PATH\[(\d+)\]=\{([^}]*)\}$", dat, re.M)
    )
    feeds = dict((int(i), float(v)) for i, v in re.findall(r"^V_PATH\[(\d+)\]=(\S+)$", dat, re.M))
    pose = np.array([points[i] for i in sorted(points)])
    assert sorted(points) == list(range(1, len(points) + 1))
    return pose[:, :3], pose[:, 3:], np.array([feeds[i] for i in sorted(feeds)]) * 1e3


def parse_rapid(files: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """robtarget positions and quaternions, speeddata v_tcp, from the module."""
    text = files[0].read_text()
    targets = re.search(r"robtarget pPath\{(\d+)\}:=\[(.*?)\];", text, re.S)
    speeds = re.search(r"speeddata vPath\{(\d+)\}:=\[(.*?)\];", text, re.S)
    assert targets and speeds
    rows = re.findall(r"\[\[([^\]]*)\],\[([^\]]*)\],\[[^\]]*\],\[[^\]]*\]\]", targets.group(2))
    assert len(rows) == int(targets.group(1))
    p = np.array([_numbers(a) for a, _ in rows])
    q = np.array([_numbers(b) for _, b in rows])
    v = np.array([_numbers(s)[0] for s in re.findall(r"\[([^\]]*)\]", speeds.group(2))])
    return p, q, v


def parse_gcode(files: list[Path]) -> tuple[np.ndarray, np.ndarray]:
    """G1 targets [mm] and the modal feed F [mm/min] -> [mm/s]."""
    points, feeds, feed = [], [], float("nan")
    for line in files[0].read_text().splitlines():
        if not line.startswith("G1 "):  # the G0 to the approach point is not a feed move
            continue
        words = dict((w[0], float(w[1:])) for w in line.split()[1:])
        feed = words.get("F", feed)
        points.append([words["X"], words["Y"], words["Z"]])
        feeds.append(feed / 60.0)
    return np.array(points), np.array(feeds)


def parse_csv(files: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, y, z [mm], rx, ry, rz [deg], feed [mm/s]."""
    lines = files[0].read_text().splitlines()
    header = lines[0].split(",")
    data = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    col = {name: data[:, k] for k, name in enumerate(header)}
    p = np.column_stack([col["x_mm"], col["y_mm"], col["z_mm"]])
    r = np.column_stack([col["rx_deg"], col["ry_deg"], col["rz_deg"]])
    return p, r, col["feed_mm_s"]


def _rx(a: float) -> np.ndarray:
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_val3_points_feeds_and_tool_orientation_read_back(
    exported: dict[str, list[Path]], expected: tuple[np.ndarray, np.ndarray], cell: CellSetup
) -> None:
    p, r, feed = parse_val3(exported["val3"])
    np.testing.assert_allclose(p[1:-1], expected[0], atol=POSITION_TOL_MM)
    np.testing.assert_allclose(feed[2:-1], expected[1][1:], atol=0.5e-3 + 1e-9)
    R = _rx(r[0, 0]) @ _ry(r[0, 1]) @ _rz(r[0, 2])  # Stäubli: Rx Ry Rz
    np.testing.assert_allclose(R, cell.R_sheet_tool, atol=1e-6)


def test_krl_points_feeds_and_orientation_read_back(
    exported: dict[str, list[Path]], expected: tuple[np.ndarray, np.ndarray], cell: CellSetup
) -> None:
    p, abc, feed = parse_krl(exported["krl"])
    np.testing.assert_allclose(p[1:-1], expected[0], atol=POSITION_TOL_MM)
    np.testing.assert_allclose(feed[2:-1], expected[1][1:], atol=0.5e-4 + 1e-9)  # 7 decimals in m/s
    R = _rz(abc[0, 0]) @ _ry(abc[0, 1]) @ _rx(abc[0, 2])  # KUKA: Rz(A) Ry(B) Rx(C)
    np.testing.assert_allclose(R, cell.R_sheet_tool, atol=1e-6)
    src = next(f for f in exported["krl"] if f.suffix == ".src").read_text()
    assert all(f"${v}={v}_DATA[16]" in src for v in ("TOOL", "LOAD", "BASE")) and "  SPL P_PATH[3]" in src
    # the process feed is the fast pass's: the slower passes' moves carry their own feed
    with_feed = {int(i) for i in re.findall(r"P_PATH\[(\d+)\] WITH \$VEL\.CP=V_PATH\[\1\]", src)}
    slower = {i + 1 for i in range(1, len(feed)) if abs(feed[i] / FAST_FEED_MM_S - 1.0) > krl.FEED_MATCH}
    assert with_feed == slower and slower


def test_rapid_points_feeds_and_quaternion_read_back(
    exported: dict[str, list[Path]], expected: tuple[np.ndarray, np.ndarray], cell: CellSetup
) -> None:
    p, q, feed = parse_rapid(exported["rapid"])
    np.testing.assert_allclose(p[1:-1], expected[0], atol=POSITION_TOL_MM)
    np.testing.assert_allclose(feed[2:-1], expected[1][1:], atol=0.5e-3 + 1e-9)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=2e-6)
    np.testing.assert_allclose(np.abs(q[0] @ quaternion_wxyz(cell.R_sheet_tool)), 1.0, atol=1e-6)
    text = exported["rapid"][0].read_text()
    assert text.count("MODULE") == 2 and "MoveL pPath{i},vPath{i},zPath,tIsf\\WObj:=wSheet;" in text
    assert "tIsf:=[TRUE,[[0,0,274.9400],[1,0,0,0]],[3.200," in text  # the cell's 3.2 kg tool


def test_gcode_points_and_modal_feed_read_back(
    exported: dict[str, list[Path]], expected: tuple[np.ndarray, np.ndarray]
) -> None:
    p, feed = parse_gcode(exported["gcode"])
    np.testing.assert_allclose(p[:-1], expected[0], atol=POSITION_TOL_MM)  # G1 down onto the path, ..., retract
    np.testing.assert_allclose(feed[1:-1] * 60.0, expected[1][1:] * 60.0, atol=0.005 + 1e-9)
    assert feed.max() > 1.9 * feed.min()  # the faster pass is in the program


def test_csv_point_list_reads_back(
    exported: dict[str, list[Path]], expected: tuple[np.ndarray, np.ndarray], cell: CellSetup
) -> None:
    p, r, feed = parse_csv(exported["csv"])
    np.testing.assert_allclose(p[1:-1], expected[0], atol=POSITION_TOL_MM)
    np.testing.assert_allclose(feed[2:-1], expected[1][1:], atol=0.5e-3 + 1e-9)
    R = _rx(r[0, 0]) @ _ry(r[0, 1]) @ _rz(r[0, 2])
    np.testing.assert_allclose(R, cell.R_sheet_tool, atol=1e-5)  # 4 decimals in degrees


def test_euler_and_quaternion_conventions_invert_each_other() -> None:
    R = _rz(30.0) @ _ry(-20.0) @ _rx(170.0)
    np.testing.assert_allclose(euler_zyx_deg(R), [30.0, -20.0, 170.0], atol=1e-9)
    a, b, c = euler_xyz_deg(R)
    np.testing.assert_allclose(_rx(a) @ _ry(b) @ _rz(c), R, atol=1e-12)
    w, x, y, z = quaternion_wxyz(R)
    Rq = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    np.testing.assert_allclose(Rq, R, atol=1e-12)


def test_val3_application_passes_the_grammar_check(exported: dict[str, list[Path]]) -> None:
    files = {f.name: f.read_text() for f in exported["val3"]}
    check_application(files)
    assert set(files) == {"isf.pjx", "isf.dtx", "start.pgx", "stop.pgx"}


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ("endFor", "endfor", r"not an instruction|missing endFor"),
        ("movel(pPath[i], tIsf, mPath[i])", "movel(pPath[i], mPath[i], tIsf)", r"not a tool"),
        ("movel(pPath[i], tIsf, mPath[i])", "movel(qPath[i], tIsf, mPath[i])", r"not a declared variable"),
        ("waitEndMove()\nend", "waitEndMove()\n", r"missing end"),
        ("waitEndMove()\n  for", "waitEndMove(1)\n  for", r"takes 0 argument"),
        ('shoulder="ssame"', 'shoulder="sright"', r"shoulder"),
        ('fatherId="fSheet[0]"', 'fatherId="fSheet[1]"', r"out of range"),
        ('fatherId="flange[0]" ioLink', 'fatherId="fSheet[0]" ioLink', r"declared tool"),
        ('tmax="', 'tmax="x', r"expected a number"),
        ('name="pPath"', 'name="1Path"', r"not a new identifier"),
    ],
)
def test_val3_check_rejects_what_the_grammar_forbids(
    exported: dict[str, list[Path]], old: str, new: str, pattern: str
) -> None:
    files = {f.name: f.read_text() for f in exported["val3"]}
    name = next(n for n, text in files.items() if old in text)
    files[name] = files[name].replace(old, new, 1)
    with pytest.raises(InputError, match=pattern):
        check_application(files)


def test_export_never_writes_over_its_input(path_csv: Path, cell: CellSetup, tmp_path: Path) -> None:
    copy = tmp_path / "path.csv"
    copy.write_bytes(path_csv.read_bytes())
    for fmt in ("gcode", "csv"):
        with pytest.raises(InputError, match="refusing to overwrite"):
            export_path(copy, fmt, copy, cell=cell)
    named_as_module = tmp_path / "path.mod"  # RAPID names its files as the program: NAME.mod, NAME.pgf
    named_as_module.write_bytes(path_csv.read_bytes())
    with pytest.raises(InputError, match="refusing to overwrite"):
        export_path(named_as_module, "rapid", copy, cell=cell)
    assert named_as_module.read_bytes() == path_csv.read_bytes()
    inside = tmp_path / "app" / "path.csv"
    inside.parent.mkdir()
    inside.write_bytes(path_csv.read_bytes())
    with pytest.raises(InputError, match="holds the input"):
        export_path(inside, "val3", inside.parent, cell=cell)
    assert copy.read_bytes() == inside.read_bytes() == path_csv.read_bytes()


def test_cli_export_writes_the_program_and_rejects_a_bad_path(
    path_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", str(path_csv), "--format", "krl", "--robot", "kr210", "--out",
                 str(tmp_path / "isf.src")]) == 0
    assert (tmp_path / "isf.dat").is_file() and "export" in capsys.readouterr().out
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,x_mm,y_mm,z_mm\n0,0,0,0\n0.1,abc,0,0\n")
    assert main(["export", str(bad), "--format", "gcode", "--out", str(tmp_path / "x.ngc")]) == 2
    assert "row 2" in capsys.readouterr().err
    assert not (tmp_path / "x.ngc").exists()
    with pytest.raises(TwinError):
        export_path(path_csv, "jbi", tmp_path / "x.jbi")


def test_default_cell_puts_the_tool_down(cell: CellSetup) -> None:
    np.testing.assert_allclose(cell.R_sheet_tool[:, 2], [0.0, 0.0, -1.0], atol=1e-12)
    assert cell.tool_length_mm == pytest.approx(274.94)


def test_a_turned_sheet_frame_puts_every_format_on_the_twins_pose(path_csv: Path, tmp_path: Path) -> None:
    """Placement yaw 30°: each format's sheet frame times its point pose is the pose the twin's IK solves for
    (tool tip origin + Rz(30°)·p, tool axes `Kinematics.R_tool_down` in the base)."""
    from twin.process.toolpath.placement import Placement
    from twin.robot.kinematics import Kinematics

    placement = Placement(origin_base_m=(1.5, 0.1, 0.2), yaw_rad=np.radians(30.0))
    cell = default_cell(placement=placement)
    kin = Kinematics()
    p_sheet = 1e3 * read_commanded_csv(path_csv).values
    p_base = 1e3 * placement.to_base(p_sheet / 1e3, kin)
    R_frame = _rz(30.0)
    val3 = export_path(path_csv, "val3", tmp_path / "v", cell=cell).files
    dtx = ET.parse(next(f for f in val3 if f.suffix == ".dtx")).getroot()
    frame = next(v for d in dtx.iter() if d.tag.endswith("Data") and d.get("name") == "fSheet" for v in d)
    assert float(frame.get("rz", "nan")) == pytest.approx(30.0)
    p, r, _ = parse_val3(val3)
    p = p[1:-1]
    np.testing.assert_allclose(p @ R_frame.T + 1e3 * np.array([1.5, 0.1, 0.2]), p_base, atol=2 * POSITION_TOL_MM)
    np.testing.assert_allclose(R_frame @ _rx(r[0, 0]) @ _ry(r[0, 1]) @ _rz(r[0, 2]), kin.R_tool_down, atol=1e-6)
    krl = next(f for f in export_path(path_csv, "krl", tmp_path / "k", cell=cell).files if f.suffix == ".src")
    sheet = _numbers(re.search(r"^BASE_DATA\[16\]=\{([^}]*)\}", krl.read_text(), re.M).group(1))  # type: ignore[union-attr]
    assert sheet[3:] == pytest.approx([30.0, 0.0, 0.0])
    rapid = export_path(path_csv, "rapid", tmp_path / "r.mod", cell=cell).files[0].read_text()
    wobj = _numbers(re.search(r"wSheet:=\[FALSE,TRUE,\"\",\[\[([^\]]*)\],\[([^\]]*)\]", rapid).group(2))  # type: ignore[union-attr]
    assert wobj == pytest.approx([np.cos(np.radians(15.0)), 0.0, 0.0, np.sin(np.radians(15.0))], abs=1e-6)
    gcode = export_path(path_csv, "gcode", tmp_path / "g.ngc", cell=cell).files[0].read_text()
    assert "G68 X0 Y0 R30" in gcode and "G69" in gcode
