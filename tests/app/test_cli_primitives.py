"""`screwsnake learn` and `screwsnake library build|show|plot`."""

from pathlib import Path

from typer.testing import CliRunner

from app.cli import cli
from primitives.library import Library

runner = CliRunner()


def test_learn_reports_convergence_and_writes_a_learning_curve(tmp_path: Path) -> None:
    out = tmp_path / "curve.png"
    result = runner.invoke(
        cli,
        ["learn", "--goal", "-2", "-2", "--shape", "periodic", "--seed", "0", "--out", str(out)],
    )
    assert result.exit_code == 0, result.output
    assert "converged" in result.output and "phases" in result.output
    assert out.read_bytes()[:4] == b"\x89PNG"


def test_learn_rejects_unknown_shapes_and_learners(tmp_path: Path) -> None:
    assert "shape" in runner.invoke(cli, ["learn", "--goal", "1", "1", "--shape", "blob"]).output
    result = runner.invoke(cli, ["learn", "--goal", "1", "1", "--learner", "sgd"])
    assert result.exit_code == 2 and "learner" in result.output


def test_library_build_show_plot(tmp_path: Path) -> None:
    lib = tmp_path / "lib.json"
    args = [
        "library",
        "build",
        "--out",
        str(lib),
        "--shapes",
        "straight",
        "--executor",
        "serial",
        "--learner",
        "pi2-cma",
    ]
    result = runner.invoke(cli, args)
    assert result.exit_code == 0, result.output
    library = Library.load(lib)
    paper = library.paper()
    assert len(paper) == 8 and all(e.cost < 0.05 and e.learner == "pi2-cma" for e in paper)
    assert len(library.lattice("straight")) == 22  # translations and turns of the lattice
    shown = runner.invoke(cli, ["library", "show", str(lib)])
    assert shown.exit_code == 0 and "P1s" in shown.output
    png = tmp_path / "fig6.png"
    plotted = runner.invoke(cli, ["library", "plot", str(lib), "--out", str(png)])
    assert plotted.exit_code == 0 and png.exists()


def test_library_commands_report_bad_files(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("{truncated")
    result = runner.invoke(cli, ["library", "show", str(bad)])
    assert result.exit_code == 2 and "not valid JSON" in result.output


def test_library_learn_shape_saves_the_library_with_the_shape_and_checks_the_joints(
    tmp_path: Path,
) -> None:
    from primitives.library import bundled_library_path, load_bundled

    bundled = bundled_library_path().read_bytes()
    out = tmp_path / "learned.json"
    result = runner.invoke(
        cli, ["library", "learn-shape", "--joints", "0.9,-0.3,0.6", "--out", str(out), "--json"]
    )
    assert result.exit_code == 0, result.output
    grown = Library.load(out)
    learned = grown.lattice("body-p090-m030-p060")
    assert learned and len(grown) == len(load_bundled()) + len(learned)
    assert grown.lattice_covers((0.9, -0.3, 0.6)).shape == "body-p090-m030-p060"
    assert bundled_library_path().read_bytes() == bundled  # the bundled file is never written
    bad = runner.invoke(cli, ["library", "learn-shape", "--joints", "0,0,1.55"])
    assert bad.exit_code == 2 and "joint limits" in bad.output
    assert runner.invoke(cli, ["library", "learn-shape", "--joints", "0,x"]).exit_code != 0
