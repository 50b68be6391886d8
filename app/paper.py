"""The paper's experiments that this system reproduces, each with the paper's figures beside ours."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.executor.runner import MissionRunner
from app.mission_plot import plot_mission, sensed_cells
from app.missions.spec import load_mission
from app.paper_missions import (
    PaperRun,
    chain_rows,
    chain_targets,
    examples_dir,
    outcome_rows,
    run_paper,
)
from app.plots import plot_learning_curves, plot_trajectories
from primitives.generalise import refine_aim
from primitives.interpolation import Interpolated, interpolate_entries
from primitives.learners import PI2
from primitives.library import Library
from primitives.params import ParameterSpace
from primitives.task import LearningTask
from sim.rollout import rollout

Row = tuple[str, str, str]  # what, the paper, ours
GOAL_MARGIN = {"fig11-multiple-goals": 0.10, "fig12-multiple-goals": 0.40}  # m, see README


@dataclass(frozen=True)
class Experiment:
    name: str
    figure: str
    title: str
    run: Callable[[Library, Path], tuple[list[Row], Path]]


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


@dataclass(frozen=True)
class Fig8:
    """Fig. 8's new behaviour: P1s, P12, P13 interpolated (eqs. 16-18) towards (2, 1), as the
    paper aims it and with the aim point learned by a few rollouts (primitives/generalise.py)."""

    made: Interpolated
    end: tuple[float, float]
    error: float
    aimed: Interpolated
    aimed_end: tuple[float, float]
    aimed_error: float
    rollouts: int


FIG8_GOAL = (2.0, 1.0)


def fig8_run(library: Library) -> Fig8:
    """Both Fig. 8 behaviours and where they end (one rollout each, plus the aim's)."""
    entries = [library.get("P1s"), library.get("P12"), library.get("P13")]
    made = interpolate_entries(entries, FIG8_GOAL)
    end = rollout(made.control()).states[0][-1, :2]
    aimed, _, rollouts = refine_aim(entries, FIG8_GOAL)
    aimed_end = rollout(aimed.control()).states[0][-1, :2]
    return Fig8(
        made,
        (float(end[0]), float(end[1])),
        math.dist(end, FIG8_GOAL),
        aimed,
        (float(aimed_end[0]), float(aimed_end[1])),
        math.dist(aimed_end, FIG8_GOAL),
        rollouts,
    )


def fig8(library: Library, out: Path) -> tuple[list[Row], Path]:
    run = fig8_run(library)
    states = rollout(run.aimed.control()).states[0]
    plain = rollout(run.made.control()).states[0]
    sources = [rollout(library.get(n).control()).states[0] for n in ("P1s", "P12", "P13")]
    path = plot_trajectories(
        out / "fig8.png",
        [*sources, plain, states],
        title="Fig. 8: P1s, P12, P13 -> goal (2, 1)",
        goals=[FIG8_GOAL],
        outlines=2,
        labels=["P1s", "P12", "P13", "interpolated at (2, 1)", "interpolated, aim learned"],
    )
    coverage = library.covers(tuple(float(v) for v in run.aimed.joints))
    aim = run.aimed.extra["aim"]
    assert isinstance(aim, list)
    return [
        (
            "interpolated at the goal (eqs. 16-18)",
            "reaches (2, 1) (Fig. 8d)",
            f"({run.end[0]:.2f}, {run.end[1]:.2f}), {run.error * 100:.1f} cm off",
        ),
        (
            "interpolated at a learned aim",
            "-",
            f"aim ({aim[0]:.3f}, {aim[1]:.3f}) after {run.rollouts} rollouts: "
            f"({run.aimed_end[0]:.3f}, {run.aimed_end[1]:.3f}), "
            f"{run.aimed_error * 100:.2f} cm off",
        ),
        (
            "body shape of the new behaviour",
            "between straight and semi-zigzag",
            f"{[round(float(v), 3) for v in run.aimed.joints]}: {coverage.describe()}",
        ),
    ], path


PAPER_CHAINS = {
    "fig9b-obstacles": "Set 1 -> P2s (IR below threshold) -> Set 1 -> P6s (time-out)",
    "fig10-two-obstacles": "P4s -> P2z -> P4s -> P2z -> P4s (PO1, PO2-PO1 twice)",
    "fig11-multiple-goals": "P1s -> P4z -> P9, shape changes between them",
    "fig12-multiple-goals": "IM1 (P8s, P1s, P2s) -> IM2 (P1a, P2a, P8a) -> IM3 (P4a, P5a, P6a) "
    "-> P5pe -> P4pe",
    "fig13b-deformation": "Set 1 -> deformation at 15 s -> IM4 (P10, P11, P12) towards 30 deg",
}


def paper_mission_experiment(name: str, figure: str, title: str, paper: str) -> Experiment:
    """A mission the paper describes primitive by primitive: runs examples/paper/<name>.json
    and tabulates the executed chain beside the paper's."""

    def run(library: Library, out: Path) -> tuple[list[Row], Path]:
        from app.mission_plot import plot_mission, sensed_cells

        done = run_paper(name, library)
        path = plot_mission(done.spec, done.result, out / f"{name}.png", sensed_cells(done.runner))
        rows = [("executed chain", PAPER_CHAINS[name], " -> ".join(done.chain()))]
        rows += chain_rows(done)
        rows += goal_rows(name, done, library)
        rows += outcome_rows(done, paper)
        return rows, path

    return Experiment(name, figure, title, run)


def goal_rows(name: str, done: PaperRun, library: Library) -> list[Row]:
    """A chain's goals: where the library predicts each step ends against where it did."""
    if not done.spec.chain:
        return []
    rows = []
    margin = GOAL_MARGIN.get(name, 0.10)
    for i, (want, got) in enumerate(
        zip(chain_targets(done.spec, library), done.step_ends(), strict=False)
    ):
        err = math.dist(want, got)
        rows.append(
            (
                f"step {i} ends (library prediction)",
                f"({want[0]:.2f}, {want[1]:.2f})",
                f"({got[0]:.2f}, {got[1]:.2f}): {err * 100:.1f} cm off (margin {margin * 100:g})",
            )
        )
    return rows


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
            paper_mission_experiment(
                "fig9b-obstacles",
                "Fig. 9b",
                "Set 1, P2s, Set 1, P6s: obstacle avoided, time-out return",
                "obstacle avoided, goal reached",
            ),
            mission_experiment(
                "fig9b-chain", "Fig. 9b", "manual chain of primitives", "primitives chained"
            ),
            paper_mission_experiment(
                "fig10-two-obstacles",
                "Fig. 10",
                "P4s and P2z around two obstacles (PO2-PO1 twice)",
                "both avoided, goal reached",
            ),
            paper_mission_experiment(
                "fig11-multiple-goals",
                "Fig. 11",
                "P1s -> P4z -> P9 through G1, G2, G3",
                "G1, G2, G3 reached",
            ),
            paper_mission_experiment(
                "fig12-multiple-goals",
                "Fig. 12",
                "IM1 -> IM2 -> IM3 -> P5pe -> P4pe",
                "G1, G2, G3 reached",
            ),
            mission_experiment(
                "fig13a-no-deformation",
                "Fig. 13a",
                "goal (-1, 2) without deformation",
                "goal reached",
            ),
            paper_mission_experiment(
                "fig13b-deformation",
                "Fig. 13b",
                "deformation at 15 s, IM4 from P10, P11, P12",
                "goal reached with IM4",
            ),
            mission_experiment(
                "fig13c-two-deformations", "Fig. 13c", "two deformations", "goal (-2, 3) reached"
            ),
        )
    },
}
