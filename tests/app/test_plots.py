"""Plots as a reader sees them: a legend, events as markers (no stacked labels), a fitted view."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from app.mission_plot import event_marks
from app.plots import learning_figure, plot_trajectories, trajectory_figure
from sim.obstacles import Circle
from sim.world import Bounds, World


def path_states(n: int = 200) -> np.ndarray:
    """A 2 m arc inside a 20 m arena, as ``[N, 6]`` states."""
    s = np.linspace(0, 1, n)
    return np.stack([-2 * s, np.sin(np.pi * s), np.zeros(n), *np.zeros((3, n))], axis=1)


def legend_texts(fig: Figure) -> list[str]:
    legend = fig.axes[0].get_legend()
    assert legend is not None
    return [t.get_text() for t in legend.get_texts()]


def text_boxes_overlap(fig: Figure) -> list[tuple[str, str]]:
    """Pairs of visible texts in the axes (annotations, legend entries) whose boxes overlap."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    ax = fig.axes[0]
    texts = [t for t in ax.texts if t.get_visible() and t.get_text()]
    legend = ax.get_legend()
    if legend is not None:
        texts += legend.get_texts()
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in texts]
    return [
        (a, b)
        for i, (a, box_a) in enumerate(boxes)
        for b, box_b in boxes[i + 1 :]
        if box_a.overlaps(box_b)
    ]


def test_mission_plot_has_a_legend_and_event_markers_that_do_not_overlap() -> None:
    states = path_states()
    times = np.linspace(0, 100, len(states))
    trajectory = [[t, *row] for t, row in zip(times, states.tolist(), strict=True)]
    # 22 replans at almost the same place (the pile of labels) and a contact.
    events = [{"t": 40 + 0.1 * i, "kind": "replan", "trigger": "path_blocked"} for i in range(22)]
    events += [{"t": 60, "kind": "collision", "part": 1, "side": "left", "at": [-1.0, 1.0]}]
    events += [{"t": 99, "kind": "goal_reached", "goal": 0}]
    world = World(Bounds(-10, 10, -10, 10), (Circle(-1, 1.6, 0.2, known=False),))
    fig = trajectory_figure(
        [states],
        title="t",
        goals=[(-2.0, 0.0)],
        world=world,
        marks=event_marks(events, trajectory),
        times=[times],
    )
    texts = legend_texts(fig)
    assert "replan: path_blocked ×22" in texts and "contact ×1" in texts
    assert "goal reached ×1" in texts and "goal" in texts and "hidden obstacle" in texts
    assert len(fig.axes[0].texts) == 0  # no label next to any marker
    assert text_boxes_overlap(fig) == []
    # Fitted to the path (2 m wide), not to the 20 m arena; a colour bar for model time.
    x0, x1 = fig.axes[0].get_xlim()
    assert -3.5 < x0 < -2 and 0 < x1 < 1.5
    assert any(ax.get_xlabel() == "model time [s]" for ax in fig.axes[1:])
    plt.close(fig)


def test_multi_run_plots_label_every_run(tmp_path: Path) -> None:
    fig = trajectory_figure([path_states(), path_states() * 0.5, path_states() * 0.25])
    assert {"run 1", "run 2", "run 3"} <= set(legend_texts(fig))
    plt.close(fig)
    curves = [[1.0 / (k + 1 + i) for k in range(10)] for i in range(10)]
    fig = learning_figure(curves, labels=[f"seed {i}" for i in range(10)], threshold=0.05)
    texts = legend_texts(fig)
    assert [f"seed {i}" for i in range(10)] == texts[:10] and "threshold 0.05 m" in texts
    assert text_boxes_overlap(fig) == []
    plt.close(fig)
    out = plot_trajectories(tmp_path / "p.png", [path_states()], times=[np.arange(200.0)])
    assert out.stat().st_size > 10_000
