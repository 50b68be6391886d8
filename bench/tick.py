"""Where a running mission's control tick goes: simulator step, sensing, world model, planning.

    python -m bench.tick [MISSION.json ...] [--repeat 3] [--clock cpu|wall] [--against /path/to/other/checkout]

Each mission runs through the executor with timers around the simulator's step (integration and
the collision sweep), its sensor read (ray casts), the world model's update, the planning
strategy's replans and its per-tick checks and steering; the rest is the executor (behaviour
tree, Robot port). Times are exclusive (a sensor read inside a step counts as sensing only) and
per control tick, best of ``--repeat`` runs. The split is in this thread's CPU time by default
(``--clock cpu``): on a shared machine wall time also counts the time other processes held the
core; ``--clock wall`` times it by the wall clock. The project's warm-up mission runs first, untimed, so
that one-off costs (imports, compiled kernels loading, motion tables) stay out of the figures. ``--against`` runs the same measurement on another
checkout of the project (e.g. the main branch) in a child process, alternating with this one so
both see the same machine load, and prints the speed-up per mission. Model/wall is model seconds
per wall second; model/CPU uses this process's CPU time, which a loaded machine disturbs less.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = (
    "examples/fig11-multiple-goals.json",
    "examples/cluttered-field.json",
    "examples/hard/corridor-oblique-60-hidden-posts.json",
    "examples/hard/noisy-sensors-clutter.json",
)
# (label, module, class, method): what each part of a tick is timed by. A module or class a
# checkout lacks is skipped: the older names stay so that ``--against`` an older checkout
# times the same parts (domain.worldmodel and domain.navigation_strategy before the costmap
# and the navigation packages).
PARTS = (
    ("sim step", "sim.simulator", "Simulator", "step"),
    ("sensing", "sim.simulator", "Simulator", "read"),
    ("world model", "domain.world", "WorldModel", "integrate"),
    ("world model", "domain.world", "WorldModel", "observe_body"),
    ("world model", "domain.world", "WorldModel", "add_contact"),
    ("world model", "domain.world", "WorldModel", "advance"),
    ("world model", "domain.worldmodel", "WorldModel", "integrate"),
    ("world model", "domain.worldmodel", "WorldModel", "add_contact"),
    ("replanning", "domain.navigation", "NavigationStrategy", "replan"),
    ("replanning", "domain.navigation_strategy", "NavigationStrategy", "replan"),
    ("replanning", "domain.reactive_strategy", "ReactiveStrategy", "replan"),
    ("steering", "domain.navigation", "NavigationStrategy", "broken"),
    ("steering", "domain.navigation", "NavigationStrategy", "command"),
    ("steering", "domain.navigation_strategy", "NavigationStrategy", "broken"),
    ("steering", "domain.navigation_strategy", "NavigationStrategy", "command"),
    ("steering", "domain.reactive_strategy", "ReactiveStrategy", "broken"),
    ("steering", "domain.reactive_strategy", "ReactiveStrategy", "command"),
)
LABELS = ("sim step", "sensing", "world model", "replanning", "steering", "executor")


CLOCKS = {"cpu": time.thread_time, "wall": time.perf_counter}


class Clock:
    """Exclusive time per label: a timed call inside another counts for its own label only."""

    def __init__(self, now: Callable[[], float] = time.thread_time) -> None:
        self.now = now
        self.totals: dict[str, float] = defaultdict(float)
        self._stack: list[float] = []

    def wrap(self, label: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = self.now()
            self._stack.append(0.0)
            try:
                return fn(*args, **kwargs)
            finally:
                elapsed = self.now() - t0
                inner = self._stack.pop()
                self.totals[label] += elapsed - inner
                if self._stack:
                    self._stack[-1] += elapsed

        return timed


def warm_up() -> None:
    """The project's warm-up (``app.executor.warm``), untimed: imports, compiled kernels and
    motion tables are ready afterwards."""
    from app.executor.warm import warm_up as warm
    from primitives.library import load_bundled

    warm(load_bundled())


def measure(path: str, repeat: int, clock_name: str = "cpu") -> dict[str, Any]:
    """Run one mission ``repeat`` times with the timers in place; the best run's figures."""
    from app.executor.runner import MissionRunner
    from app.missions.spec import load_mission
    from primitives.library import load_bundled

    library = load_bundled()
    spec = load_mission(Path(path))
    best: dict[str, Any] | None = None
    now = CLOCKS[clock_name]
    for _ in range(repeat):
        clock = Clock(now)
        originals: list[tuple[Any, str, Any]] = []
        for label, module, cls, method in PARTS:
            owner = getattr(_module(module), cls, None)
            if owner is None or not hasattr(owner, method):
                continue  # a checkout without this part
            if any(o is owner and m == method for o, m, _ in originals):
                continue  # one module re-exports another's class: timed once
            originals.append((owner, method, owner.__dict__.get(method)))
            setattr(owner, method, clock.wrap(label, getattr(owner, method)))
        try:
            runner = MissionRunner(spec, library)
            ticks = 0
            wall0, cpu0, split0 = time.perf_counter(), time.process_time(), now()
            while not runner.step():
                ticks += 1
            wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
            total = now() - split0
        finally:
            for owner, method, original in originals:
                if original is None:
                    delattr(owner, method)  # it was inherited
                else:
                    setattr(owner, method, original)
        parts = {k: clock.totals.get(k, 0.0) for k in LABELS[:-1]}
        parts["executor"] = total - sum(parts.values())
        model = runner.ctx.t
        row = {
            "mission": Path(path).stem,
            "status": runner.status,
            "ticks": ticks,
            "model": model,
            "wall": wall,
            "cpu": cpu,
            "total": total,
            "per_tick_us": {k: 1e6 * v / max(ticks, 1) for k, v in parts.items()},
        }
        if best is None or wall < best["wall"]:
            best = row
    assert best is not None
    return best


def _module(name: str) -> Any:
    """The module, or ``None`` where this checkout has none of that name."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError:
        return None


def line(row: dict[str, Any], tag: str) -> str:
    split = "".join(f"{row['per_tick_us'][k]:>12.0f}" for k in LABELS)
    total = 1e6 * row.get("total", row["wall"]) / max(row["ticks"], 1)
    return (
        f"{tag:<7}{row['mission'][:34]:<35}{row['status'][:9]:<10}{row['ticks']:>6}{split}"
        f"{total:>10.0f}{row['model'] / row['wall']:>9.0f}x{row['model'] / row['cpu']:>9.0f}x"
    )


HEADER = (
    f"{'code':<7}{'mission':<35}{'status':<10}{'ticks':>6}"
    + "".join(f"{k + ' µs':>12}" for k in LABELS)
    + f"{'tick µs':>10}{'mdl/wall':>10}{'mdl/cpu':>10}"
)


def child(paths: list[str], checkout: Path, repeat: int, clock: str) -> dict[str, Any]:
    """The measurement of one mission on another checkout, in a process importing its code."""
    # Run this file by path from the other checkout's directory: its code comes first on sys.path
    # (running the file as a script would put bench/ first, whose sim.py shadows the package).
    run = "import runpy, sys; sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"
    args = [str(Path(__file__).resolve()), "--json", "--repeat", str(repeat), "--clock", clock]
    args += paths
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    out = subprocess.run(
        [sys.executable, "-c", run, *args],
        cwd=checkout,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    result: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="*", help="mission files (default: four of examples/)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per mission, best wall time")
    parser.add_argument(
        "--clock", choices=sorted(CLOCKS), default="cpu", help="what the split is timed by"
    )
    parser.add_argument("--against", type=Path, help="another checkout to compare with")
    parser.add_argument(
        "--json", action="store_true", help="one JSON line per mission (for --against)"
    )
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat must be >= 1")
    paths = [str(Path(p).resolve()) for p in (args.missions or [ROOT / p for p in DEFAULT])]
    warm_up()
    if args.json:
        for p in paths:
            print(json.dumps(measure(p, args.repeat, args.clock)), flush=True)
        return 0
    if args.against is not None and not (args.against / "sim" / "simulator.py").is_file():
        parser.error(f"--against: {args.against} is not a checkout of this project")
    print(f"per-tick split in {args.clock} time", flush=True)
    print(HEADER, flush=True)
    speedups, rest_here, rest_other = [], [], []
    for p in paths:
        other = child([p], args.against, args.repeat, args.clock) if args.against else None
        here = measure(p, args.repeat, args.clock)
        print(line(here, "this"), flush=True)
        if here["ticks"]:
            rest_here.append(non_planning(here))
        if other is not None:
            print(line(other, "other"), flush=True)
            if not (here["ticks"] and other["ticks"]):
                print(f"{'':<7}no control tick ran: no speed-up per tick", flush=True)
                continue
            rest_other.append(non_planning(other))
            per_tick = (other["wall"] / other["ticks"]) / (here["wall"] / here["ticks"])
            per_cpu = (other["cpu"] / other["ticks"]) / (here["cpu"] / here["ticks"])
            speedups.append(per_tick)
            print(
                f"{'':<7}speed-up per tick: {per_tick:.2f}x wall, {per_cpu:.2f}x CPU; "
                f"all but replanning: {non_planning(other) / non_planning(here):.2f}x",
                flush=True,
            )
    if rest_here:
        print(
            f"all but replanning, µs per tick over {len(rest_here)} missions: median "
            f"{statistics.median(rest_here):.0f}, range {min(rest_here):.0f}-{max(rest_here):.0f}"
            + (f" (other: median {statistics.median(rest_other):.0f})" if rest_other else "")
        )
    if speedups:
        print(
            f"median speed-up per tick over {len(speedups)} missions: {statistics.median(speedups):.2f}x"
        )
    return 0


def non_planning(row: dict[str, Any]) -> float:
    """µs per tick of everything but replanning (simulator, sensing, world model, steering,
    executor)."""
    return float(sum(v for k, v in row["per_tick_us"].items() if k != "replanning"))


if __name__ == "__main__":
    sys.exit(main())
