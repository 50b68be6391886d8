"""Learning benchmarks: the paper's Experiments 1-4 over 10 seeds, and learners side by side.

Part 1 reproduces Exps 1-4 with the paper's PI² (paper: 12-20 updates). Part 2 runs every
learner on Exps 1-4 (target, bench/README.md: no failed seed). Part 3 compares rollouts to reach < 5 cm and
wall time per learner over 10 seeds on the eight Fig. 6 goals for two shapes (target: the best
learner needs at most half the paper PI²'s rollouts). Part 4 learns the 110 lattice primitives
with each learner (3 mm / 0.17° threshold, retimed to 0.8 rad/s). Part 5 (``python -m
bench.learning shapes``, alone) learns the full lattice set of shapes no library entry covers as
a mission does (primitives/shape_learning.py) and builds its motion table: wall time per shape
(target ≤ 3 s on one core with the other loaded, bench/README.md) and each entry's end-pose
error against the library build's bar.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from domain.navigation import NavigationSettings, held_joints
from domain.navigation.lattice.costs import kernel_table
from domain.navigation.lattice.motions import motion_table
from primitives.catalogue import FIG6_GOALS, lattice_specs
from primitives.lattice import LATTICE_STOP, MAX_ATTEMPTS, learn_lattice
from primitives.learners import LEARNERS, make_learner
from primitives.library import load_bundled
from primitives.params import ParameterSpace
from primitives.pose_task import LATTICE_DT, PoseTask
from primitives.shape_learning import DEFAULT_LEARNER, learn_shape
from primitives.task import LearningTask
from sim.rollout import RolloutConfig

SEEDS = range(10)
EXPERIMENTS = {
    "Exp1 straight (-3,-3)": LearningTask((-3.0, -3.0), ParameterSpace("U1", (0.0, 0.0, 0.0))),
    "Exp2 zigzag (2,-2)": LearningTask((2.0, -2.0), ParameterSpace("U1", (0.5, -0.5, 0.5))),
    "Exp3 all seven (-1,-3)": LearningTask((-1.0, -3.0), ParameterSpace("U2")),
    "Exp4 periodic (-2,-2)": LearningTask((-2.0, -2.0), ParameterSpace("U3")),
}
SHAPES = {"straight": (0.0, 0.0, 0.0), "zigzag": (0.5, -0.5, 0.5)}


def quartiles(values: list[float]) -> str:
    q1, q2, q3 = np.percentile(values, [25, 50, 75])
    return f"{q2:8.1f} [{q1:6.1f}, {q3:6.1f}]"


def paper_experiments() -> None:
    print("Part 1: paper PI² (K = 40, λ = 30), 10 seeds, stop below 5 cm")
    print(
        f"{'experiment':<26}{'updates median [q1, q3]':>26}{'min-max':>10}{'final cost [cm]':>18}{'wall [ms]':>11}"
    )
    pi2 = make_learner("pi2")
    for name, task in EXPERIMENTS.items():
        t0 = time.perf_counter()
        results = [pi2.learn(task, seed) for seed in SEEDS]
        wall = (time.perf_counter() - t0) / len(results) * 1e3
        ups = [float(r.updates) for r in results]
        costs = [r.cost * 100 for r in results]
        span = f"{min(ups):.0f}-{max(ups):.0f}"
        print(f"{name:<26}{quartiles(ups):>26}{span:>10}{np.median(costs):>18.2f}{wall:>11.1f}")


def experiments_per_learner() -> None:
    print(
        "\nPart 2: every learner on Exps 1-4, 10 seeds, stop below 5 cm (rollouts median [q1, q3])"
    )
    print(f"{'experiment':<26}{'learner':<9}{'rollouts':>26}{'vs pi2':>8}{'failed':>8}")
    for name, task in EXPERIMENTS.items():
        reference = 0.0
        for learner_name in LEARNERS:
            learner = make_learner(learner_name)
            results = [learner.learn(task, seed) for seed in SEEDS]
            rollouts = [float(r.rollouts) for r in results]
            failed = sum(not r.converged for r in results)
            median = float(np.median(rollouts))
            reference = reference or median
            print(
                f"{name:<26}{learner_name:<9}{quartiles(rollouts):>26}{median / reference:>7.2f}x{failed:>8}"
            )


def lattice_primitives() -> None:
    specs = lattice_specs()
    print(
        f"\nPart 4: the {len(specs)} lattice primitives per learner (threshold "
        f"{LATTICE_STOP.threshold * 1e3:.0f} mm + 1 m/rad; up to {MAX_ATTEMPTS} seeds each)"
    )
    print(
        f"{'learner':<9}{'rollouts':>26}{'vs pi2':>8}{'wall [ms]':>22}{'retried':>9}{'refined':>9}"
        f"{'worst [mm]':>12}{'failed':>8}"
    )
    reference = 0.0
    for name in LEARNERS:
        rollouts, walls, retried, refined, worst, failed = [], [], 0, 0, 0.0, 0
        for i, spec in enumerate(specs):
            t0 = time.perf_counter()
            entry = learn_lattice(spec, name, i, LATTICE_STOP)
            walls.append((time.perf_counter() - t0) * 1e3)
            rollouts.append(float(entry.rollouts))
            retried += entry.seed != i
            refined += bool(entry.settings["refined"])
            worst = max(worst, entry.cost * 1e3)
            failed += entry.cost >= LATTICE_STOP.threshold
        median = float(np.median(rollouts))
        reference = reference or median
        print(
            f"{name:<9}{quartiles(rollouts):>26}{median / reference:>7.2f}x{quartiles(walls):>22}"
            f"{retried:>9}{refined:>9}{worst:>12.2f}{failed:>8}"
        )


def learner_comparison() -> None:
    print("\nPart 3: rollouts to < 5 cm, 8 Fig. 6 goals x 10 seeds per shape (median [q1, q3])")
    print(f"{'shape':<10}{'learner':<9}{'rollouts':>26}{'vs pi2':>8}{'wall [ms]':>22}{'failed':>8}")
    for shape, joints in SHAPES.items():
        reference = 0.0
        for name in LEARNERS:
            learner = make_learner(name)
            rollouts, walls, failed = [], [], 0
            for goal in FIG6_GOALS:
                task = LearningTask(goal, ParameterSpace("U1", joints))
                for seed in SEEDS:
                    r = learner.learn(task, seed)
                    rollouts.append(float(r.rollouts))
                    walls.append(r.wall_time * 1e3)
                    failed += not r.converged
            median = float(np.median(rollouts))
            reference = reference or median
            print(
                f"{shape:<10}{name:<9}{quartiles(rollouts):>26}{median / reference:>7.2f}x{quartiles(walls):>22}{failed:>8}"
            )


# Shapes no library entry covers (none within the lattice tolerance of a library shape): the
# issue's deformation, its start shape, strong bends one way and both ways, a near-straight one.
NEW_SHAPES = (
    (0.9, -0.3, 0.6),
    (-0.8, 0.4, -0.7),
    (1.2, 1.2, 1.2),
    (-1.0, 0.0, 1.0),
    (0.1, -0.1, 0.1),
    (0.7, 0.7, -0.7),
)


def end_error(entry: object) -> tuple[float, float]:
    """(position mm, heading deg) of an entry's stored parameters against its target, from a
    fresh rollout of exactly what the library stores."""
    from primitives.library import Primitive

    assert isinstance(entry, Primitive)
    space = ParameterSpace("U1", entry.joints or (0.0, 0.0, 0.0), speed_limit=1.0)
    task = PoseTask(
        (entry.goal[0], entry.goal[1], entry.turn),
        space,
        config=RolloutConfig(entry.rollout.duration, LATTICE_DT),
    )
    err = task.errors(np.asarray(entry.theta)[None, :])[0]
    return float(err[0] * 1e3), float(np.degrees(err[1]))


def learned_shapes() -> None:
    library = load_bundled()
    settings = NavigationSettings()
    print(
        f"Part 5: a full lattice set for a shape no entry covers ({DEFAULT_LEARNER}, bar "
        f"{LATTICE_STOP.threshold * 1e3:.0f} mm + 1 m/rad), motion table included"
    )
    print(
        f"{'joints':<20}{'learn [s]':>10}{'table [s]':>10}{'total [s]':>10}{'cpu [s]':>8}{'rollouts':>9}"
        f"{'entries':>8}{'left out':>9}{'worst [mm]':>11}{'worst [deg]':>12}"
    )
    learn_shape((0.0, 0.0, 0.0))  # compile the kernels once, as a warm worker has
    totals, cpus = [], []  # wall, and this process's CPU time (what load does not inflate)
    for joints in NEW_SHAPES:
        assert not library.lattice_covers(joints).covered, joints
        c0, t0 = time.process_time(), time.perf_counter()
        learned = learn_shape(joints)
        t1 = time.perf_counter()
        grown = library.with_entries(learned.entries)
        table = motion_table(grown, learned.shape, held_joints(joints), settings)
        assert table is not None
        kernel_table(table, settings.margin)
        t2, c2 = time.perf_counter(), time.process_time()
        errors = [end_error(e) for e in learned.entries]
        worst_mm = max(e[0] for e in errors)
        worst_deg = max(e[1] for e in errors)
        totals.append(t2 - t0)
        cpus.append(c2 - c0)
        print(
            f"{list(joints)!s:<20}{t1 - t0:>10.2f}{t2 - t1:>10.2f}{t2 - t0:>10.2f}{c2 - c0:>8.2f}"
            f"{learned.rollouts:>9}{len(learned.entries):>8}{len(learned.failed):>9}"
            f"{worst_mm:>11.2f}{worst_deg:>12.3f}"
        )
    print(
        f"worst total {max(totals):.2f} s wall ({max(cpus):.2f} s CPU), median "
        f"{float(np.median(totals)):.2f} s wall ({float(np.median(cpus)):.2f} s CPU); target ≤ 3 s"
    )


if __name__ == "__main__":
    if sys.argv[1:] == ["shapes"]:
        learned_shapes()
        sys.exit(0)
    paper_experiments()
    experiments_per_learner()
    learner_comparison()
    lattice_primitives()
