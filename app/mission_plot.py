"""A mission's trajectory as a figure: the path coloured by model time, the body's outline,
obstacles, goals, events as markers and what the world model sensed (used by the CLI and the
paper's experiments)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from app.executor.context import MissionResult
from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from app.plots import plot_trajectories
from sim.world import World


def sensed_cells(runner: MissionRunner) -> list[list[float]]:
    """Where the world model holds sensed or contact obstacles (cell centres)."""
    world = runner.ctx.world.to_dict()
    return [*world.get("sensed", []), *world.get("contact", [])]


def event_marks(
    events: Sequence[dict[str, Any]], trajectory: Sequence[Sequence[float]]
) -> list[tuple[float, float, str]]:
    """Events as plot marks ``(x, y, text)``: a contact where it touched, the others where the
    robot was at the event's model time; texts group alike events (``replan: path_blocked``)."""
    if not trajectory:
        return []
    times = np.array([row[0] for row in trajectory])
    marks = []
    for e in events:
        kind = e.get("kind", "")
        if kind == "obstacle_sensed":  # every few ticks: the sensed cells show this instead
            continue
        if kind == "collision" and isinstance(e.get("at"), list):
            x, y = float(e["at"][0]), float(e["at"][1])
        else:
            k = min(int(np.searchsorted(times, e.get("t", 0.0))), len(times) - 1)
            x, y = float(trajectory[k][1]), float(trajectory[k][2])
        text = {
            "replan": f"replan: {e.get('trigger', '')}",
            "collision": "contact",
            "goal_reached": "goal reached",
        }.get(kind, kind)
        marks.append((x, y, text))
    return marks


def plot_mission(
    spec: MissionSpec, result: MissionResult, out: Path, sensed: Sequence[Sequence[float]]
) -> Path:
    """The mission's path coloured by model time, its events as markers, what it sensed."""
    states = np.array([row[1:] for row in result.trajectory])
    rasters = tuple(raster for raster, _ in spec.world_maps())
    world = World(spec.bounds.bounds(), tuple(spec.world_obstacles()), rasters)
    title = f"{spec.name}: {result.status} ({result.model_time:g} model s)"
    return plot_trajectories(
        out,
        [states],
        title=title,
        goals=[(g.x, g.y) for g in result.goals],
        world=world,
        outlines=6,
        marks=event_marks(result.events, result.trajectory),
        points=[(float(p[0]), float(p[1])) for p in sensed],
        times=[np.array([row[0] for row in result.trajectory])],
    )
