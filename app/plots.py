"""Matplotlib figures: trajectories with the robot's outline, obstacles, goals and events.

One look for every trajectory plot (``mission``, ``paper``, ``simulate``, ``library plot``): the
view fits what moved (with a margin) rather than the whole arena; one path is coloured by model
time (with a colour bar), several paths are labelled runs; events are markers grouped in a
compact legend (never stacked text labels); the start of each path is marked; the legend sits
outside the axes.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; no display on servers and CI
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Patch
from matplotlib.patches import Polygon as PolygonPatch

from sim.obstacles import Circle, Obstacle
from sim.raster import OccupancyRaster
from sim.robot import Array
from sim.world import World, footprint

MARGIN = 0.15  # of the larger side of what moved, at least MIN_MARGIN metres
MIN_MARGIN = 0.3
TIME_MAP = "viridis"
# Event kind -> (marker, colour); a mark's kind is its text up to the first ":" or " (".
EVENT_STYLE: dict[str, tuple[str, str]] = {
    "replan": ("D", "tab:cyan"),
    "contact": ("X", "tab:red"),
    "collision": ("X", "tab:red"),
    "goal reached": ("*", "tab:green"),
    "goal_reached": ("*", "tab:green"),
    "deform": ("^", "tab:purple"),
    "dropout": ("s", "tab:gray"),
}
OTHER_EVENT = ("P", "tab:orange")


def capsule_outline(a: Array, b: Array, radius: float, n: int = 10) -> Array:
    """Outline ``[2n+2, 2]`` of the stadium around segment a-b."""
    d = b - a
    heading = float(np.arctan2(d[1], d[0])) if np.linalg.norm(d) > 1e-12 else 0.0
    arc = np.linspace(-np.pi / 2, np.pi / 2, n + 1)
    front = b + radius * np.stack([np.cos(heading + arc), np.sin(heading + arc)], axis=-1)
    back = a + radius * np.stack([np.cos(heading + np.pi + arc), np.sin(heading + np.pi + arc)], -1)
    return np.vstack([front, back])


def draw_robot(ax: Axes, state: Array, color: str = "tab:blue", alpha: float = 0.25) -> Array:
    """Draw the head and four units at ``state`` ``[x, y, ψ, φ1, φ2, φ3]``; returns the
    outline points (for fitting the view)."""
    fp = footprint(state[:3], state[3:6])
    outlines = []
    for i, (a, b, r) in enumerate(zip(fp.starts, fp.ends, fp.radii, strict=True)):
        face = "tab:red" if i == 0 else color
        outline = capsule_outline(a, b, float(r))
        outlines.append(outline)
        ax.add_patch(PolygonPatch(outline, closed=True, fc=face, ec="k", lw=0.4, alpha=alpha))
    return np.vstack(outlines)


def draw_world(ax: Axes, world: World | None, obstacles: Sequence[Obstacle] = ()) -> None:
    """The arena's walls, known obstacles (filled) and hidden ones (hatched)."""
    if world is not None:
        b = world.bounds
        ax.plot(
            [b.xmin, b.xmax, b.xmax, b.xmin, b.xmin],
            [b.ymin, b.ymin, b.ymax, b.ymax, b.ymin],
            color="0.5",
            lw=0.8,
        )
        obstacles = (*world.obstacles, *obstacles)
        for raster in world.rasters:
            draw_raster(ax, raster)
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


def draw_raster(ax: Axes, raster: OccupancyRaster) -> None:
    """A map's occupied cells (dark) and unknown cells (light), in the map's own frame turned
    by its yaw about its origin."""
    from matplotlib.colors import ListedColormap
    from matplotlib.transforms import Affine2D

    shade = np.where(raster.cells == 1, 1.0, np.where(raster.cells == -1, 0.5, np.nan))
    x0, y0, yaw = raster.origin
    nx, ny = raster.shape
    r = raster.resolution
    image = ax.imshow(
        shade.T,
        origin="lower",
        extent=(x0, x0 + nx * r, y0, y0 + ny * r),
        cmap=ListedColormap(["0.85", "0.3"]),
        vmin=0.5,
        vmax=1.0,
        interpolation="nearest",
        zorder=1,
    )
    if yaw:
        image.set_transform(Affine2D().rotate_around(x0, y0, yaw) + ax.transData)


def event_kind(text: str) -> str:
    """The kind of an event mark: ``"replan: path_blocked"`` -> ``"replan"``."""
    return text.split(":")[0].split(" (")[0].strip()


def fit_view(ax: Axes, points: Array) -> None:
    """Limit the axes to ``points`` ``[N, 2]`` plus a margin (equal scales)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    margin = max(MARGIN * float(np.max(hi - lo)), MIN_MARGIN)
    ax.set_xlim(lo[0] - margin, hi[0] + margin)
    ax.set_ylim(lo[1] - margin, hi[1] + margin)
    ax.set_aspect("equal", adjustable="box")  # the box takes the data's shape: limits hold


def _time_path(ax: Axes, states: Array, times: Array) -> LineCollection:
    segments = np.stack([states[:-1, :2], states[1:, :2]], axis=1)
    line = LineCollection(segments.tolist(), cmap=TIME_MAP, lw=2.2, zorder=3)
    line.set_array(0.5 * (times[:-1] + times[1:]))
    ax.add_collection(line)
    return line


def trajectory_figure(
    trajectories: Sequence[Array],
    *,
    title: str = "",
    goals: Sequence[tuple[float, float]] = (),
    world: World | None = None,
    outlines: int = 4,
    labels: Sequence[str] = (),
    marks: Sequence[tuple[float, float, str]] = (),
    points: Sequence[tuple[float, float]] = (),
    times: Sequence[Array] = (),
) -> Figure:
    """The figure of :func:`plot_trajectories` (for tests and callers that add to it)."""
    fig, ax = plt.subplots(figsize=(8.5, 6.5))
    draw_world(ax, world)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    handles: list[Artist] = []
    extent: list[Array] = []
    one = len(trajectories) == 1
    for i, states in enumerate(trajectories):
        color = colors[i % len(colors)]
        label = labels[i] if i < len(labels) else (None if one else f"run {i + 1}")
        t = np.asarray(times[i]) if i < len(times) else np.arange(len(states), dtype=float)
        if one and len(states) > 1:  # one path: model time as colour along it
            line = _time_path(ax, states, t)
            bar = fig.colorbar(line, ax=ax, orientation="horizontal", shrink=0.6, pad=0.1)
            bar.set_label("model time [s]" if i < len(times) else "step")
            handles.append(Line2D([], [], color=plt.get_cmap(TIME_MAP)(0.6), lw=2.2))
            handles[-1].set_label(label or "trajectory (colour: time)")
        else:
            (line2d,) = ax.plot(
                states[:, 0], states[:, 1], "-", color=color, lw=1.5, label=label, zorder=3
            )
            handles.append(line2d)
        extent.append(states[:, :2])
        for k in np.linspace(0, len(states) - 1, max(outlines, 2)).astype(int):
            extent.append(draw_robot(ax, states[k], color="tab:blue" if one else color))
    if goals:
        g = np.asarray(goals, dtype=float)
        handles += ax.plot(
            g[:, 0], g[:, 1], "o", ms=9, mfc="none", mec="tab:green", mew=2, label="goal"
        )
        extent.append(g)
    starts = np.unique(
        np.round([states[0, :2] for states in trajectories if len(states)], 6), axis=0
    )
    if len(starts):  # where each path begins (the paper's start pose, or a mission's)
        handles += ax.plot(
            starts[:, 0],
            starts[:, 1],
            "o",
            ms=8,
            mfc="white",
            mec="k",
            mew=1.5,
            zorder=5,
            label="start" if len(starts) == 1 else "starts",
        )
    if points:
        pts = np.asarray(points, dtype=float)
        handles += ax.plot(
            pts[:, 0], pts[:, 1], "s", color="tab:purple", ms=2.5, label="sensed obstacle cells"
        )
    groups: dict[str, list[tuple[float, float]]] = {}
    for mx, my, text in marks:
        groups.setdefault(text, []).append((mx, my))
    counts = Counter({text: len(xy) for text, xy in groups.items()})
    for text, xy in groups.items():
        marker, color = EVENT_STYLE.get(event_kind(text), OTHER_EVENT)
        arr = np.asarray(xy)
        handles += ax.plot(
            arr[:, 0],
            arr[:, 1],
            marker,
            ls="none",
            color=color,
            mec="k",
            mew=0.5,
            ms=8,
            zorder=4,
            label=f"{text} ×{counts[text]}",
        )
    if world is not None:
        if any(o.known for o in world.obstacles):
            handles.append(Patch(fc="0.35", ec="0.2", label="known obstacle"))
        if any(not o.known for o in world.obstacles):
            handles.append(Patch(fc="none", ec="0.2", hatch="//", label="hidden obstacle"))
    if extent:
        fit_view(ax, np.vstack(extent))
    ax.grid(True, lw=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1))
    return fig


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
    times: Sequence[Array] = (),
) -> Path:
    """Write a PNG of state trajectories (``[N, 6]`` each) with outlines at a few instants;
    ``marks`` are events ``(x, y, text)``, ``times`` each trajectory's model times."""
    fig = trajectory_figure(
        trajectories,
        title=title,
        goals=goals,
        world=world,
        outlines=outlines,
        labels=labels,
        marks=marks,
        points=points,
        times=times,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def learning_figure(
    curves: Sequence[Sequence[float]],
    *,
    title: str = "",
    labels: Sequence[str] = (),
    threshold: float | None = None,
) -> Figure:
    """The figure of :func:`plot_learning_curves`."""
    fig, ax = plt.subplots(figsize=(8.5, 4.5))
    for i, curve in enumerate(curves):
        label = labels[i] if i < len(labels) else ("cost" if len(curves) == 1 else f"run {i + 1}")
        ax.plot(range(len(curve)), curve, marker=".", lw=1.2, label=label)
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
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1))
    return fig


def plot_learning_curves(
    path: Path,
    curves: Sequence[Sequence[float]],
    *,
    title: str = "",
    labels: Sequence[str] = (),
    threshold: float | None = None,
) -> Path:
    """Noise-free cost per update (the paper's Figs. 3-5 (ii)), one labelled line per run."""
    fig = learning_figure(curves, title=title, labels=labels, threshold=threshold)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
