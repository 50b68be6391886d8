"""A mission's trajectory as a figure: the path, the body's outline, obstacles, goals, replans
and what the world model sensed (used by the CLI and the paper's experiments)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

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


def plot_mission(
    spec: MissionSpec, result: MissionResult, out: Path, sensed: Sequence[Sequence[float]]
) -> Path:
    """The mission's trajectory plot, replans marked where they happened; returns its path."""
    states = np.array([row[1:] for row in result.trajectory])
    world = World(spec.bounds.bounds(), tuple(spec.world_obstacles()))
    replans = [(e["t"], e["trigger"]) for e in result.events if e["kind"] == "replan"]
    times = np.array([row[0] for row in result.trajectory])
    marks = []
    for t, trigger in replans:
        k = int(np.searchsorted(times, t))
        k = min(k, len(states) - 1)
        marks.append((float(states[k, 0]), float(states[k, 1]), trigger))
    title = f"{spec.name}: {result.status} ({result.model_time:g} model s)"
    return plot_trajectories(
        out,
        [states],
        title=title,
        goals=[(g.x, g.y) for g in result.goals],
        world=world,
        outlines=6,
        marks=marks,
        points=[(float(p[0]), float(p[1])) for p in sensed],
    )
