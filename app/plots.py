"""Matplotlib figures: trajectories with the robot's outline, obstacles and goals."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; no display on servers and CI
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Polygon as PolygonPatch

from sim.obstacles import Circle, Obstacle
from sim.robot import Array
from sim.world import World, footprint


def capsule_outline(a: Array, b: Array, radius: float, n: int = 10) -> Array:
    """Outline ``[2n+2, 2]`` of the stadium around segment a-b."""
    d = b - a
    heading = float(np.arctan2(d[1], d[0])) if np.linalg.norm(d) > 1e-12 else 0.0
    arc = np.linspace(-np.pi / 2, np.pi / 2, n + 1)
    front = b + radius * np.stack([np.cos(heading + arc), np.sin(heading + arc)], axis=-1)
    back = a + radius * np.stack([np.cos(heading + np.pi + arc), np.sin(heading + np.pi + arc)], -1)
    return np.vstack([front, back])


def draw_robot(ax: Axes, state: Array, color: str = "tab:blue", alpha: float = 0.35) -> None:
    """Draw the head and four units at ``state`` ``[x, y, ψ, φ1, φ2, φ3]``."""
    fp = footprint(state[:3], state[3:6])
    for i, (a, b, r) in enumerate(zip(fp.starts, fp.ends, fp.radii, strict=True)):
        face = "tab:red" if i == 0 else color
        ax.add_patch(
            PolygonPatch(
                capsule_outline(a, b, float(r)), closed=True, fc=face, ec="k", lw=0.4, alpha=alpha
            )
        )


def draw_world(ax: Axes, world: World | None, obstacles: Sequence[Obstacle] = ()) -> None:
    if world is not None:
        b = world.bounds
        ax.plot(
            [b.xmin, b.xmax, b.xmax, b.xmin, b.xmin],
            [b.ymin, b.ymin, b.ymax, b.ymax, b.ymin],
            color="0.5",
            lw=0.8,
        )
        obstacles = (*world.obstacles, *obstacles)
    for ob in obstacles:
        style = {
            "fc": "0.35" if ob.known else "none",
            "ec": "0.2",
            "hatch": None if ob.known else "//",
        }
        if isinstance(ob, Circle):
            ax.add_patch(CirclePatch((ob.x, ob.y), ob.radius, **style))
        else:
            ax.add_patch(PolygonPatch(ob.vertices, closed=True, **style))


def plot_trajectories(
    path: Path,
    trajectories: Sequence[Array],
    *,
    title: str = "",
    goals: Sequence[tuple[float, float]] = (),
    world: World | None = None,
    outlines: int = 4,
    labels: Sequence[str] = (),
    marks: Sequence[tuple[float, float, str]] = (),
    points: Sequence[tuple[float, float]] = (),
) -> Path:
    """Write a PNG of state trajectories (``[N, 6]`` each) with outlines at a few instants."""
    fig, ax = plt.subplots(figsize=(7, 7))
    draw_world(ax, world)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, states in enumerate(trajectories):
        color = colors[i % len(colors)]
        label = labels[i] if i < len(labels) else None
        ax.plot(states[:, 0], states[:, 1], "-", color=color, lw=1.5, label=label)
        for k in np.linspace(0, len(states) - 1, max(outlines, 2)).astype(int):
            draw_robot(ax, states[k], color=color)
    for gx, gy in goals:
        ax.plot(gx, gy, "o", ms=9, mfc="none", mec="tab:green", mew=2)
    if points:
        pts = np.asarray(points)
        ax.plot(pts[:, 0], pts[:, 1], ".", color="tab:purple", ms=3, label="sensed")
    for mx, my, text in marks:
        ax.plot(mx, my, "x", color="tab:orange", ms=8, mew=2)
        ax.annotate(text, (mx, my), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.plot(0, 0, "k+", ms=10)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    if labels:
        ax.legend(fontsize=8, loc="best")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def plot_learning_curves(
    path: Path,
    curves: Sequence[Sequence[float]],
    *,
    title: str = "",
    labels: Sequence[str] = (),
    threshold: float | None = None,
) -> Path:
    """Noise-free cost per update (the paper's Figs. 3-5 (ii)), one line per run."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, curve in enumerate(curves):
        ax.plot(
            range(len(curve)),
            curve,
            marker=".",
            lw=1.2,
            label=labels[i] if i < len(labels) else None,
        )
    if threshold is not None:
        ax.axhline(
            threshold, color="tab:green", ls="--", lw=0.8, label=f"threshold {threshold:g} m"
        )
    ax.set_xlabel("update")
    ax.set_ylabel("noise-free cost [m]")
    ax.set_yscale("log")
    ax.grid(True, lw=0.3)
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
