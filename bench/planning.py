"""Planning latency: first plan and replans, naive (re-parse + re-ground + search) vs ours.

Arenas of 20 m x 20 m with 100, 400 and 900 roadmap waypoints, 1, 3 and 5 goals (any order),
and 10 obstacles sensed one at a time, each dropped on the current plan's path a few steps
ahead while the robot advances. DESIGN §8 target: replan p95 <= 50 ms at 400 waypoints and
3 goals. The naive path (pyperplan parse + ground + gbf/hFF, what one gets from pyperplan out
of the box) is timed on the first NAIVE_SAMPLES replans only: it costs seconds each.
"""

from __future__ import annotations

import time

import numpy as np

from domain.knowledge import Goal, WorldKnowledge
from domain.navigation import NavigationPlanner
from domain.replanner import Replanner, naive_replan
from domain.triggers import ObstacleSensed
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

ARENA = Bounds(-10, 10, -10, 10)
GOALS = [(7.3, -6.1), (-8.2, 7.4), (6.4, 8.1), (-7.0, -7.5), (0.3, 8.8)]
NAIVE_SAMPLES = 2
NAIVE_LIMIT = 60.0


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def clear_of(point: tuple[float, float], knowledge: WorldKnowledge, margin: float) -> bool:
    """Keep sensed obstacles off the goals and the robot (those would make goals unreachable)."""
    x, y, _ = knowledge.pose
    spots = [(x, y), *((g.x, g.y) for g in knowledge.goals)]
    return all(np.hypot(point[0] - a, point[1] - b) > margin for a, b in spots)


def run(waypoints: int, n_goals: int, library, naive: bool) -> dict[str, object]:
    side = round(waypoints**0.5)
    knowledge = WorldKnowledge(
        (0.0, 0.0, 0.0), "straight", tuple(Goal(*g) for g in GOALS[:n_goals]), "any", bounds=ARENA
    )
    t0 = time.perf_counter()
    planner = NavigationPlanner(knowledge, library, spacing=20.0 / side)
    replanner = Replanner(planner)
    plan, _ = replanner.plan(knowledge)
    first_ms = (time.perf_counter() - t0) * 1e3
    lengths, ours, naive_ms, valid = [len(plan.actions)], [], [], planner.validate(plan)[0]
    for i in range(10):
        moves = [a for a in plan.actions if a.name == "move"]
        if len(moves) < 4:
            break
        x, y = moves[1].target  # the robot advanced two steps; an obstacle shows up ahead
        knowledge = knowledge.moved((x, y, 0.0))
        spots = [m.target for m in moves[2:8] if m.target and clear_of(m.target, knowledge, 1.2)]
        if not spots:
            break
        obstacle = Circle(spots[-1][0], spots[-1][1], 0.4)
        knowledge = knowledge.with_sensed(obstacle)
        plan, record = replanner.plan(knowledge, ObstacleSensed(obstacle), at=float(i))
        ours.append(record.latency_ms)
        lengths.append(len(plan.actions))
        valid = valid and (planner.validate(plan)[0] or not plan.result.solved)
        if naive and i < NAIVE_SAMPLES:
            t1 = time.perf_counter()
            result, _ = naive_replan(planner, time_limit=NAIVE_LIMIT)
            if result.solved:
                naive_ms.append((time.perf_counter() - t1) * 1e3)
    return {
        "waypoints": side * side,
        "goals": n_goals,
        "first_ms": first_ms,
        "ours": ours,
        "naive": naive_ms,
        "lengths": lengths,
        "valid": valid,
        "replans": len(ours),
        "ops": len(planner.task.operators) if planner.task else 0,
    }


def main() -> None:
    library = load_bundled()
    print(
        "20 m x 20 m arena, 8 headings, straight shape, goals in any order, gbf + roadmap heuristic"
    )
    print(
        f"{'waypoints':>9}{'goals':>6}{'operators':>10}{'first [ms]':>11}{'replan p50':>11}{'p95 [ms]':>9}"
        f"{'naive p50 [ms]':>15}{'speed-up':>9}{'plan length':>13}{'replans':>8}{'valid':>6}"
    )
    for waypoints in (100, 400, 900):
        for n_goals in (1, 3, 5):
            r = run(waypoints, n_goals, library, naive=True)
            ours, naive = r["ours"], r["naive"]
            assert (
                isinstance(ours, list)
                and isinstance(naive, list)
                and isinstance(r["lengths"], list)
            )
            p50 = pct(ours, 50)
            n50 = pct(naive, 50)
            lengths = f"{min(r['lengths'])}-{max(r['lengths'])}"
            print(
                f"{r['waypoints']:>9}{n_goals:>6}{r['ops']:>10}{r['first_ms']:>11.1f}{p50:>11.1f}{pct(ours, 95):>9.1f}"
                f"{n50:>15.0f}{n50 / p50:>8.0f}x{lengths:>13}{r['replans']:>8}{'yes' if r['valid'] else 'NO':>6}",
                flush=True,
            )


if __name__ == "__main__":
    main()
