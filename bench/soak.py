"""Soak: a bounded run (default 10 minutes) against a real uvicorn server with a mix of valid,
invalid, oversized, slow and planning-heavy missions, cancels, SIGKILLed mission workers and
websocket churn. Prints requests by status, missions by terminal status and reason, stuck
missions (must be 0), 5xx answers (must be 0) and the server's RSS at start and end.

Only 127.0.0.1 is contacted; every phase has a deadline. ``--minutes 3`` for a shorter run.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import random
import signal
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
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
        finally:
            proc.terminate()
            proc.wait(timeout=30)
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
