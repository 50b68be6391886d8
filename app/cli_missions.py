"""CLI commands that run missions headless: `screwsnake mission FILE`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from app.cli_primitives import load_library
from app.console import AsJson, console, emit, fail
from app.executor.context import MissionResult
from app.executor.runner import MissionError, MissionRunner
from app.mission_plot import plot_mission, sensed_cells
from app.missions.spec import MissionFileError, load_mission


def print_summary(result: MissionResult) -> None:
    colour = "green" if result.status == "succeeded" else "red"
    console.print(f"[bold {colour}]{result.status}[/]: {result.reason}")
    table = Table(title="goals")
    for col in ("#", "x", "y", "tolerance (m)", "reached", "error (m)", "at (s)"):
        table.add_column(col, justify="right")
    for i, g in enumerate(result.goals):
        err = "" if g.error is None else f"{g.error:.3f}"
        at = "" if g.reached_at is None else f"{g.reached_at:g}"
        table.add_row(
            str(i),
            f"{g.x:g}",
            f"{g.y:g}",
            f"{g.tolerance:g}",
            "yes" if g.reached else "no",
            err,
            at,
        )
    console.print(table)
    if result.replans:
        rt = Table(title=f"{len(result.replans)} replans")
        for col in ("at (s)", "trigger", "latency (ms)", "status"):
            rt.add_column(col)
        for r in result.replans:
            rt.add_row(f"{r.at:g}", r.trigger, f"{r.latency_ms:.1f}", r.status)
        console.print(rt)
    print_executed(result)
    ratio = result.model_time / max(result.wall_time, 1e-9)
    console.print(
        f"collisions: {result.collisions}   model time: {result.model_time:g} s   "
        f"wall time: {result.wall_time:.2f} s   ({ratio:.0f}x real time)"
    )


EXECUTED_ROWS = 40  # rows of the executed-primitives table before it is cut short


def print_executed(result: MissionResult) -> None:
    """The primitives the mission ran, in order (one row per action and grounding)."""
    runs = [e for e in result.executed if e["labels"]]
    if not runs:
        return
    table = Table(title=f"executed primitives ({len(runs)} runs)")
    for col in ("from (s)", "to (s)", "action", "grounding", "primitives"):
        table.add_column(col)
    for e in runs[:EXECUTED_ROWS]:
        table.add_row(
            f"{e['from']:g}", f"{e['to']:g}", e["action"], str(e["method"]), "+".join(e["labels"])
        )
    console.print(table)
    if len(runs) > EXECUTED_ROWS:
        console.print(f"... {len(runs) - EXECUTED_ROWS} more runs (see the mission result)")


def mission(
    file: Annotated[Path, typer.Argument(help="mission JSON (see examples/)")],
    out: Annotated[Path | None, typer.Option(help="trajectory plot (PNG)")] = None,
    library: Annotated[
        Path | None, typer.Option(help="primitive library (default: bundled)")
    ] = None,
    as_json: AsJson = False,
) -> None:
    """Run a mission headless, print a summary and write a trajectory plot."""
    try:
        spec = load_mission(file)
        runner = MissionRunner(spec, load_library(library))
    except (MissionFileError, MissionError) as exc:
        raise fail(str(exc)) from exc
    result = runner.run()
    path = plot_mission(spec, result, out or Path("out") / f"{spec.name}.png", sensed_cells(runner))
    if as_json:
        emit({**result.summary(), "plot": str(path)})
    else:
        print_summary(result)
        console.print(f"plot: {path}")
    if result.status != "succeeded":
        raise typer.Exit(code=1)


def paper(
    name: Annotated[str, typer.Argument(help="an experiment, or 'list'")] = "list",
    out: Annotated[Path, typer.Option(help="folder for the plots")] = Path("out/paper"),
    library: Annotated[
        Path | None, typer.Option(help="primitive library (default: bundled)")
    ] = None,
    as_json: AsJson = False,
) -> None:
    """List, or run, the paper's experiments that the system reproduces."""
    from app.paper import EXPERIMENTS

    if name.lower() == "list":
        if as_json:
            emit(
                [
                    {"name": e.name, "figure": e.figure, "what": e.title}
                    for e in EXPERIMENTS.values()
                ]
            )
            return
        table = Table(title="reproducible experiments")
        for col in ("name", "figure", "what"):
            table.add_column(col)
        for e in EXPERIMENTS.values():
            table.add_row(e.name, e.figure, e.title)
        console.print(table)
        return
    if name not in EXPERIMENTS:
        raise fail(f"unknown experiment {name!r}; run `screwsnake paper list`")
    experiment = EXPERIMENTS[name]
    rows, path = experiment.run(load_library(library), out)
    if as_json:
        emit(
            {
                "experiment": experiment.name,
                "figure": experiment.figure,
                "rows": [{"what": r[0], "paper": r[1], "screwsnake": r[2]} for r in rows],
                "plot": str(path),
            }
        )
        return
    table = Table(title=f"{experiment.figure}: {experiment.title}")
    for col in ("", "the paper", "screwsnake"):
        table.add_column(col)
    for row in rows:
        table.add_row(*row)
    console.print(table)
    console.print(f"plot: {path}")
