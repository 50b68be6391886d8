"""Soak: a bounded run (default 10 minutes) against a real uvicorn server with a mix of valid,
invalid, oversized, slow and planning-heavy missions, cancels, SIGKILLed mission workers and
websocket churn. Prints requests by status, missions by terminal status and reason, stuck
missions (must be 0), 5xx answers (must be 0) and the server's RSS at start and end.

Then three adversarial scenarios (``--scenarios``, all by default):
- ``race``: the live-update race, 50 concurrent mixed updates (goals added and removed,
  obstacles, pause, resume) on a running mission with a cancel among them, several rounds:
  every answer 2xx/4xx, each accepted goal at the index its answer gave, the caps held, after
  ``cancelling`` only the terminal status;
- ``stall``: the costly-body stall, /livez latency measured by a separate process, first idle,
  then while 519 kB missions (50 goals, 200 polygons of 64 points, half of them invalid) are
  posted four at a time and long /simulate rollouts run (target: max <= 50 ms);
- ``memory``: the memory cap, a 50 m maze planned with A*/hFF on a server with
  ``SCREWSNAKE_WORKER_MEMORY`` (``--worker-memory``, 1G): the mission ends ``failed: memory
  limit``, the worker is replaced, its RSS sampled all along.

Only 127.0.0.1 is contacted; every phase has a deadline. ``--minutes 3`` for a shorter run,
``--minutes 0 --scenarios stall`` for one scenario alone.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import http.client
import json
import math
import multiprocessing
import os
import random
import signal
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx
import websockets

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.service.test_server import start_server

TERMINAL = ("succeeded", "failed", "cancelled")
SERVER = {  # small limits, so that each of them is reached during the run
    "SCREWSNAKE_MAX_RUNNING": "2",
    "SCREWSNAKE_MAX_QUEUED": "12",
    "SCREWSNAKE_WALL_LIMIT": "30",
    "SCREWSNAKE_RECONCILE_SECONDS": "5",
}
DRAIN_SECONDS = 120.0  # after the run: running missions must end within this
BOUNDS = {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5}


def valid(rng: random.Random) -> dict:
    """A mission that can run: unpaced, paced, slow, or with far too much to plan."""
    kind = rng.choices(["fast", "paced", "slow", "heavy"], [5, 3, 1, 1])[0]
    goal = {"x": round(rng.uniform(-4, -1), 2), "y": round(rng.uniform(-4, 4), 2)}
    body: dict = {
        "name": f"soak-{kind}",
        "goals": [goal],
        "bounds": BOUNDS,
        "seed": rng.randrange(1000),
    }
    if kind == "paced":
        body["speed"] = 20
    elif kind == "slow":
        body |= {"speed": 2, "time_limit": 50}
    elif kind == "heavy":  # pyperplan A*/hFF over 30 unordered goals: ends by a limit
        body |= {
            "goals": [{"x": -9 + (i % 6) * 3.5, "y": -9 + (i // 6) * 4.5} for i in range(30)],
            "order": "any",
            "bounds": {"xmin": -10, "xmax": 10, "ymin": -10, "ymax": 10},
            "planner": {"search": "astar", "heuristic": "hff", "time_limit": 60},
        }
    return body


INVALID = [
    {"goals": []},
    {"goals": [{"x": True, "y": 0}]},
    {"goals": [{"x": 1, "y": 1}], "chain": [{"primitive": "P1s", "until": {"duration": 5}}]},
    {"name": "nul\x00", "goals": [{"x": 1, "y": 1}]},
    {"goals": [{"x": 1, "y": 1}], "speed": 1e-300},
    {"goals": [{"x": 1, "y": 1}], "speed": 0.5, "time_limit": 1000},  # over the wall-clock limit
    {"goals": [{"x": 1, "y": 1}], "bounds": {"xmin": -400, "xmax": 400, "ymin": -400, "ymax": 400}},
    {
        "goals": [{"x": 0.5, "y": 0.15}],
        "obstacles": [{"type": "circle", "x": 0.5, "y": 0.1, "radius": 0.2}],
    },
]


class Soak:
    def __init__(self, base: str, pid: int, seconds: float, seed: int) -> None:
        self.base, self.pid, self.seconds = base, pid, seconds
        self.rng = random.Random(seed)
        self.statuses: Counter[str] = Counter()
        self.ids: list[str] = []
        self.kills = self.ws_sessions = self.ws_ends = 0
        self.stop = asyncio.Event()

    async def request(
        self, http: httpx.AsyncClient, method: str, path: str, **kw: object
    ) -> httpx.Response | None:
        try:
            r = await http.request(method, path, **kw)  # type: ignore[arg-type]
        except httpx.HTTPError as exc:
            self.statuses[f"error {type(exc).__name__}"] += 1
            return None
        busy = r.status_code == 503 and "missions are waiting" in r.json().get("detail", "")
        self.statuses["503 busy (queue full)" if busy else str(r.status_code)] += 1
        return r

    async def poster(self, http: httpx.AsyncClient) -> None:
        while not self.stop.is_set():
            roll = self.rng.random()
            if roll < 0.6:
                headers = {"Idempotency-Key": f"k{self.rng.randrange(50)}"} if roll < 0.05 else {}
                r = await self.request(
                    http, "POST", "/missions", json=valid(self.rng), headers=headers
                )
                if r is not None and r.status_code == 201:
                    self.ids.append(r.json()["id"])
            elif roll < 0.85:
                await self.request(http, "POST", "/missions", json=self.rng.choice(INVALID))
            elif roll < 0.92:
                await self.request(
                    http,
                    "POST",
                    "/missions",
                    content=b"{not json",
                    headers={"Content-Type": "application/json"},
                )
            else:  # 2 MB: over the 1 MB default body limit
                await self.request(
                    http,
                    "POST",
                    "/missions",
                    content=b" " * 2_000_000,
                    headers={"Content-Type": "application/json"},
                )
            await asyncio.sleep(self.rng.uniform(0.1, 0.6))

    async def reader(self, http: httpx.AsyncClient) -> None:
        while not self.stop.is_set():
            if self.ids and self.rng.random() < 0.7:
                mission = self.rng.choice(self.ids)
                await self.request(
                    http,
                    "GET",
                    f"/missions/{mission}{self.rng.choice(['', '/plan', '/tree', '/trajectory'])}",
                )
            else:
                await self.request(http, "GET", "/missions?limit=20")
            await asyncio.sleep(0.2)

    async def canceller(self, http: httpx.AsyncClient) -> None:
        while not self.stop.is_set():
            await asyncio.sleep(self.rng.uniform(1, 4))
            if self.ids:
                await self.request(
                    http, "POST", f"/missions/{self.rng.choice(self.ids[-20:])}/cancel"
                )

    async def killer(self) -> None:
        while not self.stop.is_set():
            await asyncio.sleep(self.rng.uniform(10, 25))
            if self.stop.is_set():
                return
            victims = mission_workers(self.pid)
            if victims:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(self.rng.choice(victims), signal.SIGKILL)
                    self.kills += 1

    async def watcher(self) -> None:
        """Websocket churn: read a few frames or to the end, stall, or drop the connection."""
        while not self.stop.is_set():
            await asyncio.sleep(self.rng.uniform(0.2, 1.0))
            if not self.ids:
                continue
            url = (
                self.base.replace("http", "ws") + f"/missions/{self.rng.choice(self.ids[-10:])}/ws"
            )
            self.ws_sessions += 1
            with contextlib.suppress(Exception):
                async with websockets.connect(url, open_timeout=10, max_size=2**22) as ws:
                    limit = self.rng.choice([1, 5, 50, 10_000])
                    for _ in range(limit):
                        frame = json.loads(await asyncio.wait_for(ws.recv(), 30))
                        if frame["type"] == "end":
                            self.ws_ends += 1
                            break
                        if self.rng.random() < 0.01:
                            await asyncio.sleep(2)  # a stalled client

    async def run(self) -> None:
        async with httpx.AsyncClient(base_url=self.base, timeout=30) as http:
            tasks = [
                asyncio.create_task(t)
                for t in (self.poster(http), self.reader(http), self.canceller(http), self.killer())
            ] + [asyncio.create_task(self.watcher()) for _ in range(3)]
            await asyncio.sleep(self.seconds)
            self.stop.set()
            await asyncio.wait(tasks, timeout=60)


def mission_workers(server: int) -> list[int]:
    """Mission worker processes: children of the server's forkserver."""
    parents: dict[int, int] = {}
    cmdlines: dict[int, bytes] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
                parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
                cmdlines[int(entry.name)] = (entry / "cmdline").read_bytes()
            except (OSError, ValueError, IndexError):
                continue
    servers = {
        p
        for p, parent in parents.items()
        if parent == server and b"forkserver" in cmdlines.get(p, b"")
    }
    return [p for p, parent in parents.items() if parent in servers]


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def drain(base: str) -> list[dict]:
    """Cancel what still waits (an operator emptying the queue), let running missions end by
    themselves, and return every mission."""
    with httpx.Client(base_url=base, timeout=30) as http:

        def everything() -> list[dict]:
            out, offset = [], 0
            while True:
                page = http.get("/missions", params={"limit": 200, "offset": offset}).json()
                out += page["items"]
                offset += 200
                if offset >= page["total"]:
                    return out

        for m in everything():
            if m["status"] == "queued":
                http.post(f"/missions/{m['id']}/cancel")
        deadline = time.monotonic() + DRAIN_SECONDS
        while time.monotonic() < deadline:
            missions = everything()
            if all(m["status"] in TERMINAL for m in missions):
                break
            time.sleep(1)
        return missions


# -- the adversarial scenarios --------------------------------------------------------------------------
RACE_ROUNDS = 5
RACE_UPDATES = 50
RACE_MISSION = {  # paced: it runs until cancelled (within the soak's 30 s wall-clock limit)
    "name": "soak-race",
    "goals": [{"x": -4, "y": 4}],
    "bounds": BOUNDS,
    "speed": 1,
    "time_limit": 25,
}
STALL_ROUNDS = 3
LIVEZ_EVERY = 0.01  # seconds between the prober's requests
STALL_TARGET_MS = 50.0


def costly_mission(bad: bool) -> dict[str, Any]:
    """50 goals against 200 polygons of 64 points (~519 kB of JSON): its validation alone took
    1.4-1.6 s; ``bad``: the last goal too close to a polygon (a 422 after all of it)."""
    polygons = []
    for k in range(200):
        cx, cy = -9 + (k % 20) * 0.9, 2 + (k // 20) * 0.75
        points = [
            [
                round(cx + 0.2 * math.cos(2 * math.pi * i / 64), 12),
                round(cy + 0.2 * math.sin(2 * math.pi * i / 64), 12),
            ]
            for i in range(64)
        ]
        polygons.append({"type": "polygon", "points": points})
    goals = [{"x": -9 + (i % 10) * 1.8, "y": -9 + (i // 10) * 1.5} for i in range(50)]
    if bad:
        goals[-1] = {"x": -9.0, "y": 2.22}
    return {
        "name": "soak-costly",
        "goals": goals,
        "obstacles": polygons,
        "bounds": {"xmin": -10, "xmax": 10, "ymin": -10, "ymax": 10},
        "time_limit": 20,
        "planner": {"time_limit": 2},
    }


def race_goal(rng: random.Random) -> dict[str, float]:
    return {"x": round(rng.uniform(-4, 4), 3), "y": round(rng.uniform(-4, 4), 3)}


async def race_round(http: httpx.AsyncClient, rng: random.Random) -> dict[str, Any]:
    """One mission, 50 concurrent mixed updates and a cancel among them; what held."""
    r = await http.post("/missions", json=RACE_MISSION)
    assert r.status_code == 201, r.text
    mission = r.json()["id"]
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if (await http.get(f"/missions/{mission}")).json()["status"] == "executing":
            break
        await asyncio.sleep(0.05)

    async def update(k: int) -> tuple[str, httpx.Response, Any]:
        kind = rng.choices(["goal", "remove", "obstacle", "pause", "resume"], [5, 2, 2, 1, 1])[0]
        base = f"/missions/{mission}"
        if k == RACE_UPDATES // 2:  # the cancel, once the first updates are under way
            await asyncio.sleep(0.05)
            return "cancel", await http.post(f"{base}/cancel"), None
        if kind == "goal":
            goal = race_goal(rng)
            return kind, await http.post(f"{base}/goals", json=goal), goal
        if kind == "remove":
            return kind, await http.delete(f"{base}/goals/{rng.randrange(8)}"), None
        if kind == "obstacle":
            circle = {"type": "circle", **race_goal(rng), "radius": 0.1}
            return kind, await http.post(f"{base}/obstacles", json={"obstacle": circle}), None
        return kind, await http.post(f"{base}/{kind}"), None

    answers = await asyncio.gather(*(update(k) for k in range(RACE_UPDATES)))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        m = (await http.get(f"/missions/{mission}")).json()
        if m["status"] in TERMINAL:
            break
        await asyncio.sleep(0.1)
    codes = Counter(f"{kind} {r.status_code}" for kind, r, _ in answers)
    statuses = [t["status"] for t in m["transitions"]]
    after = statuses[statuses.index("cancelling") + 1 :] if "cancelling" in statuses else []
    wrong = sum(
        1
        for kind, r, goal in answers
        if kind == "goal"
        and r.status_code == 202
        and (m["goals"][r.json()["goal"]]["x"], m["goals"][r.json()["goal"]]["y"])
        != (goal["x"], goal["y"])
    )
    return {
        "codes": codes,
        "fives": sum(r.status_code >= 500 for _, r, _ in answers),
        "end": m["status"],
        "after_cancelling": after,
        "wrong_index": wrong,
        "goals": len(m["goals"]),
    }


def race(base: str, rounds: int, seed: int) -> None:
    print(
        f"\n== live-update race: {rounds} rounds of {RACE_UPDATES} concurrent updates, a cancel among them"
    )

    async def run() -> list[dict[str, Any]]:
        rng = random.Random(seed)
        async with httpx.AsyncClient(base_url=base, timeout=60) as http:
            return [await race_round(http, rng) for _ in range(rounds)]

    results = asyncio.run(run())
    codes: Counter[str] = Counter()
    for result in results:
        codes.update(result["codes"])
    print("answers by update and status:")
    for key, n in sorted(codes.items()):
        print(f"  {key:>16}  {n}")
    print(f"ends: {Counter(r['end'] for r in results)}")
    print(f"goals per mission at the end: {[r['goals'] for r in results]} (cap 50)")
    print(f"statuses after cancelling: {[r['after_cancelling'] for r in results]} (only an end)")
    print(
        f"accepted goals not at their answered index: {sum(r['wrong_index'] for r in results)} (must be 0)"
    )
    print(f"5xx: {sum(r['fives'] for r in results)} (must be 0)")


def prober(port: int, seconds: float, out: Any) -> None:
    """A separate process: GET /livez every LIVEZ_EVERY for ``seconds``; the latencies (ms)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    latencies, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        started = time.perf_counter()
        conn.request("GET", "/livez")
        conn.getresponse().read()
        latencies.append((time.perf_counter() - started) * 1e3)
        time.sleep(LIVEZ_EVERY)
    out.put(latencies)


def livez_while(port: int, seconds: float, work: Any) -> list[float]:
    """/livez latencies (ms) measured by another process while ``work()`` runs."""
    context = multiprocessing.get_context("spawn")
    out = context.Queue()
    probe = context.Process(target=prober, args=(port, seconds, out))
    probe.start()
    time.sleep(0.5)
    work()
    latencies: list[float] = out.get(timeout=seconds + 120)
    probe.join()
    return latencies


def summary(latencies: list[float]) -> str:
    ms = sorted(latencies)
    p = lambda q: ms[min(len(ms) - 1, int(q * len(ms)))]  # noqa: E731
    return f"n={len(ms)} p50 {p(0.5):.1f} p99 {p(0.99):.1f} max {ms[-1]:.1f} ms"


def stall(base: str, rounds: int) -> None:
    port = int(base.rsplit(":", 1)[1])
    bodies = [json.dumps(costly_mission(bad=i % 2 == 0)).encode() for i in range(4)]
    print(
        f"\n== costly-body stall: {rounds} rounds of 4 posts of {len(bodies[0]) // 1000} kB at once (2 invalid), then 3 long /simulate"
    )
    idle = livez_while(port, 5, lambda: None)
    print(f"/livez idle:                {summary(idle)}")
    posts: list[tuple[int, float]] = []

    def post_costly() -> None:
        async def go() -> None:
            async with httpx.AsyncClient(base_url=base, timeout=120) as http:
                for _ in range(rounds):

                    async def one(body: bytes) -> None:
                        started = time.perf_counter()
                        r = await http.post(
                            "/missions", content=body, headers={"Content-Type": "application/json"}
                        )
                        posts.append((r.status_code, time.perf_counter() - started))
                        if r.status_code == 201:
                            await http.post(f"/missions/{r.json()['id']}/cancel")

                    await asyncio.gather(*(one(b) for b in bodies))

        asyncio.run(go())

    busy = livez_while(port, 25, post_costly)
    took = sorted(s for _, s in posts)
    print(f"/livez while posting:       {summary(busy)}")
    print(
        f"  posts: {dict(Counter(c for c, _ in posts))}, each {took[0]:.1f}-{took[-1]:.1f} s (validation in the pool)"
    )
    sim = {
        "theta": [-0.1, 0.53, -0.12, 0.5],
        "phases": [0.6, -0.5, -0.3],
        "duration": 3600,
        "dt": 0.04,
        "max_points": 100_000,
    }
    sims: list[int] = []

    def simulate() -> None:
        async def go() -> None:
            async with httpx.AsyncClient(base_url=base, timeout=120) as http:
                rs = await asyncio.gather(*(http.post("/simulate", json=sim) for _ in range(3)))
                sims.extend(r.status_code for r in rs)

        asyncio.run(go())

    simulating = livez_while(port, 10, simulate)
    print(
        f"/livez while simulating:    {summary(simulating)}  ({dict(Counter(sims))}, 90,000 rows each)"
    )
    worst = max(max(busy), max(simulating))
    print(
        f"worst /livez under the costly requests: {worst:.1f} ms (target <= {STALL_TARGET_MS:g}; idle max {max(idle):.1f})"
    )


def maze() -> dict[str, Any]:
    """A 50 m x 50 m serpentine maze (six walls, 5 m gaps at alternate ends), goal at the far
    corner, planned with pyperplan's A* and hFF: its search grew a worker to 3 GB in 60 s."""
    walls = [
        {"type": "rectangle", "x": -2.5 if k % 2 == 0 else 2.5, "y": y, "width": 45, "height": 0.3}
        for k, y in enumerate((-17.5, -10, -2.5, 5, 12.5, 20))
    ]
    return {
        "name": "soak-maze-50m",
        "start": {"x": -22, "y": -22, "psi": 0},
        "goals": [{"x": 22, "y": 23}],
        "obstacles": walls,
        "bounds": {"xmin": -25, "xmax": 25, "ymin": -25, "ymax": 25},
        "planner": {"search": "astar", "heuristic": "hff", "time_limit": 120},
        "time_limit": 36000,
    }


def memory(worker_memory: str) -> None:
    print(f"\n== memory cap: the 50 m maze with A*/hFF, SCREWSNAKE_WORKER_MEMORY={worker_memory}")
    with tempfile.TemporaryDirectory() as tmp:
        proc, base = start_server(
            Path(tmp) / "memory.db",
            SCREWSNAKE_MAX_RUNNING="1",
            SCREWSNAKE_WORKER_MEMORY=worker_memory,
            SCREWSNAKE_WALL_LIMIT="300",
        )
        try:
            with httpx.Client(base_url=base, timeout=30) as http:
                deadline = time.monotonic() + 300
                while http.get("/readyz").status_code != 200 and time.monotonic() < deadline:
                    time.sleep(0.2)
                before = set(mission_workers(proc.pid))
                mission = http.post("/missions", json=maze()).json()["id"]
                started, peak = time.monotonic(), 0.0
                while time.monotonic() - started < 300:
                    for pid in mission_workers(proc.pid):
                        with contextlib.suppress(OSError, ValueError):
                            peak = max(peak, rss_mb(pid))
                    m = http.get(f"/missions/{mission}").json()
                    if m["status"] in TERMINAL:
                        break
                    time.sleep(0.05)
                took = time.monotonic() - started
                time.sleep(2)  # the replacement starts
                after = set(mission_workers(proc.pid))
                ready = http.get("/readyz").status_code
        finally:
            proc.terminate()
            proc.wait(timeout=60)
    print(f"ended after {took:.1f} s: {m['status']}: {m['reason']}")
    print(
        f"worker RSS sampled every 50 ms: peak {peak:.0f} MB; worker replaced: {before != after and bool(after)}; /readyz after: {ready}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--scenarios",
        default="race,stall,memory",
        help="comma-separated: race, stall, memory (run after the soak)",
    )
    parser.add_argument("--worker-memory", default="1G", help="the memory scenario's cap")
    args = parser.parse_args()
    scenarios = {name for name in args.scenarios.split(",") if name}
    print(
        f"soak: {args.minutes:g} min, seed {args.seed}, server {' '.join(f'{k}={v}' for k, v in SERVER.items())}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        proc, base = start_server(Path(tmp) / "soak.db", **SERVER)
        try:
            rss_start = rss_mb(proc.pid)
            soak = Soak(base, proc.pid, args.minutes * 60, args.seed)
            t0 = time.perf_counter()
            asyncio.run(soak.run())
            missions = drain(base)
            wall = time.perf_counter() - t0
            rss_end = rss_mb(proc.pid)
            health = httpx.get(f"{base}/readyz", timeout=10).status_code
            report(soak, missions, wall, health, rss_start, rss_end)
            if "race" in scenarios:
                race(base, RACE_ROUNDS, args.seed)
            if "stall" in scenarios:
                stall(base, STALL_ROUNDS)
        finally:
            proc.terminate()
            proc.wait(timeout=30)
    if "memory" in scenarios:
        memory(args.worker_memory)


def report(
    soak: Soak, missions: list[dict], wall: float, health: int, rss_start: float, rss_end: float
) -> None:
    fives = sum(n for s, n in soak.statuses.items() if s.startswith("5") and "busy" not in s)
    print(
        f"\nwall {wall:.0f} s (run + drain); workers SIGKILLed: {soak.kills}; websocket sessions: "
        f"{soak.ws_sessions} ({soak.ws_ends} read to their end frame); /readyz at the end: {health}"
    )
    print("\nrequests by status:")
    for status, n in sorted(soak.statuses.items()):
        print(f"  {status:>24}  {n}")
    by_status = Counter(m["status"] for m in missions)
    print(f"\nmissions: {len(missions)}; by status: {dict(sorted(by_status.items()))}")
    reasons = Counter((m["status"], m["reason"].split(":")[0][:60]) for m in missions)
    for (status, reason), n in reasons.most_common():
        print(f"  {n:>5}  {status:<10} {reason}")
    stuck = [m["id"] for m in missions if m["status"] not in TERMINAL]
    internal = sum("internal error" in m["reason"] for m in missions)
    print(f"\nstuck missions: {len(stuck)} (must be 0)")
    print(f"5xx answers (the full queue's '503 busy' above is by design): {fives} (must be 0)")
    print(f"'internal error' reasons: {internal} (must be 0)")
    print(f"server RSS: start {rss_start:.0f} MB, end {rss_end:.0f} MB")


if __name__ == "__main__":
    main()
