"""CLI commands for learning primitives and managing the primitive library."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from pydantic import ValidationError
from rich import box
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from app.api.schemas import LearnIn
from app.console import AsJson, console, emit, fail, invalid, numbers
from app.plots import plot_learning_curves, plot_trajectories
from primitives.build import build_library
from primitives.catalogue import FAMILIES, PrimitiveSpec, default_specs, grid_specs, lattice_specs
from primitives.executors import make_executor
from primitives.learners import LEARNERS, StopRule, UpdateRecord, make_learner
from primitives.library import Library, LibraryError, Primitive, bundled_library_path
from primitives.params import ParameterSpace
from primitives.shape_learning import LearningStopped, learn_shape
from primitives.shapes import SHAPES, learned_name, shape_named
from primitives.task import LearningTask
from sim.rollout import rollout

library_cli = typer.Typer(
    help="Build, inspect and plot the primitive library.", no_args_is_help=True
)


def learn(
    goal: Annotated[
        tuple[float, float],
        typer.Option(metavar="X Y", parser=numbers("X Y"), help="goal in the start frame (m)"),
    ],
    shape: Annotated[
        str, typer.Option(help=f"one of {', '.join(SHAPES)}, or 'free' (U2)")
    ] = "straight",
    learner: Annotated[str, typer.Option(help=f"one of {', '.join(LEARNERS)}")] = "pi2",
    seed: Annotated[int, typer.Option(help="random seed")] = 0,
    threshold: Annotated[float, typer.Option(help="stop below this cost (m)")] = 0.05,
    max_updates: Annotated[int, typer.Option(help="update budget")] = 100,
    out: Annotated[
        Path | None,
        typer.Option(help="learning-curve plot (PNG); default: out/ named after the inputs"),
    ] = None,
    as_json: AsJson = False,
) -> None:
    """Learn one primitive, with a progress bar and a learning-curve plot; exits 1 when it
    does not converge below the threshold."""
    try:  # the API's request model: what POST /jobs/learn rejects is rejected here too
        LearnIn(
            goal=goal,
            shape=shape,
            learner=learner,  # type: ignore[arg-type]  # checked by the model
            seed=seed,
            threshold=threshold,
            max_updates=max_updates,
        )
    except ValidationError as exc:
        raise invalid(exc) from exc
    try:
        space = ParameterSpace.for_shape(shape)
        task = LearningTask(goal, space)
        algo = make_learner(learner)
        stop = StopRule(threshold, max_updates)
    except ValueError as exc:
        raise fail(str(exc)) from exc
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console, transient=True, disable=as_json) as bar:
        job = bar.add_task(f"{algo.name} → {goal}", total=max_updates)

        def tick(record: UpdateRecord) -> None:
            bar.update(
                job, completed=record.update, description=f"{algo.name}: cost {record.cost:.3f} m"
            )

        result = algo.learn(task, seed, stop, progress=tick)
    theta, joints, phases = space.split(result.params)
    x, y = goal
    out = out or Path("out") / f"learn-{shape}-goal{x:g}_{y:g}-{learner}-seed{seed}.png"
    plot_learning_curves(
        out,
        [result.curve],
        title=f"learning {shape} to goal ({x:g}, {y:g}) m: {algo.name}, seed {seed}",
        threshold=threshold,
    )
    if as_json:
        emit(
            {
                "converged": result.converged,
                "cost": result.cost,
                "updates": result.updates,
                "rollouts": result.rollouts,
                "wall_ms": round(result.wall_time * 1e3, 1),
                "theta": np.round(theta, 6).tolist(),
                "joints": None if joints is None else np.round(joints, 6).tolist(),
                "phases": None if phases is None else np.round(phases, 6).tolist(),
                "curve": list(result.curve),
                "plot": str(out),
            }
        )
    else:
        verdict = (
            "[green]converged[/green]" if result.converged else "[yellow]not converged[/yellow]"
        )
        console.print(
            f"{verdict}: cost {result.cost:.4f} m after {result.updates} updates, "
            f"{result.rollouts} rollouts, {result.wall_time * 1e3:.0f} ms"
        )
        console.print(f"theta = {np.round(theta, 3).tolist()}")
        shape_values = phases if phases is not None else joints or []
        console.print(f"{'phases' if phases else 'joints'} = {np.round(shape_values, 3).tolist()}")
        console.print(f"plot: {out}", soft_wrap=True)
    if not result.converged:
        raise typer.Exit(code=1)  # like a failed mission: scripts see that it did not work


def load_library(path: Path | None) -> Library:
    try:
        return Library.load(path or bundled_library_path())
    except LibraryError as exc:
        raise fail(str(exc)) from exc


@library_cli.command("build")
def library_build(
    out: Annotated[Path, typer.Option(help="where to write the library JSON")] = Path(
        "var/library.json"
    ),
    learner: Annotated[str, typer.Option(help=f"one of {', '.join(LEARNERS)}")] = "pi2",
    seed: Annotated[int, typer.Option(help="base seed (entry i uses seed + i)")] = 0,
    grid: Annotated[
        bool, typer.Option(help="8 headings × 1, 2, 3 m per shape instead of Fig. 6")
    ] = False,
    family: Annotated[
        str,
        typer.Option(
            help="paper (Fig. 6 or --grid), lattice (short translations and turns of each "
            "shape) or both"
        ),
    ] = "both",
    shapes: Annotated[str, typer.Option(help="comma-separated shapes")] = ",".join(SHAPES),
    executor: Annotated[str, typer.Option(help="serial, local (process pool) or ray")] = "local",
    workers: Annotated[
        int | None, typer.Option(help="worker processes (default: all cores)")
    ] = None,
    address: Annotated[
        str | None, typer.Option(help="Ray cluster address, e.g. ray://head:10001")
    ] = None,
    as_json: AsJson = False,
) -> None:
    """Learn every primitive of the catalogue (deterministic for a seed) and save the library."""
    try:
        names = tuple(s.strip() for s in shapes.split(",") if s.strip())
        for name in names:
            shape_named(name)
        if family not in (*FAMILIES, "both"):
            raise ValueError(f"family: one of {', '.join(FAMILIES)}, both; got {family!r}")
        specs: list[PrimitiveSpec] = []
        if family in ("paper", "both"):  # paper entries first: their seeds do not depend on lattice
            fixed = tuple(n for n in names if not SHAPES[n].periodic)
            specs += grid_specs(fixed) if grid else default_specs(names)
        if family in ("lattice", "both"):
            specs += lattice_specs(names)
        pool = make_executor(executor, workers, address)
        make_learner(learner)
    except ValueError as exc:
        raise fail(str(exc)) from exc
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console, disable=as_json) as bar:
        job = bar.add_task(f"learning ({pool.name})", total=len(specs))
        library = build_library(specs, learner, seed, pool, done=lambda i: bar.advance(job))
    library.save(out)
    parts, families = [], {}
    for name in FAMILIES:
        entries = [e for e in library if e.family == name]
        if entries:
            worst = max(e.cost for e in entries)
            families[name] = {"primitives": len(entries), "worst_cost": worst}
            parts.append(f"{len(entries)} {name} (worst cost {worst * 100:.2f} cm)")
    if as_json:
        emit({"out": str(out), "primitives": len(library), "families": families})
        return
    console.print(f"{len(library)} primitives: {', '.join(parts) or 'none'} → {out}")


@library_cli.command("learn-shape")
def learn_shape_command(
    joints: Annotated[
        str, typer.Option(metavar="A,B,C", help="the fixed shape's three joint angles (rad)")
    ],
    library: Annotated[
        Path | None, typer.Option(help="the library to extend (default: the bundled one)")
    ] = None,
    out: Annotated[
        Path, typer.Option(help="where to save the library with the learned shape")
    ] = Path("out/library-learned.json"),
    budget: Annotated[float, typer.Option(help="wall seconds for the whole set")] = 30.0,
    as_json: AsJson = False,
) -> None:
    """Learn a fixed shape's lattice primitives (as a mission or POST /jobs/learn does: PI²-CMA,
    a seed from the shape) and save the library with them; the input file is not changed."""
    try:
        angles = tuple(float(v) for v in joints.split(","))
    except ValueError:
        raise fail(f"joints: three numbers a,b,c (radians); got {joints!r}") from None
    try:  # the API's request model: the same joint limits as POST /jobs/learn
        LearnIn.model_validate({"joints": angles})
    except ValidationError as exc:
        raise invalid(exc) from exc
    path = library or bundled_library_path()
    if out.resolve() == path.resolve() or out.resolve() == bundled_library_path().resolve():
        raise fail(f"out: {out} is the input library; save the learned library elsewhere")
    try:
        base = Library.load(path)
    except LibraryError as exc:
        raise fail(str(exc)) from exc
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn())
    with Progress(*columns, console=console, disable=as_json) as bar:
        task = bar.add_task(f"learning {learned_name(angles)}", total=None)
        try:
            learned = learn_shape(
                angles,
                budget=budget,
                progress=lambda done, total: bar.update(task, completed=done, total=total),
            )
        except LearningStopped as exc:
            raise fail(f"learning: {exc}") from exc
    grown = base.with_entries(learned.entries)
    grown.save(out)
    summary = {**learned.summary(), "out": str(out), "library": grown.version[:12]}
    if as_json:
        emit(summary)
    else:
        left = f", left out: {', '.join(learned.failed)}" if learned.failed else ""
        console.print(
            f"{learned.shape}: {len(learned.entries)} lattice primitives in "
            f"{learned.wall:.2f} s ({learned.rollouts} rollouts{left}) → {out}"
        )
    if not learned.entries:
        raise typer.Exit(1)


@library_cli.command("show")
def library_show(
    path: Annotated[
        Path | None, typer.Argument(help="library JSON (default: the bundled one)")
    ] = None,
    shape: Annotated[str | None, typer.Option(help="only this shape")] = None,
    family: Annotated[str | None, typer.Option(help="only this family: paper or lattice")] = None,
    params: Annotated[
        bool, typer.Option("--params", help="add the parameters (θ̇, φ/ϕ): a wide table")
    ] = False,
    as_json: AsJson = False,
) -> None:
    """List the primitives: id, label, goal, direction, turn, duration, error, updates."""
    library = load_library(path)
    if shape is not None and not library.of_shape(shape):
        raise fail(f"no primitives of shape {shape!r}; shapes: {', '.join(library.shapes())}")
    if family is not None and family not in FAMILIES:
        raise fail(f"family: one of {', '.join(FAMILIES)}; got {family!r}")
    entries = [
        e for e in library if (not shape or e.shape == shape) and (not family or e.family == family)
    ]
    if as_json:
        emit(
            {
                "total": len(library),
                "shown": len(entries),
                "primitives": [entry_dict(e) for e in entries],
            }
        )
        return
    console.print(primitives_table(entries, len(library), params))


def entry_dict(e: Primitive) -> dict[str, object]:
    """A primitive as JSON-ready data (what ``library show --json`` prints)."""
    return {
        "id": e.id,
        "label": e.label,
        "shape": e.shape,
        "family": e.family,
        "goal": list(e.goal),
        "direction": e.direction,
        "turn": e.turn,
        "duration": e.rollout.duration,
        "theta": list(e.theta),
        "joints": None if e.joints is None else list(e.joints),
        "phases": None if e.phases is None else list(e.phases),
        "cost": e.cost,
        "updates": e.updates,
    }


def primitives_table(entries: list[Primitive], total: int, params: bool) -> Table:
    """The primitives as a table that fits 80 columns (without ``params``): ids are what users
    copy into missions, so they are never cut; the title counts the rows shown."""
    title = f"{len(entries)} primitives" + (f" (of {total})" if len(entries) < total else "")
    table = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    table.add_column("id", no_wrap=True, min_width=max((len(e.id) for e in entries), default=2))
    columns = ["label", "goal (m)", "dir°", "turn°", "T s"]  # the id names the shape
    columns += [*(["θ̇ rad/s", "φ / ϕ rad"] if params else []), "err cm", "upd"]
    for col in columns:
        table.add_column(col, justify="left" if col == "label" else "right", no_wrap=not params)
    for e in entries:
        row = [e.id, e.label or ""]
        row += [
            f"{e.goal[0]:.2f},{e.goal[1]:.2f}",
            f"{e.direction:.0f}",
            f"{math.degrees(e.turn):+.3g}" if e.family == "lattice" else "",
            f"{e.rollout.duration:g}",
        ]
        if params:
            row += [
                " ".join(f"{v:+.2f}" for v in e.theta),
                " ".join(f"{v:+.2f}" for v in (e.phases or e.joints or ())),
            ]
        row += [f"{e.cost * 100:.1f}", str(e.updates)]
        table.add_row(*row)
    return table


@library_cli.command("plot")
def library_plot(
    path: Annotated[
        Path | None, typer.Argument(help="library JSON (default: the bundled one)")
    ] = None,
    shape: Annotated[str, typer.Option(help="shape to draw")] = "straight",
    out: Annotated[Path, typer.Option(help="PNG to write")] = Path("out/library.png"),
    as_json: AsJson = False,
) -> None:
    """Draw each primitive's trajectory from the start pose, like the paper's Fig. 6."""
    library = load_library(path)
    entries = library.of_shape(shape)
    if not entries:
        raise fail(f"no primitives of shape {shape!r}; shapes: {', '.join(library.shapes())}")
    states = [rollout(e.control()).states[0] for e in entries]
    plot_trajectories(
        out,
        states,
        title=f"{len(entries)} {shape} primitives of {(path or bundled_library_path()).name}, "
        "each from the start pose (0, 0, ψ = 0)",
        goals=[e.goal for e in entries],
        outlines=2,
        labels=[e.name for e in entries],
    )
    if as_json:
        emit({"plot": str(out), "primitives": [e.id for e in entries]})
        return
    console.print(f"plot: {out}", soft_wrap=True)
