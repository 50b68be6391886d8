"""CLI exit codes and input checks: the same rules as the API, tables that fit 80 columns."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from app.cli import cli

runner = CliRunner()
EXAMPLES = Path(__file__).parents[2] / "examples"


def test_learn_exits_1_when_it_does_not_converge(tmp_path: Path) -> None:
    out = tmp_path / "curve.png"
    args = ["learn", "--goal", "-2", "-2", "--max-updates", "1", "--out", str(out)]
    result = runner.invoke(cli, args)
    assert result.exit_code == 1, result.output
    assert "not converged" in result.output and out.exists()  # the plot is still written


def test_learn_rejects_what_the_api_rejects() -> None:
    # POST /jobs/learn allows goals within ±7 m and thresholds of at least 5 mm.
    result = runner.invoke(cli, ["learn", "--goal", "50", "0"])
    assert result.exit_code == 2 and "goal.0" in result.output and "7" in result.output
    result = runner.invoke(cli, ["learn", "--goal", "1", "1", "--threshold", "0"])
    assert result.exit_code == 2 and "threshold" in result.output
    result = runner.invoke(cli, ["learn", "--goal", "1", "1", "--max-updates", "0"])
    assert result.exit_code == 2 and "max-updates" in result.output


def test_simulate_rejects_what_the_api_rejects(tmp_path: Path) -> None:
    # The API's screw speeds are within ±1 rad/s; the CLI used to run anything.
    args = ["simulate", "--theta", "5", "0", "0", "0", "--out", str(tmp_path / "x.png")]
    result = runner.invoke(cli, args)
    assert result.exit_code == 2 and "theta.0" in result.output
    assert not (tmp_path / "x.png").exists()


def test_library_show_checks_the_shape_and_counts_what_it_shows() -> None:
    banana = runner.invoke(cli, ["library", "show", "--shape", "banana"])
    plot = runner.invoke(cli, ["library", "plot", "--shape", "banana"])
    assert banana.exit_code == plot.exit_code == 2
    assert "no primitives of shape 'banana'" in banana.output
    family = runner.invoke(cli, ["library", "show", "--family", "nope"])
    assert family.exit_code == 2 and "family" in family.output

    shown = runner.invoke(cli, ["library", "show", "--shape", "semi-zigzag"], terminal_width=80)
    assert shown.exit_code == 0
    lines = shown.output.splitlines()
    rows = [line for line in lines if "semi-zigzag" in line]
    title = next(line for line in lines if "primitives" in line)
    assert f"{len(rows)} primitives (of " in title
    assert "lat-semi-zigzag-t025-a180" in shown.output  # ids in full, never "semi-…"
    assert "…" not in shown.output
    assert max(len(line) for line in lines) <= 80


def test_every_command_prints_json_for_scripts(tmp_path: Path) -> None:
    sim = runner.invoke(
        cli, ["simulate", "--case", "exp4", "--out", str(tmp_path / "s.png"), "--json"]
    )
    data = json.loads(sim.output)
    assert sim.exit_code == 0 and abs(data["end"]["x"] + 2.04) < 0.01 and data["distance"] < 0.1

    learn = runner.invoke(
        cli,
        [
            "learn",
            "--goal",
            "-2",
            "-2",
            "--max-updates",
            "1",
            "--out",
            str(tmp_path / "l.png"),
            "--json",
        ],
    )
    data = json.loads(learn.output)
    assert learn.exit_code == 1 and data["converged"] is False and len(data["theta"]) == 4

    show = runner.invoke(cli, ["library", "show", "--shape", "straight", "--json"])
    data = json.loads(show.output)
    assert show.exit_code == 0 and data["shown"] == len(data["primitives"]) < data["total"]
    assert {p["shape"] for p in data["primitives"]} == {"straight"}

    plot = runner.invoke(cli, ["library", "plot", "--out", str(tmp_path / "p.png"), "--json"])
    assert plot.exit_code == 0 and "straight-g1" in json.loads(plot.output)["primitives"]

    listed = runner.invoke(cli, ["paper", "list", "--json"])
    assert listed.exit_code == 0 and "exp1" in {e["name"] for e in json.loads(listed.output)}

    mission = runner.invoke(
        cli,
        [
            "mission",
            str(EXAMPLES / "fig9a-single-goal.json"),
            "--out",
            str(tmp_path / "m.png"),
            "--json",
        ],
    )
    data = json.loads(mission.output)
    assert mission.exit_code == 0 and data["status"] == "succeeded" and data["goals"][0]["reached"]
