"""Maps and thousands of obstacles: decoding, validation, the simulator's per-step questions, whole
missions, and a real server's /livez while big maps and obstacle lists are posted.

    python -m bench.maps [--posts 2000] [--size 1000] [--server] [--rounds 3]

- decoding a ``--size`` square map (PGM and PNG) and validating a mission on it;
- the simulator's per-step questions (``free_within``, ``contact``, a sensor read) in a field of
  ``--posts`` posts given as obstacles and as a map of the same posts (0.05 m cells), and with
  10,000 posts;
- the same field's mission headless: posts known, hidden, as a known map and as a hidden map
  (status, model and wall time, model/wall);
- ``--server``: /livez latency from another process while ``POST /maps`` takes ``--size`` maps
  and ``POST /missions`` missions of 10,000 obstacles, four at a time (validation in the pool),
  each then read back (``GET /missions/{id}``, its websocket snapshot) and cancelled.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from primitives.library import Library, bundled_library_path
from sim.maps import MapParams, load_raster
from sim.obstacles import Circle
from sim.raster import OccupancyRaster
from sim.sensors import SensorSuite, forward_ir, range_ring
from sim.world import Bounds, World, footprint
from tests.maps_fixtures import pgm, png

HALF = 18.0  # the field's arena: [-HALF, HALF]^2 (2,000 posts: about 0.8 m apart)
RADIUS = 0.075  # 0.15 m posts
RES = 0.05


def post_field(n: int, half: float = HALF, seed: int = 0) -> np.ndarray:
    """``n`` post centres on a jittered grid, clear of the start (0, 0) and the goal."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n * 1.6)))
    g = np.linspace(-half + 0.4, half - 0.4, side)
    xs, ys = np.meshgrid(g, g)
    pts = np.stack([xs.ravel(), ys.ravel()], -1) + rng.uniform(-0.08, 0.08, (side * side, 2))
    goal = np.array([-4.0, -4.0])
    clear = (np.hypot(*pts.T) > 1.6) & (np.hypot(*(pts - goal).T) > 1.0)
    return pts[clear][:n]


def field_image(posts: np.ndarray, half: float = HALF) -> np.ndarray:
    """The posts as a map_server image at 0.05 m (row 0 the top): a pixel is black where its
    centre lies within a post."""
    n = int(round(2 * half / RES))
    centres = -half + (np.arange(n) + 0.5) * RES
    occupied = np.zeros((n, n), dtype=bool)  # [i, j]: x, y
    for x, y in posts:
        i0, i1 = np.searchsorted(centres, [x - RADIUS, x + RADIUS])
        j0, j1 = np.searchsorted(centres, [y - RADIUS, y + RADIUS])
        xs, ys = np.meshgrid(centres[i0:i1], centres[j0:j1], indexing="ij")
        occupied[i0:i1, j0:j1] |= np.hypot(xs - x, ys - y) <= RADIUS
    image = np.where(occupied, 0, 254).astype(np.uint8)
    return np.ascontiguousarray(image.T[::-1])


def timed(fn: Any, repeat: int = 300) -> float:
    fn()
    started = time.perf_counter()
    for _ in range(repeat):
        fn()
    return (time.perf_counter() - started) / repeat * 1e6


def decoding(size: int) -> None:
    rng = np.random.default_rng(1)
    image = np.where(rng.random((size, size)) < 0.05, 0, 254).astype(np.uint8)
    params = MapParams(RES, (-size * RES / 2, -size * RES / 2, 0.0))
    for kind, data in (("pgm", pgm(image)), ("png", png(image))):
        started = time.perf_counter()
        load_raster(data, params, 10**8)
        took = time.perf_counter() - started
        print(f"decode {size}x{size} {kind} ({len(data) / 1e6:.1f} MB): {took * 1e3:.0f} ms")
    body = {
        "goals": [{"x": 0.5, "y": 0.5, "tolerance": 0.2}],
        "start": {"x": 0.0, "y": 0.0},
        "maps": [
            {
                "image": base64.b64encode(pgm(np.full((size, size), 254, np.uint8))).decode(),
                "resolution": RES,
                "origin": [-size * RES / 2, -size * RES / 2, 0.0],
            }
        ],
    }
    text = json.dumps(body)
    started = time.perf_counter()
    MissionSpec.model_validate(json.loads(text))
    print(
        f"validate a mission with a {size}x{size} map ({len(text) / 1e6:.1f} MB of JSON): "
        f"{(time.perf_counter() - started) * 1e3:.0f} ms"
    )


def per_step(posts: np.ndarray, raster: OccupancyRaster, label: str) -> None:
    obstacles = tuple(Circle(float(x), float(y), RADIUS) for x, y in posts)
    bounds = Bounds(-HALF, HALF, -HALF, HALF)
    suite = SensorSuite(range_sensors=range_ring(8, 1.0) + forward_ir())
    pose = np.array([0.0, 0.0, 0.0])
    fp = footprint(pose, np.zeros(3))
    for name, world in (
        ("obstacles", World(bounds, obstacles)),
        ("map", World(bounds, (), (raster,))),
    ):
        figures = {
            "free_within": timed(lambda w=world: w.free_within(fp, 0.05)),
            "contact": timed(lambda w=world: w.contact(fp)),
            "sensor read": timed(lambda w=world: suite.read(w, pose, np.zeros(3))),
        }
        shown = ", ".join(f"{k} {v:.1f} us" for k, v in figures.items())
        print(f"  {label} as {name}: {shown}")


def missions(posts: np.ndarray, image: np.ndarray, library: Library) -> None:
    goal = {"x": -4.0, "y": -4.0, "tolerance": 0.15}
    base = {
        "goals": [goal],
        "bounds": {"xmin": -HALF, "xmax": HALF, "ymin": -HALF, "ymax": HALF},
        "time_limit": 900,
    }
    circles = [{"type": "circle", "x": float(x), "y": float(y), "radius": RADIUS} for x, y in posts]
    encoded = base64.b64encode(pgm(image)).decode()
    the_map = {"image": encoded, "resolution": RES, "origin": [-HALF, -HALF, 0.0]}
    cases = {
        "posts known": {**base, "obstacles": circles},
        "posts hidden": {**base, "obstacles": [{**c, "known": False} for c in circles]},
        "known map": {**base, "maps": [{**the_map, "known": True}]},
        "hidden map": {**base, "maps": [{**the_map, "known": False}]},
    }
    for name, body in cases.items():
        spec = MissionSpec.model_validate(body)
        started = time.perf_counter()
        runner = MissionRunner(spec, library)
        result = runner.run()
        wall = time.perf_counter() - started
        print(
            f"  {name:13s} {result.status:9s} model {result.model_time:6.1f} s  wall {wall:5.2f} s"
            f"  ({result.model_time / wall:5.0f}x)  replans {len(result.replans):3d}"
            f"  contacts {result.collisions}  {result.reason[:60]}"
        )


def server(size: int, rounds: int) -> None:
    import httpx
    import websockets

    from bench.soak import livez_while, summary
    from tests.service.test_server import start_server

    rng = np.random.default_rng(2)
    bodies = []
    for k in range(4):
        image = np.where(rng.random((size, size)) < 0.02, 0, 254).astype(np.uint8)
        image[0, k] = 0  # four different maps: none stored before
        bodies.append(
            json.dumps(
                {
                    "image": base64.b64encode(pgm(image)).decode(),
                    "resolution": RES,
                    "origin": [0, 0, 0],
                }
            ).encode()
        )
    posts = post_field(10_000, half=24.0)
    obstacles = [
        {"type": "circle", "x": float(x), "y": float(y), "radius": RADIUS} for x, y in posts
    ]
    mission = json.dumps(
        {
            "goals": [{"x": -23.0, "y": -23.0}],
            "obstacles": obstacles,
            "bounds": {"xmin": -24.5, "xmax": 24.5, "ymin": -24.5, "ymax": 24.5},
        }
    ).encode()
    with tempfile.TemporaryDirectory() as tmp:
        proc, base = start_server(Path(tmp) / "maps.db", SCREWSNAKE_MAX_RUNNING="1")
        port = int(base.rsplit(":", 1)[1])
        try:
            print(f"/livez idle: {summary(livez_while(port, 3, lambda: None))}")
            for label, path, payloads in (
                (f"POST /maps of {size}x{size}", "/maps", bodies),
                (
                    "POST, GET, WS snapshot, cancel of missions of 10,000 posts",
                    "/missions",
                    [mission] * 4,
                ),
            ):
                answers: list[tuple[int, float]] = []

                def work(
                    path: str = path,
                    payloads: list[bytes] = payloads,
                    answers: list[tuple[int, float]] = answers,
                ) -> None:
                    async def go() -> None:
                        async with httpx.AsyncClient(base_url=base, timeout=300) as http:
                            for _ in range(rounds):

                                async def one(body: bytes) -> None:
                                    started = time.perf_counter()
                                    r = await http.post(
                                        path,
                                        content=body,
                                        headers={"Content-Type": "application/json"},
                                    )
                                    answers.append((r.status_code, time.perf_counter() - started))
                                    if path == "/missions" and r.status_code == 201:
                                        # The mission read back whole, as a client and the
                                        # viewer do: its resource, its websocket snapshot.
                                        url = f"/missions/{r.json()['id']}"
                                        await http.get(url)
                                        ws_url = base.replace("http", "ws", 1) + url + "/ws"
                                        async with websockets.connect(ws_url, max_size=None) as ws:
                                            await ws.recv()
                                        await http.post(f"{url}/cancel")

                                await asyncio.gather(*(one(b) for b in payloads))

                    asyncio.run(go())

                busy = livez_while(port, 20 + 5 * rounds, work)
                took = sorted(s for _, s in answers)
                codes = sorted({c for c, _ in answers})
                print(
                    f"/livez while {label} x4 ({len(payloads[0]) / 1e6:.1f} MB each, {rounds} "
                    f"rounds): {summary(busy)}; answers {codes} in {took[0]:.2f}-{took[-1]:.2f} s"
                )
        finally:
            proc.terminate()
            proc.wait(timeout=30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--posts", type=int, default=2000)
    parser.add_argument("--size", type=int, default=1000)
    parser.add_argument("--server", action="store_true")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    decoding(args.size)
    posts = post_field(args.posts)
    image = field_image(posts)
    raster = load_raster(pgm(image), MapParams(RES, (-HALF, -HALF, 0.0)), 10**8)
    print(f"per step, {len(posts)} posts in a {2 * HALF:g} m field:")
    per_step(posts, raster, f"{len(posts)} posts")
    many = post_field(10_000, half=24.0)
    print("per step, 10,000 posts in a 48 m field (as obstacles only):")
    obstacles = tuple(Circle(float(x), float(y), RADIUS) for x, y in many)
    world = World(Bounds(-24.5, 24.5, -24.5, 24.5), obstacles)
    fp = footprint(np.zeros(3), np.zeros(3))
    print(
        f"  free_within {timed(lambda: world.free_within(fp, 0.05)):.1f} us, "
        f"contact {timed(lambda: world.contact(fp)):.1f} us"
    )
    print(f"missions through the {len(posts)}-post field (headless):")
    missions(posts, image, Library.load(bundled_library_path()))
    if args.server:
        server(args.size, args.rounds)


if __name__ == "__main__":
    main()
