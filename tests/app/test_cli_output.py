"""What the CLI prints and writes, as a user reads it at 80 columns: a short mission summary
that never cuts a primitive id, plots named after their inputs, a clear word when an option
gets too few numbers, plots that mark the start and name what they show."""

from __future__ import annotations

import os
import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.plots import trajectory_figure
from primitives.library import Library, bundled_library_path

runner = CliRunner()
NARROW = {"COLUMNS": "80", "LINES": "40"}
ID = re.compile(r"\blat-[a-z-]+-(?:t\d{3}-a\d{3}|r[mp]\d\dp\d)\b")


def in_dir(tmp_path: Path, args: list[str]) -> tuple[int, str]:
    """Run the CLI with ``tmp_path`` as the working directory (where out/ is written)."""
    here = Path.cwd()
    os.chdir(tmp_path)
    try:
        result = runner.invoke(cli, args, env=NARROW)
    finally:
        os.chdir(here)
    return result.exit_code, result.output


def test_mission_summary_is_short_and_never_cuts_an_id(tmp_path: Path) -> None:
    mission = str(Path("examples/cluttered-field.json").resolve())
    code, out = in_dir(tmp_path, ["mission", mission, "--out", "m.png"])
    assert code == 0, out
    assert len(out.splitlines()) <= 20
    assert "…" not in out and re.search(r"^replans: (none|\d+ \(\w+ ×\d+)", out, re.MULTILINE)
    assert "most used: lat-" in " ".join(out.split()) and "--verbose" in out
    code, verbose = in_dir(tmp_path, ["mission", mission, "--out", "m.png", "--verbose"])
    assert code == 0 and "…" not in verbose
    library = Library.load(bundled_library_path())
    ids = ID.findall(verbose)
    assert len(ids) > 40 and all(i in library for i in ids)  # every id whole, none cut
    assert all(len(line) <= 80 for line in verbose.splitlines())
    code, wide = in_dir(tmp_path, ["mission", mission, "--out", "m.png", "-v", "--wide"])
    assert code == 0 and "…" not in wide
    assert any(len(line) > 100 for line in wide.splitlines())  # one line a run
    assert re.search(r"\(move \S+ \S+ lat-\S+\)\s*$", wide, re.MULTILINE)


def test_simulate_names_each_plot_after_its_inputs(tmp_path: Path) -> None:
    forward = ["simulate", "--theta", "-1", "1", "-1", "1", "--joints", "0", "0", "0"]
    gait = ["simulate", "--theta", "-.1", ".53", "-.12", ".5", "--phases", ".6", "-.5", "-.3"]
    gait += ["--dt", "0.05", "--joint-mode", "complete"]
    plots = []
    for args in (forward, gait, ["simulate", "--case", "exp4"]):
        code, out = in_dir(tmp_path, args)
        assert code == 0, out
        plots.append(re.search(r"plot: (\S+\.png)", out).group(1))  # type: ignore[union-attr]
    assert len(set(plots)) == 3 and "out/simulate-exp4.png" in plots
    assert all((tmp_path / p).exists() for p in plots)


@pytest.mark.parametrize(
    ("args", "option"),
    [
        (["learn", "--goal", "-3", "--shape", "straight"], "--goal"),
        (["simulate", "--theta", "-1", "1", "-1", "--joints", "0", "0", "0"], "--theta"),
        (["simulate", "--theta", "-1", "1", "-1", "1", "--joints", "0", "x", "0"], "--joints"),
    ],
)
def test_too_few_numbers_are_named(tmp_path: Path, args: list[str], option: str) -> None:
    code, out = in_dir(tmp_path, args)
    text = " ".join(out.split())  # the error box wraps
    assert code == 2 and option in text
    assert "takes" in text or "is not a number" in text
    assert "unable to parse" not in text


def test_help_shows_units_and_the_numbers_an_option_takes(tmp_path: Path) -> None:
    code, out = in_dir(tmp_path, ["learn", "--help"])
    assert code == 0 and "--goal" in out and "X Y" in out and "(m)" in out
    goal_line = next(line for line in out.splitlines() if "--goal" in line)
    assert "[required]" in goal_line  # on its line, not wrapped alone onto the next
    code, out = in_dir(tmp_path, ["simulate", "--help"])
    assert "T1 T2 T3 T4" in out and "(rad/s)" in out


def test_plots_mark_the_start_and_name_what_they_show(tmp_path: Path) -> None:
    s = np.linspace(0, 1, 50)
    states = np.stack([1 - 2 * s, s, *np.zeros((4, 50))], axis=1)
    fig = trajectory_figure([states], title="t")
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "start" in legend and "origin" not in legend
    start = next(line for line in fig.axes[0].lines if line.get_label() == "start")
    assert tuple(start.get_xydata()[0]) == (1.0, 0.0)  # the path's first point, not (0, 0)
    plt.close(fig)
    from app.cli import simulation_title

    title = simulation_title(
        "exp4", (-0.1, 0.53, -0.12, 0.5), None, (0.6, -0.5, -0.3), (100, 1, "paper")
    )
    assert "exp4" in title and "Fig. 5" in title and "(-0.1, 0.53, -0.12, 0.5) rad/s" in title
    assert "gait phases (0.6, -0.5, -0.3) rad" in title and "100 model s" in title
