"""The gaps a forming engineer found: `sweep` on any twin (`--robot`, `--model`, `--process`) and bounded `--draws`;
`replay --figure`; every axis in a replay's rerun recording; `identify` printing the K_R the data supports (3x3 on a
cone, x-z on the groove); every figure panel labelled with units."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure

import twin
from twin.base.csvio import write_table
from twin.cli import main
from twin.errors import InputError
from twin.process.toolpath.groove import groove_path

UNIT = re.compile(r"\[[^\]]+\]")


def _json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    """Run a command with `--json -` and return its payload (the summary went to stderr)."""
    capsys.readouterr()
    assert main([*argv, "--json", "-"]) == 0
    captured = capsys.readouterr()
    payload: dict[str, Any] = json.loads(captured.out)
    payload["_printed"] = captured.err
    return payload


@pytest.fixture(scope="module")
def first_pass_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The groove's first pass as an ideal path CSV (142 samples): a cheap sweep."""
    path = groove_path()
    keep = path.pass_index == 1
    p_mm = 1e3 * path.p_sheet_m[keep]
    return write_table(tmp_path_factory.mktemp("sweep") / "pass1.csv",
                       {"t_s": path.t_s[keep], "x_mm": p_mm[:, 0], "y_mm": p_mm[:, 1], "z_mm": p_mm[:, 2]})


@pytest.fixture(scope="module")
def cone_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small cone (3 mm deep, 30 mm across) formed on the lab: its forces span x, y and z."""
    base = tmp_path_factory.mktemp("cone")
    assert main(["path", "--shape", "cone", "--depth-mm", "3", "--top-width-mm", "30", "--out",
                 str(base / "cone.csv")]) == 0
    assert main(["lab", "--scenario", "nominal", "--commanded", str(base / "cone.csv"), "--seed", "1", "--out",
                 str(base / "run")]) == 0
    return base / "run"


# ---------------------------------------------------------------- sweep: its twin, and --draws bounded
def _mean_k_q(payload: dict[str, Any]) -> np.ndarray:
    mean = payload["uncertainty"]["mean"]
    return np.array([mean[k] for k in sorted(mean) if k.startswith("k_q")])


def test_sweep_runs_on_the_robot_and_process_given(first_pass_csv: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from twin.robot.description import load_robot
    from twin.sim.spec import TwinSpec

    process = tmp_path / "p.toml"
    process.write_text('format = "tx200-twin-process/1"\nthickness_mm = 1.2\ntool_radius_mm = 6.0\n')
    base = ["sweep", "--draws", "2", "--workers", "1", "--ideal", str(first_pass_csv)]
    payload = _json([*base, "--robot", "kr210", "--process", str(process)], capsys)
    assert payload["robot"] == "kr210" and payload["draws"] == 2
    assert payload["process"]["thickness_mm"] == 1.2 and payload["process"]["tool_radius_mm"] == 6.0
    kr210 = TwinSpec(robot=load_robot("kr210")).build().joint_stiffness
    np.testing.assert_allclose(_mean_k_q(payload), kr210)  # the draws are around kr210's K_q, not the tx200's
    assert "robot kr210" in payload["_printed"]


def test_sweep_runs_on_a_model_file(first_pass_csv: Path, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    from twin.analysis.identify.rollouts import write_joint_stiffness
    from twin.sim.spec import TwinSpec

    spec = TwinSpec()
    k_q = 0.5 * spec.build().joint_stiffness
    model = write_joint_stiffness(tmp_path / "soft.json", k_q, note="half the K_q", spec=spec)
    payload = _json(["sweep", "--draws", "2", "--workers", "1", "--ideal", str(first_pass_csv), "--model",
                     str(model)], capsys)
    np.testing.assert_allclose(_mean_k_q(payload), k_q)


def test_sweep_refuses_a_force_model_it_cannot_draw(first_pass_csv: Path, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    process = tmp_path / "isf.toml"
    process.write_text('format = "tx200-twin-process/1"\nforce_model = "isf"\n')
    out = tmp_path / "s.json"
    assert main(["sweep", "--draws", "2", "--workers", "1", "--ideal", str(first_pass_csv), "--process",
                 str(process), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "'table'" in err and "'isf'" in err and not out.exists()


def test_sweep_refuses_too_many_draws_before_allocating(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    import twin.apps.tasks.sweep as task
    from twin.apps.uncertainty import Uncertainty

    def allocated(*_: Any, **__: Any) -> Any:
        raise AssertionError("the sweep went on to draw before checking --draws")

    monkeypatch.setattr(task, "run_sweep", allocated)
    monkeypatch.setattr(Uncertainty, "draw", allocated)
    out, figure = tmp_path / "s.json", tmp_path / "s.png"
    assert main(["sweep", "--draws", "1000000000", "--figure", str(figure), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--draws 1000000000" in err and "at most 1000000" in err and "GiB" in err
    assert "Traceback" not in err and not out.exists() and not figure.exists()


def test_the_draw_limit_follows_the_machines_memory(monkeypatch: pytest.MonkeyPatch) -> None:
    import twin.apps.sweep as sweep
    from twin.apps.uncertainty import Uncertainty

    monkeypatch.setattr(Uncertainty, "draw", lambda *_: pytest.fail("drew before checking"))
    sweep.check_draws(500_000)
    monkeypatch.setattr(sweep, "_machine_bytes", lambda: 2**30)  # a 1 GiB machine: ~400 000 draws fit in half
    limit = 2**29 // sweep.draw_bytes()
    sweep.check_draws(limit)
    with pytest.raises(InputError, match=rf"--draws 500000: expected at most {limit} .*1 GiB"):
        sweep.check_draws(500_000)
    with pytest.raises(InputError, match="--draws"):
        sweep.run_sweep(500_000)


# ---------------------------------------------------------------- replay: --figure, every axis recorded
def _labels_of(fig: Figure) -> list[tuple[str, str, str]]:
    """(kind, x label, y label) of each visible panel; a colour bar gives its long axis's label as both."""
    found = []
    for ax in fig.axes:
        if not ax.axison or not ax.get_visible():
            continue
        bar = getattr(ax, "_colorbar", None)
        if bar is not None:
            label = ax.get_ylabel() if bar.orientation == "vertical" else ax.get_xlabel()
            found.append(("colorbar", label, label))
        else:
            found.append(("axes", ax.get_xlabel(), ax.get_ylabel()))
    return found


@pytest.fixture
def saved_labels(monkeypatch: pytest.MonkeyPatch) -> list[list[tuple[str, str, str]]]:
    """The panels' labels of every figure saved while the test runs (read just before it is written)."""
    figures: list[list[tuple[str, str, str]]] = []
    original = Figure.savefig

    def savefig(self: Figure, *args: Any, **kwargs: Any) -> Any:
        figures.append(_labels_of(self))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return figures


def _unlabelled(figures: list[list[tuple[str, str, str]]]) -> list[str]:
    return [f"figure {i}: {kind} x {x!r}, y {y!r}" for i, panels in enumerate(figures) for kind, x, y in panels
            if not (UNIT.search(x) and UNIT.search(y))]


def test_replay_writes_a_labelled_figure_of_every_axis(cone_run: Path, tmp_path: Path,
                                                        saved_labels: list[list[tuple[str, str, str]]],
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    figure = tmp_path / "replay.png"
    payload = _json(["replay", str(cone_run), "--figure", str(figure)], capsys)
    assert payload["figure"] == str(figure) and figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*.tmp"))  # written atomically: no temporary file left
    (panels,) = saved_labels
    assert [y.split()[0] for _, _, y in panels] == ["x", "y", "z"]
    assert all(x == "time [s]" and y.endswith("[mm]") for _, x, y in panels)


def test_replay_figure_never_replaces_an_input(cone_run: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from twin.apps.tasks.replay import ReplayRequest

    commanded = cone_run / "commanded.csv"
    before = commanded.read_bytes()
    assert main(["replay", str(cone_run), "--figure", str(commanded)]) == 2
    assert "--figure" in capsys.readouterr().err and commanded.read_bytes() == before
    with pytest.raises(InputError, match=r"commanded\.csv"):
        ReplayRequest(cone_run, figure=commanded)  # the task refuses it too, for Python callers


def test_the_replay_recording_has_every_axis(cone_run: Path, tmp_path: Path) -> None:
    from rerun.chunk import RrdReader

    from twin.runs.read import read_run

    rrd = tmp_path / "cone.rrd"
    assert main(["replay", str(cone_run), "--rrd", str(rrd)]) == 0
    chunks: dict[str, list[Any]] = {}
    for chunk in RrdReader(rrd).stream().to_chunks():
        chunks.setdefault(chunk.entity_path, []).append(chunk)
    for axis in "xyz":
        for entity in (f"/plots/deflection_{axis}_mm/measured", f"/plots/deflection_{axis}_mm/predicted",
                       f"/plots/force_{axis}_n/measured", f"/plots/force_{axis}_n/predicted"):
            assert entity in chunks, f"{entity} missing; have {sorted(e for e in chunks if 'plots' in e)}"
    run = read_run(cone_run)
    y_mm = [np.asarray(c.to_record_batch().column("Scalars:scalars").to_pylist()).ravel()
            for c in chunks["/plots/deflection_y_mm/measured"] if not c.is_static]
    cmd_y = np.interp(run.tracker.t_s, run.commanded.t_s, run.commanded.values[:, 1])
    np.testing.assert_allclose(np.concatenate(y_mm), 1e3 * (run.tracker.values[:, 1] - cmd_y), atol=1e-9)
    assert np.ptp(np.concatenate(y_mm)) > 0.1  # a cone moves the tip in y by more than 0.1 mm


# ---------------------------------------------------------------- identify: the K_R the data supports
def test_identify_method2_fits_every_axis_on_a_cone(cone_run: Path, capsys: pytest.CaptureFixture[str]) -> None:
    payload = _json(["identify", "--method", "2", str(cone_run)], capsys)
    assert payload["axes"] == ["x", "y", "z"]
    for key in ("k_r_n_per_mm", "k_r_measured_forces_n_per_mm", "c_r_mm_per_kn", "twin_compliance_mm_per_kn",
                "compliance_measured_forces_mm_per_kn", "twin_compliance_fitted_axes_mm_per_kn"):
        assert np.asarray(payload[key]).shape == (3, 3), key
    assert np.asarray(payload["twin_compliance_xz_mm_per_kn"]).shape == (2, 2)
    printed = payload["_printed"]
    assert "rows Fx, Fy, Fz; columns dUx, dUy, dUz" in printed and "x-y-z block" in printed
    assert len(re.findall(r"^\s+\[.*\]$", printed, flags=re.M)) == 6  # two 3x3 matrices, one row a line


def test_identify_method2_keeps_x_z_on_the_groove_and_says_why(clean_run_dir: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    payload = _json(["identify", "--method", "2", str(clean_run_dir)], capsys)
    assert payload["axes"] == ["x", "z"] and np.asarray(payload["k_r_n_per_mm"]).shape == (2, 2)
    assert np.asarray(payload["twin_compliance_mm_per_kn"]).shape == (3, 3)  # the record keeps every axis
    assert "do not span y" in payload["_printed"] and "rows Fx, Fz" in payload["_printed"]


def test_method2_recovers_a_known_3x3_compliance(cone_run: Path) -> None:
    """A cone run whose tracker is the command plus C·F_ID exactly: Method 2 gives C back on all three axes."""
    from dataclasses import replace

    from twin.analysis.identify.method2 import method2
    from twin.process.description import Process
    from twin.process.force.registry import build_force_field
    from twin.process.toolpath.groove import ToolPath, label_passes
    from twin.runs.format import Stream
    from twin.runs.read import read_run
    from twin.sim.quasi_static import PASS_DEADBAND_M

    run = read_run(cone_run)
    process = Process(force_model="isf")
    cmd = run.commanded
    passes, direction = label_passes(cmd.values[:, 0], deadband_m=PASS_DEADBAND_M)
    path = ToolPath(t_s=cmd.t_s, p_sheet_m=cmd.values, pass_index=passes, direction=direction)
    f_ideal = build_force_field(process).rigid_forces(path)
    c = np.array([[1.6, 0.1, 0.6], [0.2, 1.2, -0.1], [0.6, 0.05, 1.1]]) * 1e-6  # [m/N]
    exact = replace(run, tracker=Stream(cmd.t_s, cmd.values + f_ideal @ c.T))
    result = method2(exact, process)
    assert result.axes == (0, 1, 2) and result.force_span > 0.05
    np.testing.assert_allclose(result.c_ideal_m_per_n, c, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(result.k_r_ideal_n_per_m, np.linalg.inv(c), rtol=1e-6)
    xz = method2(exact, process, axes=(0, 2))  # the thesis's x-z block, asked for
    assert xz.c_ideal_m_per_n.shape == (2, 2)
    with pytest.raises(InputError, match="axes"):
        method2(exact, process, axes=(0, 0))


def test_identify_method1_prints_the_full_compliance(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from twin.analysis.identify.cartesian import THESIS_KR1_N_PER_MM, THESIS_TABLE_4_2_LOADS_N

    d_mm = np.linalg.solve(THESIS_KR1_N_PER_MM, THESIS_TABLE_4_2_LOADS_N.T).T
    names = ("fx_n", "fy_n", "fz_n", "dx_mm", "dy_mm", "dz_mm")
    values = np.column_stack([THESIS_TABLE_4_2_LOADS_N, d_mm])
    loads = write_table(tmp_path / "loads.csv", {n: values[:, k] for k, n in enumerate(names)},
                        formats=dict.fromkeys(names, ".9f"))
    payload = _json(["identify", "--method", "1", "--loads", str(loads)], capsys)
    assert payload["axes"] == ["x", "y", "z"]
    np.testing.assert_allclose(payload["c_r_mm_per_kn"], 1e3 * np.linalg.inv(THESIS_KR1_N_PER_MM), rtol=1e-6)
    assert "C_R = inv(K_R) [mm/kN]" in payload["_printed"]


# ---------------------------------------------------------------- every figure's panels: labels with units
def _synthetic_figures(tmp_path: Path) -> dict[str, Path]:
    """Write every figure of the package from small synthetic inputs; name -> file."""
    from twin.analysis.part_compensation import PartStage
    from twin.analysis.placement_search import PlacementSearch, SearchBox
    from twin.analysis.surface_check import REGIONS, RegionDeviation, SurfaceDeviation
    from twin.apps.sweep import PARAMETERS, SweepResult, Uncertainty
    from twin.apps.sweep_figure import sweep_figure
    from twin.lab.dynamic.sweep import SweepRow, write_sweep_figure
    from twin.viz.deflection_figures import plot_deflection_by_pass, plot_residual_before_after
    from twin.viz.path_figures import plot_forces, plot_path_xz, plot_replay
    from twin.viz.placement_figure import placement_figure
    from twin.viz.stiffness_figures import plot_stiffness_ellipse
    from twin.viz.surface_figures import plot_part_stages, plot_surface_deviation

    rng = np.random.default_rng(0)
    n = 120
    t = np.linspace(0.0, 6.0, n)
    passes = np.repeat([1, 2], n // 2)
    direction = np.where(passes == 1, 1.0, -1.0)
    p = np.column_stack([0.03 * np.sin(t), 0.01 * np.cos(t), -1e-3 * t])
    d = 1e-4 * rng.standard_normal((n, 3))
    xy = np.stack(np.meshgrid(np.linspace(-0.02, 0.02, 12), np.linspace(-0.02, 0.02, 12)), -1).reshape(-1, 2)
    points = np.column_stack([xy, np.zeros(len(xy))])
    dev = 1e-4 * np.sin(40 * xy[:, 0])
    regions = RegionDeviation(points, dev, np.arange(len(xy)) % len(REGIONS))
    surface = SurfaceDeviation(points, dev, float(np.std(dev)), float(np.max(np.abs(dev))), float(np.mean(dev)))
    rows = np.column_stack([rng.uniform(-0.3, 0.3, (40, 3)), rng.uniform(-3, 3, 40)])
    screened = np.column_stack([rng.uniform(1e-4, 1e-3, 40), rng.uniform(1e-4, 2e-3, 40), np.zeros(40),
                                np.ones(40), np.ones(40)])
    search = PlacementSearch(rows, screened, rows[0], screened[0], screened[0], np.arange(3), screened[:3],
                             SearchBox(), 0, "local", {"total": 1.0})
    k = len(PARAMETERS)
    sweep = SweepResult(np.ones((30, k)) + 0.1 * rng.standard_normal((30, k)), rng.uniform(1e-5, 5e-5, 30),
                        rng.uniform(5e-5, 1e-4, 30), rng.uniform(-1e-5, 1e-5, 30), 2e-5, 1.0, 1, 1.0,
                        Uncertainty(np.ones(k), 0.1 * np.ones(k), "synthetic"))
    feeds = [SweepRow(f, 0.02 * f, 0.05 * f, 0.01 * f, 2.0 * f, 600.0, 0.07, 1.0) for f in (1.0, 2.0, 4.0)]
    c_mm_per_kn = np.array([[1.54, 0.19], [0.79, 1.02]])
    writers = {
        "plot_path_xz": lambda out: plot_path_xz(out, p, p + d, p_commanded_sheet_m=p - d),
        "plot_forces": lambda out: plot_forces(out, t, 1e3 * p, t_ideal_s=t, f_ideal_n=1e3 * p),
        "plot_replay": lambda out: plot_replay(out, t, p + d, p + 0.5 * d, p),
        "plot_deflection_by_pass": lambda out: plot_deflection_by_pass(out, p[:, 0], d, passes, direction),
        "plot_residual_before_after": lambda out: plot_residual_before_after(out, t, d, 0.5 * d),
        "plot_stiffness_ellipse": lambda out: plot_stiffness_ellipse(out, [c_mm_per_kn], ["C_R(1)"]),
        "plot_surface_deviation": lambda out: plot_surface_deviation(out, surface, regions=regions),
        "plot_part_stages": lambda out: plot_part_stages(out, [PartStage("twin, iteration 1", "predicted", regions),
                                                               PartStage("scan", "scanned", regions)]),
        "placement_figure": lambda out: placement_figure(search, out),
        "sweep_figure": lambda out: sweep_figure(sweep, out),
        "write_sweep_figure": lambda out: write_sweep_figure(feeds, out),
    }
    return {name: write(tmp_path / f"{name}.png") for name, write in writers.items()}


def _figure_functions() -> set[str]:
    """Every function of the package that writes a figure (calls `save_figure` or `.savefig`), but the writer."""
    root = Path(twin.__file__).parent
    found = set()
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and node.name != "save_figure":
                calls = {getattr(c.func, "attr", getattr(c.func, "id", "")) for c in ast.walk(node)
                         if isinstance(c, ast.Call)}
                if calls & {"save_figure", "savefig"}:
                    found.add(node.name)
    return found


def test_every_figure_panel_has_axis_labels_with_units(tmp_path: Path,
                                                        saved_labels: list[list[tuple[str, str, str]]]) -> None:
    written = _synthetic_figures(tmp_path)
    assert set(written) == _figure_functions(), "a figure function this test does not draw (add it above)"
    assert len(saved_labels) == len(written) and all(saved_labels)
    assert _unlabelled(saved_labels) == []


def test_the_label_check_catches_a_panel_without_units() -> None:
    fig = Figure()
    ax = fig.subplots()
    ax.set_xlabel("time [s]")
    ax.set_ylabel("draws")
    assert _unlabelled([_labels_of(fig)]) == ["figure 0: axes x 'time [s]', y 'draws'"]
