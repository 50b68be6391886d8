"""Planning latency on the primitive lattice: first plan and replans, p50/p95 per arena size,
beside Fast Downward lama-first on the same exported PDDL.

Arenas of 5 m, 10 m and 20 m square with random known clutter (seeded). The robot starts in
one corner and plans to the far corner; then, ten times, it advances a few steps along its plan
and a post is sensed on the path ahead (three consistent echoes of a range reading: a lethal
cell of the world model's sensed layer), and it replans as a mission does (the same planner:
its motion cache and maps kept). A second table senses one cell on the path 1 m ahead in arenas
of 5-40 m and prints the replan time, by the planner that made the plan and by a fresh one (from
scratch), with its log-log slope against the number of lattice states (target: < 0.5). Target: replan p95 <=
20 ms on 10 m x 10 m at the resolution that passes 0.30 m corridors (0.05 m cells, 64
orientations); bench/README.md holds the targets. ``--load`` keeps the other core busy (a
spinning child process) for the under-load figure. The one-off costs of a process (the motion
table, the compiled kernels loading) are timed apart before the figures.

The first plan's problem, as the mission stores it (``domain/navigation/lattice/pddl.py``, with
its action costs), is then given to Fast Downward (``up-fast-downward``): its driver run
directly (the whole process: Python driver, translate and search, and the search alone as its
log reports it) and through unified-planning's ``OneshotPlanner`` (read + solve). The export
holds only the part of the lattice our search generated, so Fast Downward searches a smaller
problem than we do.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from typing import Any

import numpy as np

from bench.fast_downward import FdRun, run_driver, run_unified_planning
from domain.goal_order import LegGoal
from domain.navigation import (
    COST_SEARCH,
    Failure,
    MotionTable,
    NavigationSettings,
    Plan,
    Planner,
    PlanRequest,
    lattice_domain_text,
    motion_table,
)
from domain.world import RangeObservation, WorldModel
from primitives.library import Library, load_bundled
from sim.obstacles import Circle
from sim.world import Bounds

SIZES = (5.0, 10.0, 20.0)
REPLANS = 10


def pct(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def clutter(side: float, rng: np.random.Generator) -> list[Circle]:
    n = int(side * side / 8)
    out: list[Circle] = []
    while len(out) < n:
        x, y = rng.uniform(-side / 2 + 1.5, side / 2 - 1.5, 2)
        if abs(x) + abs(y) > 1.0:
            out.append(Circle(float(x), float(y), float(rng.uniform(0.15, 0.4))))
    return out


SEARCHES = {"compiled": COST_SEARCH, "pyperplan": "gbf"}  # --search: the planner's search


def straight_table(library: Library, settings: NavigationSettings) -> MotionTable:
    table = motion_table(library, "straight", (0.0, 0.0, 0.0), settings)
    assert table is not None
    return table


def sense_post(world: WorldModel, x: float, y: float) -> None:
    """Three consistent echoes of a ray from 0.5 m east of (x, y): a sensed (lethal) cell."""
    for _ in range(3):
        world.integrate([RangeObservation((x + 0.5, y), math.pi, 0.0, 1.0, 0.5, True)])


def solved(out: Plan | Failure) -> Plan:
    if isinstance(out, Failure):
        raise RuntimeError(f"no plan: {out.reason}")
    return out


def run(side: float, library: Library, seed: int = 0, search: str = COST_SEARCH) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    bounds = Bounds(-side / 2, side / 2, -side / 2, side / 2)
    settings = NavigationSettings()
    world = WorldModel(bounds, clutter(side, rng), settings.costmap)
    table = straight_table(library, settings)
    planner = Planner(bounds, settings, search=search, time_limit=30.0)
    pose = (-side / 2 + 1.3, -side / 2 + 0.4, np.pi)  # tail towards -x, head first to +x
    goal = (LegGoal(0, side / 2 - 0.6, side / 2 - 0.6, 0.1),)
    t0 = time.perf_counter()
    plan = solved(planner.plan(PlanRequest(pose, table, goal, True, world)))
    first = (time.perf_counter() - t0) * 1e3
    problem = plan.problem()
    export = {
        "solved": not plan.partial,
        "length": len(plan.actions),
        "problem": problem.text() if problem is not None else "",
        "states": len(problem.objects["lstate"]) if problem is not None else 0,
        "facts": len(list(problem.init)) if problem is not None else 0,
    }
    replans: list[float] = []
    for _ in range(REPLANS):
        moves = [a for a in plan.actions if a.name == "move"]
        if len(moves) < 8:
            break
        pose = moves[2].target  # the robot advanced; something is sensed a few steps ahead
        ahead = moves[7].target
        sense_post(world, ahead[0], ahead[1])
        t0 = time.perf_counter()
        out = planner.plan(PlanRequest(pose, table, goal, True, world))
        replans.append((time.perf_counter() - t0) * 1e3)
        if isinstance(out, Failure):
            break
        plan = out
    return {
        "first": first,
        "p50": pct(replans, 50),
        "p95": pct(replans, 95),
        "n": len(replans),
        "export": export,
    }


def scaling(
    side: float, library: Library, seed: int = 0, trials: int = 5, search: str = COST_SEARCH
) -> dict[str, Any]:
    """Replan time after one cell is sensed on the path 1 m ahead of the robot: by the planner
    that made the plan (what a mission does: its motion cache and maps kept) and by a fresh
    one, medians over ``trials`` positions."""
    rng = np.random.default_rng(seed)
    bounds = Bounds(-side / 2, side / 2, -side / 2, side / 2)
    settings = NavigationSettings()
    world = WorldModel(bounds, clutter(side, rng), settings.costmap)
    table = straight_table(library, settings)
    planner = Planner(bounds, settings, search=search, time_limit=60.0)
    pose = (-side / 2 + 1.3, -side / 2 + 0.4, np.pi)
    goal = (LegGoal(0, side / 2 - 0.6, side / 2 - 0.6, 0.1),)
    plan = solved(planner.plan(PlanRequest(pose, table, goal, True, world)))
    replan, full = [], []
    for trial in range(trials):
        moves = [a for a in plan.actions if a.name == "move"]
        if len(moves) <= 2 + 2 * trial:
            break
        here = moves[2 + 2 * trial].target
        ahead = next(
            (
                m.target
                for m in moves
                if np.hypot(m.target[0] - here[0], m.target[1] - here[1]) >= 1.0
            ),
            None,
        )
        if ahead is None:
            break
        sense_post(world, ahead[0], ahead[1])  # one sensed cell
        t0 = time.perf_counter()
        planner.plan(PlanRequest(here, table, goal, True, world))
        replan.append((time.perf_counter() - t0) * 1e3)
        fresh = Planner(bounds, settings, search=search, time_limit=60.0)  # nothing kept
        t0 = time.perf_counter()
        fresh.plan(PlanRequest(here, table, goal, True, world))
        full.append((time.perf_counter() - t0) * 1e3)
    return {
        "states": planner.grid.size,
        "replan": pct(replan, 50),
        "full": pct(full, 50),
        "n": len(replan),
    }


def slope(xs: list[float], ys: list[float]) -> float:
    """The log-log slope of ``ys`` against ``xs`` (least squares)."""
    return float(np.polyfit(np.log(xs), np.log(ys), 1)[0])


def scaling_table(args: argparse.Namespace) -> None:
    library = load_bundled()
    print(
        "\nreplan after one cell is blocked on the path 1 m ahead (median of the trials): "
        "the planner that made the plan vs a fresh one (ms)"
    )
    print(f"{'arena':>7}{'states':>12}{'replan':>9}{'scratch':>9}")
    rows = []
    for side in args.scaling:
        r = scaling(side, library, args.seed, search=SEARCHES[args.search])
        rows.append(r)
        print(
            f"{side:>5g} m{r['states']:>12,}{r['replan']:>9.1f}{r['full']:>9.1f}",
            flush=True,
        )
    if len(rows) > 1:
        states = [float(r["states"]) for r in rows]
        print(
            f"log-log slope against the number of states: replan "
            f"{slope(states, [r['replan'] for r in rows]):.2f}, from scratch "
            f"{slope(states, [r['full'] for r in rows]):.2f} (target < 0.5)"
        )


def ms(value: float | None) -> str:
    """Seconds as milliseconds, to 0.1 ms below 10 ms."""
    if value is None:
        return "-"
    return f"{value * 1e3:.1f}" if value < 0.01 else f"{value * 1e3:.0f}"


def peer(run: FdRun, limit: float) -> str:
    """A Fast Downward run as the table shows it: its wall time, or why there is none."""
    if run.status == "solved":
        return ms(run.wall)
    if run.status == "timeout":
        return f">{limit:g} s"
    return run.status


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--sizes", type=float, nargs="+", default=list(SIZES), help="arena sides (m)"
    )
    parser.add_argument("--load", action="store_true", help="keep the other core busy meanwhile")
    parser.add_argument("--fd-limit", type=float, default=300.0, help="s per Fast Downward run")
    parser.add_argument(
        "--up-limit", type=float, default=60.0, help="s per unified-planning call (0: skip)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--search",
        choices=("compiled", "pyperplan"),
        default="compiled",
        help="the planner's cost search (weighted A*, compiled unless SCREWSNAKE_KERNELS is "
        "off; domain/navigation/search) or pyperplan's gbf on the same lattice task",
    )
    parser.add_argument(
        "--scaling",
        type=float,
        nargs="*",
        default=[5.0, 10.0, 20.0, 40.0],
        help="arena sides (m) for the one-blocked-cell replan scaling (none: skip)",
    )
    args = parser.parse_args(argv)
    load = None
    if args.load:  # one spinning process: the other core is taken while we measure
        load = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        table(args)
        if args.scaling:
            scaling_table(args)
    finally:
        if load is not None:
            load.kill()
            load.wait()


def warm_up(library: Library) -> tuple[float, float]:
    """The one-off costs of a planning process, timed apart from the figures: building the
    straight shape's motion table (kept per process and shape) and a small plan that loads the
    compiled kernels (numba's on-disk cache). Returns both in ms."""
    settings = NavigationSettings()
    t0 = time.perf_counter()
    table = straight_table(library, settings)
    built = (time.perf_counter() - t0) * 1e3
    bounds = Bounds(-1.5, 1.5, -1.5, 1.5)
    world = WorldModel(bounds, [Circle(0.0, 0.0, 0.2)], settings.costmap)
    t0 = time.perf_counter()
    goal = (LegGoal(0, 1, 1, 0.1),)
    Planner(bounds, settings).plan(PlanRequest((-0.5, -1.0, np.pi), table, goal, True, world))
    return built, (time.perf_counter() - t0) * 1e3


def table(args: argparse.Namespace) -> None:
    library = load_bundled()
    built, loaded = warm_up(library)
    print(
        f"once per process, not in the figures: motion table {built:.0f} ms, a first small "
        f"plan loading the compiled kernels {loaded:.0f} ms"
    )
    print(
        "lattice: 0.05 m cells, 64 orientations, the straight shape's learned primitives "
        f"({SEARCHES[args.search]} search, obstacle heuristic)"
        + ("; the other core loaded" if args.load else "")
    )
    print(
        "FD: Fast Downward lama-first on the first plan's exported PDDL; driver = whole process "
        "(driver, translate, search), search = its 'Search time' (search component total); "
        "UP = unified-planning read + OneshotPlanner('fast-downward') (ms)"
    )
    print(
        f"{'arena':>7}{'first':>8}{'replan p50':>11}{'p95':>7}"
        f"{'FD driver':>11}{'translate':>10}{'FD search':>17}{'FD via UP':>11}"
        f"{'our len':>8}{'FD len':>7}{'export states/facts':>21}"
    )
    notes, partial = [], False
    for side in args.sizes:
        r = run(side, library, args.seed, search=SEARCHES[args.search])
        e = r["export"]
        domain = lattice_domain_text()
        fd = run_driver(domain, e["problem"], args.fd_limit) if e["problem"] else FdRun("no export")
        up = (
            run_unified_planning(domain, e["problem"], args.up_limit)
            if e["problem"] and args.up_limit > 0
            else FdRun("skipped")
        )
        search = f"{ms(fd.search)} ({ms(fd.search_total)})" if fd.status == "solved" else "-"
        ours = f"{e['length']}" + ("" if e["solved"] else "*")
        partial |= not e["solved"]
        print(
            f"{side:>5g} m{r['first']:>8.0f}{r['p50']:>11.1f}{r['p95']:>7.1f}"
            f"{peer(fd, args.fd_limit):>11}{ms(fd.translate) if fd.status == 'solved' else '-':>10}"
            f"{search:>17}{peer(up, args.up_limit):>11}"
            f"{ours:>8}{fd.length if fd.length is not None else '-':>7}"
            f"{e['states']:>12}/{e['facts']:<8}",
            flush=True,
        )
        for name, run_ in (("driver", fd), ("UP", up)):
            if run_.detail:
                notes.append(f"{side:g} m, FD {name}: {run_.detail}")
            if run_.status == "timeout":
                notes.append(
                    f"{side:g} m, FD {name}: no answer within the time limit "
                    f"({args.fd_limit if name == 'driver' else args.up_limit:g} s)"
                )
            if name == "UP" and run_.read is not None:
                notes.append(f"{side:g} m, UP: read {ms(run_.read)} ms of {ms(run_.wall)} ms")
    if partial:
        print("* a partial plan (the search ran out of time; the rest is planned from its end)")
    print(
        "unified-planning lists every grounding of every predicate when it writes a problem out "
        "(|states|^2 x |primitives| for succ; aiplan4eu/unified-planning#689), hence its cost."
    )
    for note in notes:
        print(note)


if __name__ == "__main__":
    main()
