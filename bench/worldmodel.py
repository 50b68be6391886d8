"""World model timings: one sensor update, a clearance recompute, footprint checks.

A 10 m x 10 m arena at 0.05 m cells (200 x 200), a few obstacles, the project's sensor layout
(forward IR cone 10°/0.8 m, ring of 8 rays/1.0 m, σ = 0.02 m), on the costmap of
``domain.world``. Targets: < 0.3 ms per beam in an update, < 5 ms for a full clearance
recompute (the sensed layer's distance transform from scratch, and the lethal view after a
change). Also the views as a mission reads them each tick: an update, then the lethal
clearance at a plan's worth of points (the plan guard) and the risk view (what a motion costs),
with a contact on the way. Prints figures, never asserts.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from domain.world import RangeObservation, WorldModel
from domain.world.distance import clearance_map
from sim.obstacles import Circle, rectangle, unit_vectors
from sim.world import Bounds, World, footprint

SIGMA = 0.02
LAYOUT = [(0.0, math.radians(10), 0.8, 21)] + [(k * math.pi / 4, 0.0, 1.0, 1) for k in range(8)]


def arena() -> World:
    obstacles = (
        Circle(1.0, 0.5, 0.4),
        rectangle(-1.5, 1.0, 2.0, 0.2, 0.3),
        rectangle(2.5, -2.0, 0.3, 3.0),
        Circle(-2.0, -2.5, 0.6),
    )
    return World(Bounds(-5, 5, -5, 5), obstacles)


def readings(world: World, ticks: int, rng: np.random.Generator) -> list[list[RangeObservation]]:
    """Sensor readings along a loop through the arena, cast beforehand (not timed)."""
    out = []
    for k in range(ticks):
        a = 2 * math.pi * k / ticks
        origin = (2.0 * math.cos(a), 2.0 * math.sin(a))
        heading = a + math.pi / 2 + 0.6 * math.sin(3 * a)
        tick = []
        for axis, fov, reach, rays in LAYOUT:
            angles = heading + axis + np.linspace(-fov / 2, fov / 2, rays)
            dist, what = world.ray_cast(np.asarray(origin), unit_vectors(angles), reach)
            i = int(np.argmin(dist))
            hit = bool(what[i] != -2)
            value = float(np.clip(dist[i] + (rng.normal(0, SIGMA) if hit else 0.0), 0, reach))
            tick.append(RangeObservation(origin, heading + axis, fov, reach, value, hit, SIGMA))
        out.append(tick)
    return out


def best_of(fn: Callable[[], object], repeat: int) -> float:
    """The shortest of ``repeat`` timed calls (s)."""
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def views_per_tick(world: World, ticks: list[list[RangeObservation]]) -> None:
    """An update, then the lethal clearance at 200 points along the way (as the plan guard
    reads it) and the risk view (as a motion's cost reads it), per tick, with a contact on the
    way: best of 3 runs."""
    pts = np.random.default_rng(1).uniform(-4, 4, (200, 2))

    def run() -> None:
        model = WorldModel(world.bounds)
        for k, tick in enumerate(ticks):
            model.integrate(tick)
            if k == len(ticks) // 3:
                model.add_contact((1.0, -0.1, 0.0), (0.0, 0.0, 0.0), 2, "left", 0.1 * k)
            model.clearance_at(pts)
            model.risk()

    per_tick = best_of(run, 3) / len(ticks)
    print(
        f"update + guard read (200 points of lethal clearance) + risk view: "
        f"{per_tick * 1e6:.0f} µs per tick"
    )


def capsules_clear(
    model: WorldModel, starts: np.ndarray, ends: np.ndarray, radii: np.ndarray, margin: float
) -> np.ndarray:
    """Per footprint, whether every capsule keeps ``margin`` by the lethal view (its axis at
    five points)."""
    s = np.linspace(0.0, 1.0, 5)[:, None]
    axis = starts[..., None, :] + s * (ends - starts)[..., None, :]  # [N, 5, 5, 2]
    clear = model.clearance_at(axis) >= radii[:, None] + margin
    out: np.ndarray = np.asarray(clear.all(axis=(-1, -2)))
    return out


def main() -> None:
    world = arena()
    rng = np.random.default_rng(0)
    ticks = readings(world, 400, rng)
    model = WorldModel(world.bounds)
    print(f"grid {model.grid.nx} x {model.grid.ny} cells of {model.grid.resolution} m")
    t0 = time.perf_counter()
    for tick in ticks:
        model.integrate(tick)
    per_tick = (time.perf_counter() - t0) / len(ticks)
    beams = len(LAYOUT)
    print(
        f"update, {beams} beams (1 cone + {beams - 1} rays): {per_tick * 1e3:.3f} ms per tick, "
        f"{per_tick / beams * 1e3:.3f} ms per beam (target < 0.3)"
    )
    print(f"  sensed cells occupied: {int(model.sensed_occupied().sum())}, version {model.version}")
    views_per_tick(world, ticks)
    occupied = model.sensed_occupied()
    cap = model.settings.max_clearance
    full = best_of(lambda: clearance_map(occupied, model.grid.resolution, cap), 20)
    print(f"sensed layer's distance transform from scratch: {full * 1e3:.2f} ms (target < 5)")

    def recompute() -> None:
        model.version += 1  # force the cached view out, as a real change would
        model.lethal_clearance()

    print(f"lethal view after a change: {best_of(recompute, 20) * 1e3:.2f} ms (target < 5)")
    print(
        f"static layer, 4 known obstacles: {best_of(lambda: WorldModel(world.bounds, world.obstacles), 5) * 1e3:.1f} ms"
    )
    known = WorldModel(world.bounds, world.obstacles)
    known.integrate(ticks[0])
    known.add_contact((0.0, -1.0, 0.0), (0.0, 0.0, 0.0), 1, "right", 0.0)
    poses = np.column_stack([rng.uniform(-4, 4, (5000, 2)), rng.uniform(-np.pi, np.pi, 5000)])
    fp = footprint(poses, np.array([0.3, 0.3, 0.3]))
    t = best_of(lambda: capsules_clear(known, fp.starts, fp.ends, fp.radii, 0.02), 5)
    print(
        f"footprint checks by the lethal view, 5000 footprints x 5 capsules x 5 points: "
        f"{t * 1e3:.1f} ms ({t / 5000 * 1e6:.1f} µs each)"
    )


if __name__ == "__main__":
    main()
