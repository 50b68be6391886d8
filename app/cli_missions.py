"""CLI commands that run missions headless: `screwsnake mission FILE`."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Annotated

import typer
from pydantic import ValidationError
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from app.cli_primitives import load_library
from app.console import AsJson, console, emit, fail
from app.executor.context import MissionResult
from app.executor.runner import MissionError, MissionRunner
from app.mission_plot import plot_mission, sensed_cells
from app.missions.maps import read_map_yaml
from app.missions.spec import MissionFileError, load_mission
from sim.maps import MapError


def print_summary(result: MissionResult, verbose: bool = False, wide: bool = False) -> None:
    """The outcome in a few lines (goals, replans and primitives in brief); with ``verbose``
    every replan and every run of a primitive. Primitive ids are never cut: at the terminal's
    width they wrap, with ``wide`` each row is one line however long."""
    colour = "green" if result.status == "succeeded" else "red"
    console.print(f"[bold {colour}]{result.status}[/]: {escape(result.reason)}", soft_wrap=True)
    table = Table(title="goals", box=box.SIMPLE_HEAD, pad_edge=False)
    for col in ("#", "x (m)", "y (m)", "tolerance (m)", "reached", "error (m)", "at (s)"):
        table.add_column(col, justify="right")
    for i, g in enumerate(result.goals):
        err = "" if g.error is None else f"{g.error:.3f}"
        at = "" if g.reached_at is None else f"{g.reached_at:g}"
        reached = "removed" if g.removed else ("yes" if g.reached else "no")
        table.add_row(str(i), f"{g.x:g}", f"{g.y:g}", f"{g.tolerance:g}", reached, err, at)
    console.print(table)
    print_replans(result, verbose, wide)
    print_executed(result, verbose, wide)
    ratio = result.model_time / max(result.wall_time, 1e-9)
    console.print(
        f"collisions: {result.collisions}   model time: {result.model_time:g} s   "
        f"wall time: {result.wall_time:.2f} s   ({ratio:.0f}x real time)"
    )


def counted(items: list[str]) -> str:
    """``a ×3, b ×1``, most frequent first."""
    return ", ".join(f"{item} ×{n}" for item, n in Counter(items).most_common())


def print_replans(result: MissionResult, verbose: bool, wide: bool) -> None:
    if not result.replans:
        console.print("replans: none")
        return
    latencies = [r.latency_ms for r in result.replans]
    console.print(
        f"replans: {len(result.replans)} ({counted([r.trigger for r in result.replans])}), "
        f"planning {min(latencies):.1f}-{max(latencies):.1f} ms",
        soft_wrap=wide,
    )
    if not verbose:
        return
    table = Table(box=box.SIMPLE_HEAD, pad_edge=False)
    for col in ("at (s)", "trigger", "latency (ms)", "status"):
        table.add_column(col, no_wrap=wide, overflow="fold")
    for r in result.replans:
        table.add_row(f"{r.at:g}", r.trigger, f"{r.latency_ms:.1f}", r.status)
    show(table, wide)


def print_executed(result: MissionResult, verbose: bool, wide: bool) -> None:
    """The primitives the mission ran: in brief, or (``verbose``) every run in order, its
    action and the primitives it ran (an interpolation blends several)."""
    runs = [e for e in result.executed if e["labels"]]
    if not runs:
        return
    methods = counted([str(e["method"]) for e in runs])
    used = Counter(label for e in runs for label in e["labels"])
    top = ", ".join(f"{label} ({n})" for label, n in used.most_common(3))
    console.print(
        f"executed: {len(runs)} runs ({methods}) of {len(used)} primitives; most used: {top}",
        soft_wrap=wide,
    )
    if not verbose:
        console.print("(--verbose: every replan and every run)")
        return
    table = Table.grid(padding=(0, 2))
    table.add_column(justify="right", no_wrap=True)
    table.add_column(no_wrap=True)
    table.add_column(overflow="fold", no_wrap=wide)  # ids wrap at " + ", never cut
    for e in runs:
        span = f"{e['from']:g}-{e['to']:g} s"
        table.add_row(span, str(e["method"]), f"{e['action']}\n  " + " + ".join(e["labels"]))
    show(table, wide)


def show(table: Table, wide: bool) -> None:
    """A table at the terminal's width (cells wrap, nothing is cut), or at its own."""
    if wide:  # a console of the table's own width (a console's print never goes wider)
        Console(file=console.file, width=max(console.width, table_width(table))).print(table)
    else:
        console.print(table)


def table_width(table: Table) -> int:
    """The width of ``table`` with every cell on one line."""
    return (
        sum(
            max(
                [len(str(col.header))]
                + [len(line) for cell in col.cells for line in str(cell).splitlines()]
            )
            + 2
            for col in table.columns
        )
        + 2
    )


def mission(
    file: Annotated[Path, typer.Argument(help="mission JSON (see examples/)")],
    out: Annotated[Path | None, typer.Option(help="trajectory plot (PNG)")] = None,
    library: Annotated[
        Path | None, typer.Option(help="primitive library (default: bundled)")
    ] = None,
    verbose: Annotated[
        bool, typer.Option("--verbose", "-v", help="every replan and every primitive run")
    ] = False,
    wide: Annotated[
        bool, typer.Option("--wide", help="tables one row a line, however wide (no wrapping)")
    ] = False,
    maps: Annotated[
        list[Path] | None,
        typer.Option(
            "--map",
            help="a ROS map_server map (its YAML; the image it names is relative to it), known "
            "to the planner; repeatable",
        ),
    ] = None,
    hidden_maps: Annotated[
        list[Path] | None,
        typer.Option(
            "--hidden-map",
            help="a map_server map the robot must sense (binary); repeatable",
        ),
    ] = None,
    as_json: AsJson = False,
) -> None:
    """Run a mission headless, print a summary and write a trajectory plot."""
    extra = [*map_entries(maps or [], True), *map_entries(hidden_maps or [], False)]
    try:
        spec = load_mission(file, extra)
        runner = MissionRunner(spec, load_library(library))
    except (MissionFileError, MissionError) as exc:
        raise fail(str(exc)) from exc
    result = runner.run()
    path = plot_mission(spec, result, out or Path("out") / f"{spec.name}.png", sensed_cells(runner))
    if as_json:
        emit({**result.summary(), "plot": str(path)})
    else:
        print_summary(result, verbose, wide)
        console.print(f"plot: {path}", soft_wrap=True)
    if result.status != "succeeded":
        raise typer.Exit(code=1)


def map_entries(paths: list[Path], known: bool) -> list[dict[str, object]]:
    """Map YAML files as a mission's inline maps (a bad one exits 2, naming the option)."""
    option = "--map" if known else "--hidden-map"
    out = []
    for path in paths:
        try:
            out.append(read_map_yaml(path, known).model_dump())
        except MapError as exc:
            raise fail(f"{option} {path}: {exc}") from exc
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(p) for p in first["loc"]) or "map"
            raise fail(f"{option} {path}: {where}: {first['msg']}") from exc
    return out


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
    console.print(f"plot: {path}", soft_wrap=True)
