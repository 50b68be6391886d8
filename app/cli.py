"""The ``screwsnake`` command line (typer + rich)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from pydantic import ValidationError
from rich.table import Table

from app.api.schemas import SimulateIn
from app.console import AsJson, console, emit, fail, invalid, numbers
from app.missions.spec import Pose
from app.plots import plot_trajectories
from sim.controls import Control, FixedShape, PeriodicGait
from sim.paper_cases import PAPER_CASES
from sim.rollout import JOINT_MODES, RolloutConfig, rollout

cli = typer.Typer(
    help="Learn, plan and run goal-directed locomotion of a screw-drive snake robot.",
    no_args_is_help=True,
    add_completion=False,
)


@cli.callback()
def root() -> None:
    """screwsnake: motor primitives, planning and missions for a screw-drive snake robot."""


Triple = tuple[float, float, float]
Quad = tuple[float, float, float, float]


@cli.command()
def simulate(
    case: Annotated[
        str | None, typer.Option(help=f"a paper case: {', '.join(PAPER_CASES)}")
    ] = None,
    theta: Annotated[
        Quad | None,
        typer.Option(
            metavar="T1 T2 T3 T4", parser=numbers("T1 T2 T3 T4"), help="screw speeds (rad/s)"
        ),
    ] = None,
    joints: Annotated[
        Triple | None,
        typer.Option(
            metavar="P1 P2 P3", parser=numbers("P1 P2 P3"), help="held joint angles (rad)"
        ),
    ] = None,
    phases: Annotated[
        Triple | None,
        typer.Option(metavar="F1 F2 F3", parser=numbers("F1 F2 F3"), help="gait phases (rad)"),
    ] = None,
    start: Annotated[
        Triple,
        typer.Option(metavar="X Y PSI", parser=numbers("X Y PSI"), help="start pose (m, m, rad)"),
    ] = (0.0, 0.0, 0.0),
    duration: Annotated[float, typer.Option(help="model seconds")] = 100.0,
    dt: Annotated[float, typer.Option(help="Euler step (model s)")] = 1.0,
    joint_mode: Annotated[str, typer.Option(help="paper (quasi-static) or complete")] = "paper",
    out: Annotated[
        Path | None,
        typer.Option(help="trajectory plot (PNG); default: out/ named after the inputs"),
    ] = None,
    as_json: AsJson = False,
) -> None:
    """Run one control open-loop, print the end pose and write a trajectory plot."""
    goal: tuple[float, float] | None = None
    if case is None and theta is not None:  # what POST /simulate rejects is rejected here too
        try:
            SimulateIn(
                theta=list(theta),
                joints=None if joints is None else list(joints),
                phases=None if phases is None else list(phases),
                duration=duration,
                dt=dt,
                start=Pose(x=start[0], y=start[1], psi=start[2]),
                joint_mode=joint_mode,  # type: ignore[arg-type]  # checked by the model
            )
        except ValidationError as exc:
            raise invalid(exc) from exc
    try:
        control: Control
        if case is not None:
            if case not in PAPER_CASES:
                raise ValueError(f"case: unknown {case!r}; known: {', '.join(PAPER_CASES)}")
            paper = PAPER_CASES[case]
            control, goal = paper.control(), paper.goal
        elif theta is None:
            raise ValueError("give --case NAME or --theta with --joints or --phases")
        elif phases is not None:
            control = PeriodicGait.of(theta, phases)
        else:
            control = FixedShape.of(theta, joints or (0.0, 0.0, 0.0))
        if joint_mode not in JOINT_MODES:
            raise ValueError(f"joint-mode: one of {', '.join(JOINT_MODES)}")
        config = RolloutConfig(duration, dt, joint_mode)
        states = rollout(control, start, config).states[0]
    except ValueError as exc:
        raise fail(str(exc)) from exc
    end = states[-1]
    if case is not None:
        paper = PAPER_CASES[case]
        theta, joints, phases = paper.theta, paper.joints, paper.phases
    settings = (config.duration, config.dt, joint_mode)
    path = out or Path("out") / f"{output_name(case, theta, joints, phases, settings)}.png"
    times = np.arange(len(states), dtype=np.float64) * config.dt
    title = simulation_title(case, theta, joints, phases, settings)
    plot_trajectories(path, [states], title=title, goals=[goal] if goal else [], times=[times])
    error = None if goal is None else float(np.hypot(end[0] - goal[0], end[1] - goal[1]))
    if as_json:
        emit(
            {
                "end": {"x": float(end[0]), "y": float(end[1]), "psi": float(end[2])},
                "duration": config.duration,
                "steps": config.steps,
                "goal": goal,
                "distance": error,
                "plot": str(path),
            }
        )
        return
    table = Table(title=f"end pose after {config.duration:g} model s ({config.steps} steps)")
    for col in ("x (m)", "y (m)", "ψ (deg)"):
        table.add_column(col, justify="right")
    table.add_row(f"{end[0]:.3f}", f"{end[1]:.3f}", f"{math.degrees(end[2]):.1f}")
    console.print(table)
    if goal is not None:
        console.print(f"goal {goal}: distance {error:.3f} m")
    console.print(f"plot: {path}", soft_wrap=True)


def numbers_text(values: tuple[float, ...], sep: str = ", ") -> str:
    return sep.join(f"{v:g}" for v in values)


def output_name(
    case: str | None,
    theta: Quad | None,
    joints: Triple | None,
    phases: Triple | None,
    settings: tuple[float, float, str],
) -> str:
    """The plot's file name, after what was simulated: two runs with other inputs never write
    the same file (``simulate-exp4``, ``simulate-theta-1_1_-1_1-joints0_0_0``)."""
    duration, dt, joint_mode = settings
    if case is not None:
        name = f"simulate-{case}"
    else:
        assert theta is not None
        shape = (
            f"phases{numbers_text(phases, '_')}"
            if phases
            else f"joints{numbers_text(joints or (0.0, 0.0, 0.0), '_')}"
        )
        name = f"simulate-theta{numbers_text(theta, '_')}-{shape}"
    if duration != 100.0:
        name += f"-T{duration:g}"
    if dt != 1.0:
        name += f"-dt{dt:g}"
    if joint_mode != "paper":
        name += f"-{joint_mode}"
    return name


def simulation_title(
    case: str | None,
    theta: Quad | None,
    joints: Triple | None,
    phases: Triple | None,
    settings: tuple[float, float, str],
) -> str:
    """What the plot shows: the case and its parameters, the duration and step."""
    duration, dt, joint_mode = settings
    assert theta is not None
    shape = (
        f"gait phases ({numbers_text(phases)}) rad"
        if phases
        else f"joints ({numbers_text(joints or (0.0, 0.0, 0.0))}) rad"
    )
    head = f"{case} ({PAPER_CASES[case].figure} of the paper): " if case else "open loop: "
    return (
        f"{head}screw speeds ({numbers_text(theta)}) rad/s, {shape}\n"
        f"{duration:g} model s, dt {dt:g} s, {joint_mode} kinematics"
    )


@cli.command()
def serve(
    host: Annotated[str, typer.Option(help="interface to listen on")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="TCP port")] = 8000,
    ws_deflate: Annotated[
        bool,
        typer.Option(
            help="compress websocket frames (permessage-deflate); off by default: a frame is "
            "compressed on the event loop in one piece (a 10,000-obstacle mission's 2 MB "
            "snapshot took ~50 ms, every other request waiting), and state frames are small"
        ),
    ] = False,
) -> None:
    """Serve the API, the websocket and the viewer (SQLite file and bundled library by default)."""
    import uvicorn

    from app.settings import Settings, missing_extra

    needed = missing_extra(Settings.from_env())
    if needed is not None:
        raise fail(needed)
    console.print(f"screwsnake serving on http://{host}:{port}/  (API docs at /docs)")
    uvicorn.run(
        "app.main:app", host=host, port=port, log_level="info", ws_per_message_deflate=ws_deflate
    )


def _register() -> None:
    from app.cli_missions import mission, paper
    from app.cli_primitives import learn, library_cli

    cli.command()(learn)
    cli.command()(mission)
    cli.command()(paper)
    cli.add_typer(library_cli, name="library")


_register()


def main() -> None:
    cli()
