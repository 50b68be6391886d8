"""Planning latency on the primitive lattice: first plan and replans, p50/p95 per arena size.

Arenas of 5 m, 10 m and 20 m square with random known clutter (seeded). The robot starts in
one corner and plans to the far corner; then, ten times, it advances a few steps along its plan
and an obstacle is sensed on the path ahead (a disc of contact marks in the world model), and
it replans. DESIGN §8 target: replan p95 <= 50 ms on 10 m x 10 m at the resolution that passes
0.30 m corridors (0.05 m cells, 64 orientations). Run with the other core loaded for the
under-load figure (e.g. `python -c 'while 1: pass' &`).
"""

from __future__ import annotations

import time

import numpy as np

from domain.lattice import LatticeSettings, motion_table
from domain.lattice_planner import LatticePlanner, LegGoal
from domain.worldmodel import WorldModel
from primitives.library import load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

SIZES = (5.0, 10.0, 20.0)
REPLANS = 10


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def clutter(side: float, rng: np.random.Generator) -> list[Circle]:
    n = int(side * side / 8)
    out = []
    while len(out) < n:
        x, y = rng.uniform(-side / 2 + 1.5, side / 2 - 1.5, 2)
        if abs(x) + abs(y) > 1.0:
            out.append(Circle(float(x), float(y), float(rng.uniform(0.15, 0.4))))
    return out


def run(side: float, library: object, seed: int = 0) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    bounds = Bounds(-side / 2, side / 2, -side / 2, side / 2)
    world = WorldModel(bounds, clutter(side, rng))
    settings = LatticeSettings()
    table = motion_table(library, "straight", (0.0, 0.0, 0.0), settings)  # type: ignore[arg-type]
    assert table is not None
    planner = LatticePlanner(bounds, settings, time_limit=30.0)
    pose = (-side / 2 + 1.3, -side / 2 + 0.4, np.pi)  # tail towards -x, head first to +x
    goal = [LegGoal(0, side / 2 - 0.6, side / 2 - 0.6, 0.1)]
    t0 = time.perf_counter()
    plan = planner.plan(table, world.clearance_at, world.version, pose, goal, True)
    first = (time.perf_counter() - t0) * 1e3
    replans: list[float] = []
    for _ in range(REPLANS):
        moves = [a for a in plan.actions if a.name == "move"]
        if len(moves) < 8:
            break
        pose = moves[2].target  # the robot advanced; something is sensed a few steps ahead
        ahead = moves[7].target
        world.add_contact((ahead[0], ahead[1]))
        t0 = time.perf_counter()
        plan = planner.plan(table, world.clearance_at, world.version, pose, goal, True)
        replans.append((time.perf_counter() - t0) * 1e3)
    return {
        "first": first,
        "p50": pct(replans, 50),
        "p95": pct(replans, 95),
        "n": len(replans),
        "steps": len(plan.actions),
        "solved": float(plan.solved),
    }


def main() -> None:
    library = load_bundled()
    print(
        "lattice: 0.05 m cells, 64 orientations, 22 learned primitives per shape (gbf, lattice h)"
    )
    print(
        f"{'arena':>8}{'first [ms]':>12}{'replan p50':>12}{'replan p95':>12}{'replans':>9}{'steps':>7}"
    )
    for side in SIZES:
        r = run(side, library)
        print(
            f"{side:>6g} m{r['first']:>12.1f}{r['p50']:>12.1f}{r['p95']:>12.1f}"
            f"{r['n']:>9.0f}{r['steps']:>7.0f}"
        )


if __name__ == "__main__":
    main()
