"""Ablations that show the library drives the robot (issue "Plans are chains of learned
primitives").

    python -m bench.ablation [--workers 2] [--seeds 3]

1. Families of lattice primitives removed from the library, in memory: the plans change, or a
   goal becomes unreachable with the reason saying so. Variants: the full library; without the
   straight shape's translations to the robot's left (start-frame dy < 0: the robot lies on +x
   facing −x, so its left is −y, docs/robot-model.md); without every 0.05 m translation; without
   every turn; without any lattice primitive of the straight shape (the first replan then fails
   typed, ``no_primitives``, and the behaviour tree's reshape recovery may change the body into
   a shape the library has primitives for: the shapes it took are listed).
2. Deliberately poor primitives: every lattice primitive's screw speeds scaled by 0.9 and turned
   by a small seeded rotation in R⁴, with ``end_pose`` and ``swept`` recomputed by rolling the
   perturbed parameters out (the same ``sweep`` as the library build), so the planner plans with
   honest records. Corrections (planned moves grounded as ``interpolated``, i.e. blended with
   small library primitives because the primitive alone does not land on the planned state) are
   counted per metre travelled, good library against poor, over the mission seeds.

Prints tables; never fails. About a minute on 2 cores.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.executor.context import MissionContext
from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec, load_mission
from domain.navigation import NavigationStrategy
from domain.navigation.strategy import Running
from primitives.lattice import sweep
from primitives.library import Library, Primitive, load_bundled
from primitives.params import ParameterSpace
from primitives.pose_task import PoseTask
from sim.controls import FixedShape
from sim.rollout import rollout

ROOT = Path(__file__).resolve().parents[1]
MISSION_FILES = (
    "examples/fig9a-single-goal.json",
    "examples/hard/corridor-straight-030.json",
    "examples/hard/goals-near-walls.json",
)
SIDEWAYS: dict[str, Any] = {  # the goal lies straight to the robot's left (−y at ψ = 0)
    "name": "inline-sideways-left",
    "start": {"x": 0.0, "y": 0.0, "psi": 0.0},
    "goals": [{"x": 0.0, "y": -1.5, "tolerance": 0.1}],
    "bounds": {"xmin": -3, "xmax": 3, "ymin": -3, "ymax": 3},
    "seed": 0,
}
VARIANTS = ("full", "no-left-straight", "no-0.05m", "no-turns", "no-straight")
POOR_SCALE = 0.9  # screw speeds of a poor primitive, relative to the learned ones
POOR_ANGLE = 0.15  # rad: rotation of the screw-speed vector in a random plane of R⁴
CLAIM_RATIO = 1.2


# -- libraries ----------------------------------------------------------------------------------
def is_translation(e: Primitive) -> bool:
    return e.family == "lattice" and e.turn == 0.0


def is_turn(e: Primitive) -> bool:
    return e.family == "lattice" and e.turn != 0.0


def dropped(variant: str, e: Primitive) -> bool:
    """Whether ``variant`` removes ``e`` from the library."""
    if variant == "no-left-straight":
        return is_translation(e) and e.shape == "straight" and e.goal[1] < -1e-9
    if variant == "no-0.05m":
        return is_translation(e) and abs(math.hypot(*e.goal) - 0.05) < 1e-6
    if variant == "no-turns":
        return is_turn(e)
    if variant == "no-straight":
        return e.family == "lattice" and e.shape == "straight"
    return False


def ablated(library: Library, variant: str) -> Library:
    return Library([e for e in library if not dropped(variant, e)], library.file.code_version)


def rotation4(rng: np.random.Generator, angle: float) -> np.ndarray:
    """A rotation of R⁴ by ``angle`` in a random plane."""
    u, v = np.linalg.qr(rng.standard_normal((4, 2)))[0].T
    out: np.ndarray = (
        np.eye(4)
        + (math.cos(angle) - 1) * (np.outer(u, u) + np.outer(v, v))
        + math.sin(angle) * (np.outer(v, u) - np.outer(u, v))
    )
    return out


def rerecorded(e: Primitive, theta: np.ndarray) -> Primitive:
    """``e`` with parameters ``theta`` and honest records: end pose, swept poses, end, cost."""
    joints = e.joints or (0.0, 0.0, 0.0)
    config = e.rollout.config()
    states = rollout(FixedShape.of(theta, joints), config=config).states[0]
    end = states[-1, :3]
    task = PoseTask((e.goal[0], e.goal[1], e.turn), ParameterSpace("U1", joints), config=config)
    return e.model_copy(
        update={
            "theta": tuple(float(v) for v in theta),
            "end": (float(end[0]), float(end[1])),
            "end_pose": (float(end[0]), float(end[1]), float(end[2])),
            "swept": [tuple(float(v) for v in p) for p in sweep(states[:, :3], joints)],
            "cost": float(task.costs(theta[None, :])[0]),
        }
    )


def poor(library: Library, seed: int) -> Library:
    """Every lattice primitive perturbed (θ scaled, rotated in R⁴; seeded), records recomputed."""
    rng = np.random.default_rng(seed)
    out = []
    for e in library:
        if e.family == "lattice":
            theta = POOR_SCALE * rotation4(rng, POOR_ANGLE) @ np.asarray(e.theta)
            e = rerecorded(e, theta)
        out.append(e)
    return Library(out, library.file.code_version)


_CACHE: dict[tuple[str, int], Library] = {}  # per worker process


def library_of(variant: str, seed: int = 0) -> Library:
    key = (variant, seed if variant == "poor" else 0)
    if key not in _CACHE:
        base = _CACHE.setdefault(("full", 0), load_bundled())
        _CACHE[key] = poor(base, seed) if variant == "poor" else ablated(base, variant)
    return _CACHE[key]


# -- running and counting -------------------------------------------------------------------------
def mission(name: str, seed: int) -> MissionSpec:
    spec = (
        MissionSpec.model_validate(SIDEWAYS)
        if name == SIDEWAYS["name"]
        else load_mission(ROOT / name)
    )
    return spec.model_copy(update={"seed": seed})


def kind(primitive: str | None, library: Library) -> str:
    if primitive is None or primitive not in library:
        return "?"
    e = library.get(primitive)
    if e.turn != 0.0:
        return "turn"
    return f"t{math.hypot(*e.goal):.2f}"


@dataclass
class Outcome:
    variant: str
    mission: str
    seed: int
    status: str = "error"
    reason: str = ""
    plan_steps: int = 0  # actions of the first plan (moves and goal visits)
    first_plan: list[str] = field(default_factory=list)  # its primitives in order
    replans: int = 0
    first_status: str = ""  # the first replan's ("solved", or the failure's kind)
    shapes: list[str] = field(default_factory=list)  # shapes the recoveries changed into
    kinds: Counter[str] = field(default_factory=Counter)  # executed planned moves by kind
    moves: int = 0  # executed planned moves
    corrections: int = 0  # of which grounded as "interpolated"
    approaches: int = 0  # final approaches to a goal (always blended)
    back_offs: int = 0
    metres: float = 0.0
    model_time: float = 0.0
    wall: float = 0.0


def run(variant: str, name: str, seed: int) -> Outcome:
    """One mission with one library; never raises."""
    out = Outcome(variant, name, seed)
    t0 = time.perf_counter()
    try:
        library = library_of(variant, seed)
        seen: list[Running] = []

        def on_tick(ctx: MissionContext, snapshot: dict[str, Any]) -> None:
            running = ctx.strategy.running if isinstance(ctx.strategy, NavigationStrategy) else None
            if running is not None and (not seen or running is not seen[-1]):
                seen.append(running)  # a new grounded move started this tick

        runner = MissionRunner(mission(name, seed), library, on_tick=on_tick)
        result = runner.run()
        out.status, out.reason = result.status, result.reason
        out.model_time = result.model_time
        first = next((r for r in runner.ctx.replans if r.trigger == "initial"), None)
        out.plan_steps = len(first.new) if first is not None else 0
        out.first_plan = [step.strip("()").split()[-1] for step in (first.new if first else [])]
        out.replans = len(result.replans)
        out.first_status = first.status if first is not None else ""
        out.shapes = [str(e["shape"]) for e in result.events if e["kind"] == "shape_change"]
        for r in seen:
            if r.action.name == "move":
                out.moves += 1
                out.corrections += r.grounded.method == "interpolated"
                out.kinds[kind(r.action.primitive, library)] += 1
            elif r.action.name == "visit":
                out.approaches += 1
            else:
                out.back_offs += 1
        xy = np.asarray(result.trajectory, dtype=float)[:, 1:3]
        out.metres = float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1)))
    except Exception as exc:  # a crash is a row, never the bench's end
        out.status, out.reason = "error", f"{type(exc).__name__}: {exc}"
    out.wall = time.perf_counter() - t0
    return out


def run_all(jobs: list[tuple[str, str, int]], workers: int) -> list[Outcome]:
    if workers <= 1:
        return [run(*job) for job in jobs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(run, *job) for job in jobs]
        return [f.result() for f in futures]


def short(name: str) -> str:
    return Path(name).stem if name.endswith(".json") else name


# -- experiment 1 -------------------------------------------------------------------------------
def experiment1(outcomes: list[Outcome]) -> list[str]:
    lines = [
        "Experiment 1: lattice primitive families removed from the library",
        "variants: full | no-left-straight = no straight translation with start-frame dy < 0 "
        "(robot's left) | no-0.05m | no-turns | no-straight = no straight lattice primitive",
        f"{'mission':<24}{'variant':<18}{'status':<11}{'steps':>6}{'moves':>6}{'t0.05':>6}"
        f"{'t0.25':>6}{'turn':>5}{'repl':>5}{'plan=full':>10}{'model [s]':>10}{'wall [s]':>9}"
        "  reason",
    ]
    full_plans = {o.mission: o.first_plan for o in outcomes if o.variant == "full"}
    for o in outcomes:
        same = (
            "-"
            if o.variant == "full"
            else ("same" if o.first_plan == full_plans.get(o.mission) else "changed")
        )
        lines.append(
            f"{short(o.mission)[:23]:<24}{o.variant:<18}{o.status:<11}{o.plan_steps:>6}"
            f"{o.moves:>6}{o.kinds['t0.05']:>6}{o.kinds['t0.25']:>6}{o.kinds['turn']:>5}"
            f"{o.replans:>5}{same:>10}{o.model_time:>10.1f}{o.wall:>9.2f}  {o.reason[:70]}"
        )
    by_mission: dict[str, dict[str, Outcome]] = {}
    for o in outcomes:
        by_mission.setdefault(o.mission, {})[o.variant] = o
    changed = 0
    compared = 0
    for variants in by_mission.values():
        full = variants.get("full")
        for v, o in variants.items():
            if v == "full" or full is None:
                continue
            compared += 1
            unchanged = (o.status, o.first_plan, o.moves, dict(o.kinds)) == (
                full.status,
                full.first_plan,
                full.moves,
                dict(full.kinds),
            )
            changed += not unchanged
    lines.append(f"ablations that changed the plan or the outcome: {changed}/{compared}")
    # Without straight primitives the first replan fails typed (no_primitives); the behaviour
    # tree's reshape recovery may then change into a shape the library has primitives for.
    rows = [o for o in outcomes if o.variant == "no-straight"]
    bad = [o for o in rows if o.first_status != "no_primitives"]
    lines.append(
        "no-straight: the first replan fails with no_primitives ('body shape straight has no "
        "primitives in the library'): "
        + ("yes, every mission" if not bad else f"NO for {[short(o.mission) for o in bad]}")
    )
    for o in rows:
        then = f"reshaped into {', '.join(o.shapes)}" if o.shapes else "no reshape"
        lines.append(f"  {short(o.mission)}: {then}; {o.status}: {o.reason[:70]}")
    return lines


# -- experiment 2 -------------------------------------------------------------------------------
def totals(rows: list[Outcome]) -> tuple[int, int, int, float]:
    return (
        sum(o.moves for o in rows),
        sum(o.corrections for o in rows),
        sum(o.approaches for o in rows),
        sum(o.metres for o in rows),
    )


def experiment2(outcomes: list[Outcome], seeds: list[int]) -> list[str]:
    lines = [
        "Experiment 2: corrections per metre, learned (good) vs perturbed (poor) lattice primitives",
        f"poor = theta x {POOR_SCALE} rotated by {POOR_ANGLE} rad in a seeded random plane of R^4, "
        "end_pose/swept re-recorded; poor library seed = mission seed",
        "corrections = planned moves grounded 'interpolated'; approaches (final blends onto a "
        "goal) listed apart",
        f"{'mission':<24}{'seed':>5}  {'library':<8}{'status':<11}{'moves':>6}{'corr':>6}"
        f"{'appr':>6}{'metres':>8}{'corr/m':>8}{'model [s]':>10}",
    ]
    for o in outcomes:
        rate = o.corrections / o.metres if o.metres > 0 else float("nan")
        lines.append(
            f"{short(o.mission)[:23]:<24}{o.seed:>5}  {o.variant:<8}{o.status:<11}{o.moves:>6}"
            f"{o.corrections:>6}{o.approaches:>6}{o.metres:>8.2f}{rate:>8.2f}{o.model_time:>10.1f}"
        )
    lines.append("")
    lines.append(
        f"{'seed':<6}{'library':<8}{'moves':>7}{'corr':>7}{'appr':>6}{'metres':>9}{'corr/m':>8}"
        f"{'poor/good':>11}"
    )
    ratios = []
    for seed in [*seeds, None]:
        rates = {}
        for lib in ("good", "poor"):
            rows = [o for o in outcomes if o.variant == lib and seed in (None, o.seed)]
            moves, corr, appr, metres = totals(rows)
            rates[lib] = corr / metres if metres > 0 else float("nan")
            label = "all" if seed is None else str(seed)
            tail = ""
            if lib == "poor":
                ratio = rates["poor"] / rates["good"] if rates["good"] > 0 else float("nan")
                tail = f"{ratio:>11.2f}"
                if seed is not None:
                    ratios.append(ratio)
                else:
                    overall = ratio
            lines.append(
                f"{label:<6}{lib:<8}{moves:>7}{corr:>7}{appr:>6}{metres:>9.2f}"
                f"{rates[lib]:>8.3f}{tail}"
            )
    every = all(r >= CLAIM_RATIO for r in ratios)
    lines.append(
        f"poor/good corrections per metre: overall {overall:.2f} "
        f"({'>=' if overall >= CLAIM_RATIO else '<'} {CLAIM_RATIO}); per seed "
        f"{', '.join(f'{r:.2f}' for r in ratios)} "
        f"({'all' if every else 'NOT all'} >= {CLAIM_RATIO})"
    )
    lines.append(
        "claim (>= 20 % more corrections per metre with poor primitives): "
        + ("holds" if overall >= CLAIM_RATIO and every else "DOES NOT HOLD")
    )
    return lines


def fidelity() -> str:
    """Re-recording the learned parameters must reproduce the library's own records."""
    library = library_of("full")
    worst = 0.0
    for e in library.lattice("straight"):
        again = rerecorded(e, np.asarray(e.theta))
        assert e.end_pose is not None and again.end_pose is not None
        worst = max(worst, float(np.max(np.abs(np.subtract(again.end_pose, e.end_pose)))))
    return f"re-recording the learned straight primitives reproduces end_pose within {worst:.1e}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2, help="processes in the pool")
    parser.add_argument("--seeds", type=int, default=3, help="mission seeds of experiment 2")
    args = parser.parse_args(argv)
    if args.workers < 1 or args.seeds < 1:
        parser.error("--workers and --seeds must be >= 1")
    t0 = time.perf_counter()
    names = [*MISSION_FILES, SIDEWAYS["name"]]
    seeds = list(range(args.seeds))
    jobs1 = [(v, n, 0) for n in names for v in VARIANTS]
    jobs2 = [(lib, n, s) for n in names for s in seeds for lib in ("good", "poor")]
    jobs2 = [("full" if v == "good" else v, n, s) for v, n, s in jobs2]
    outcomes = run_all(jobs1 + jobs2, args.workers)
    first, second = outcomes[: len(jobs1)], outcomes[len(jobs1) :]
    for o in second:
        o.variant = "good" if o.variant == "full" else o.variant
    print(fidelity())
    print()
    print("\n".join(experiment1(first)))
    print()
    print("\n".join(experiment2(second, seeds)))
    print(f"\nwall time {time.perf_counter() - t0:.1f} s on {args.workers} worker(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
