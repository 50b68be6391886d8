"""The paper's experiments that this system reproduces, each with the paper's figures beside ours."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from app.executor.runner import MissionRunner
from app.mission_plot import plot_mission, sensed_cells
from app.missions.spec import load_mission
from app.plots import plot_learning_curves, plot_trajectories
from primitives.interpolation import interpolate_entries
from primitives.learners import PI2
from primitives.library import Library
from primitives.params import ParameterSpace
from primitives.task import LearningTask
from sim.rollout import rollout

Row = tuple[str, str, str]  # what, the paper, ours


@dataclass(frozen=True)
class Experiment:
    name: str
    figure: str
    title: str
    run: Callable[[Library, Path], tuple[list[Row], Path]]


def examples_dir() -> Path:
    """Where the example missions live: the checkout's examples/ folder."""
    here = Path(str(resources.files("app"))).parent / "examples"
    return here if here.is_dir() else Path("examples")


LEARNING = {
    "exp1": (
        "Fig. 3a",
        "straight shape, goal (-3, -3)",
        (-3.0, -3.0),
        ParameterSpace("U1"),
        "around 20",
    ),
    "exp2": (
        "Fig. 3b",
        "zigzag shape, goal (2, -2)",
        (2.0, -2.0),
        ParameterSpace("U1", (0.5, -0.5, 0.5)),
        "around 16",
    ),
    "exp3": (
        "Fig. 4",
        "all seven parameters, goal (-1, -3)",
        (-1.0, -3.0),
        ParameterSpace("U2"),
        "around 20",
    ),
    "exp4": (
        "Fig. 5",
        "periodic gait, goal (-2, -2)",
        (-2.0, -2.0),
        ParameterSpace("U3"),
        "around 15",
    ),
}


def learning_experiment(name: str) -> Experiment:
    figure, title, goal, space, paper_updates = LEARNING[name]

    def run(library: Library, out: Path) -> tuple[list[Row], Path]:
        task = LearningTask(goal, space)
        results = [PI2().learn(task, seed) for seed in range(10)]
        updates = [r.updates for r in results]
        path = plot_learning_curves(
            out / f"{name}.png",
            [r.curve for r in results],
            title=f"{name}: {title}",
            labels=[f"seed {seed}" for seed in range(len(results))],
            threshold=0.05,
        )
        rows = [
            (
                "updates to < 5 cm (10 runs)",
                f"{paper_updates}; 12-20 overall",
                f"median {np.median(updates):g}, {min(updates)}-{max(updates)}",
            ),
            (
                "final cost",
                "almost zero",
                f"median {np.median([r.cost for r in results]) * 100:.1f} cm",
            ),
            ("rollouts per update", "K = 40", "K = 40 (+1 noise-free)"),
        ]
        return rows, path

    return Experiment(name, figure, f"PI² learning: {title}", run)


def fig6(library: Library, out: Path) -> tuple[list[Row], Path]:
    entries = library.of_shape("straight")
    states = [rollout(e.control()).states[0] for e in entries]
    path = plot_trajectories(
        out / "fig6.png",
        states,
        title="Fig. 6: straight primitives P1s-P8s",
        goals=[e.goal for e in entries],
        outlines=2,
        labels=[e.name for e in entries],
    )
    worst = max(math.dist(s[-1, :2], e.goal) for s, e in zip(states, entries, strict=True))
    return [
        ("primitives P1-P8 reach G1-G8", "yes (Fig. 6)", f"all 8, worst {worst * 100:.1f} cm"),
        (
            "library size",
            "Table 2: 20 listed",
            f"{len(library)} entries, {len(library.shapes())} shapes",
        ),
    ], path


def fig8(library: Library, out: Path) -> tuple[list[Row], Path]:
    made = interpolate_entries(
        [library.get("P1s"), library.get("P12"), library.get("P13")], (2.0, 1.0)
    )
    states = rollout(made.control()).states[0]
    sources = [rollout(library.get(n).control()).states[0] for n in ("P1s", "P12", "P13")]
    path = plot_trajectories(
        out / "fig8.png",
        [*sources, states],
        title="Fig. 8: P1s, P12, P13 -> goal (2, 1)",
        goals=[(2.0, 1.0)],
        outlines=2,
        labels=["P1s", "P12", "P13", "interpolated"],
    )
    err = math.dist(states[-1, :2], (2.0, 1.0))
    return [
        (
            "interpolated end point",
            "reaches (2, 1) (Fig. 8d)",
            f"({states[-1, 0]:.2f}, {states[-1, 1]:.2f}), {err * 100:.0f} cm off",
        )
    ], path


def mission_experiment(name: str, figure: str, title: str, paper: str) -> Experiment:
    def run(library: Library, out: Path) -> tuple[list[Row], Path]:
        spec = load_mission(examples_dir() / f"{name}.json")
        runner = MissionRunner(spec, library)
        result = runner.run()
        path = plot_mission(spec, result, out / f"{name}.png", sensed_cells(runner))
        errors = ", ".join(f"{g.error * 100:.1f}" for g in result.goals if g.error is not None)
        rows = [
            ("outcome", paper, f"{result.status}: {result.reason}"),
            ("goal errors", "about 25 cm on the real robot", f"{errors or '-'} cm"),
            ("collisions / replans", "-", f"{result.collisions} / {len(result.replans)}"),
        ]
        return rows, path

    return Experiment(name, figure, title, run)


EXPERIMENTS: dict[str, Experiment] = {
    **{n: learning_experiment(n) for n in LEARNING},
    "fig6": Experiment("fig6", "Fig. 6", "the primitive library", fig6),
    "fig8": Experiment("fig8", "Fig. 8", "bilinear interpolation across shapes", fig8),
    **{
        e.name: e
        for e in (
            mission_experiment(
                "fig9a-single-goal", "Fig. 9a", "one goal, no obstacles", "goal (-3, -1) reached"
            ),
            mission_experiment(
                "fig9b-obstacles",
                "Fig. 9b",
                "obstacle avoided by replanning",
                "obstacle avoided, goal reached",
            ),
            mission_experiment(
                "fig9b-chain", "Fig. 9b", "manual chain of primitives", "primitives chained"
            ),
            mission_experiment(
                "fig10-two-obstacles",
                "Fig. 10",
                "two obstacles, PO2-PO1 twice",
                "both avoided, goal reached",
            ),
            mission_experiment(
                "fig11-multiple-goals", "Fig. 11", "three goals in sequence", "G1, G2, G3 reached"
            ),
            mission_experiment(
                "fig12-multiple-goals",
                "Fig. 12",
                "three goals, several shapes",
                "G1, G2, G3 reached",
            ),
            mission_experiment(
                "fig13a-no-deformation",
                "Fig. 13a",
                "goal (-1, 2) without deformation",
                "goal reached",
            ),
            mission_experiment(
                "fig13b-deformation", "Fig. 13b", "deformation at 15 s", "goal reached with IM4"
            ),
            mission_experiment(
                "fig13c-two-deformations", "Fig. 13c", "two deformations", "goal (-2, 3) reached"
            ),
        )
    },
}
