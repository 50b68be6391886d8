"""Load: a burst of N missions (20) posted at once, a websocket client each, and a stream of
GET /plan and POST /missions requests, against a real uvicorn server on loopback, while a CPU
burner process loads another core (targets in bench/README.md: API p99 <= 100 ms, every
client gets every mission's ``end`` frame; mission start latency after the burst).

``--executor local|ray|both``: the warm local pool, Ray actors on a local Ray instance, or both
one after the other, with the outcomes of the same seeded missions side by side (they must be
identical: status, reason, goals reached, model time, collisions, replans, final pose).

Bounded: each round stops by itself (a timeout); only 127.0.0.1 is contacted; the burner is
stopped at the end.

    python -m bench.load [--missions 20] [--executor local|ray|both] [--pool N] [--no-burner]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path
from typing import Any

import aiohttp
import httpx
import numpy as np
import websockets

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.settings import cores
from tests.service.test_server import start_server

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
MISSION = json.loads((EXAMPLES / "fig9b-obstacles.json").read_text())
ROUND_TIMEOUT = 600.0
WARM_TIMEOUT = 300.0  # seconds the workers may take to warm up (a first run compiles kernels)
READY_POLL = 0.05  # seconds between looks at /readyz while the workers warm up
TERMINAL = ("succeeded", "failed", "cancelled")
POST_EVERY = 0.25  # seconds between the steady POSTs (each cancelled at once: no extra load)
GET_EVERY = 0.01  # seconds between GET /plan requests
LAG_EVERY = 0.005  # seconds between looks at the bench's own event loop
SLOW_SHOWN = 8  # the slowest POSTs shown with the server's account of their time
BURNER = "while True: pass"  # the other core's load: a busy Python loop


@contextlib.contextmanager
def burner(on: bool) -> Iterator[None]:
    """A process spinning a core at full priority for as long as the block runs."""
    if not on:
        yield
        return
    proc = subprocess.Popen([sys.executable, "-c", BURNER])
    try:
        yield
    finally:
        proc.kill()
        proc.wait(timeout=10)


def shows_running(frame: dict[str, Any]) -> bool:
    """Whether a frame says the mission runs (or ran): it left the queue."""
    if frame["type"] == "snapshot":
        return bool(frame["mission"]["status"] != "queued")
    return frame["type"] != "event" or frame.get("kind") != "status" or frame["status"] != "queued"


async def client(base: str, mission_id: str, posted: float) -> dict[str, float]:
    """Follow a mission's websocket to its end frame; seconds from its POST to the first frame
    that shows it running."""
    url = base.replace("http", "ws") + f"/missions/{mission_id}/ws"
    frames, ended, running = 0, 0.0, float("nan")
    async with websockets.connect(url, max_size=2**22, open_timeout=60) as ws:
        async for raw in ws:
            frames += 1
            frame = json.loads(raw)
            if running != running and shows_running(frame):  # the first one (nan != nan)
                running = time.perf_counter() - posted
            if frame["type"] == "end":
                ended = 1.0
                break
    return {"frames": frames, "ended": ended, "running": running}


async def loop_lag(lags: list[float]) -> None:
    """The bench's own event-loop delays (ms past each LAG_EVERY sleep): when they are large,
    the client itself held up what it measured (JSON of frames, the CPU taken by others)."""
    while True:
        t0 = time.perf_counter()
        await asyncio.sleep(LAG_EVERY)
        lags.append((time.perf_counter() - t0 - LAG_EVERY) * 1e3)


async def getter(
    http: aiohttp.ClientSession, ids: list[str], stop: asyncio.Event, latencies: list[float]
) -> None:
    """GET /plan?mission=... for each mission in turn (404 before its first plan counts too)."""
    i = 0
    while not stop.is_set():
        t0 = time.perf_counter()
        async with http.get("/plan", params={"mission": ids[i % len(ids)]}) as r:
            text = await r.text()
        latencies.append((time.perf_counter() - t0) * 1e3)
        assert r.status in (200, 404), text
        i += 1
        await asyncio.sleep(GET_EVERY)


def server_timing(header: str) -> dict[str, float]:
    """The spans of a ``Server-Timing`` header, in milliseconds (``total`` among them)."""
    spans: dict[str, float] = {}
    for part in header.split(","):
        name, _, params = part.strip().partition(";")
        for param in params.split(";"):
            key, _, value = param.strip().partition("=")
            if key == "dur" and name:
                spans[name] = spans.get(name, 0.0) + float(value)
    return spans


class Post:
    """One POST /missions as the client saw it, with the server's own account of it."""

    def __init__(
        self, kind: str, at: float, ms: float, timing: str, phases: dict[str, float]
    ) -> None:
        self.kind, self.at, self.ms = kind, at, ms  # at: seconds since the round began
        self.spans = server_timing(timing)
        self.phases = phases  # client side, ms: before it was sent, in flight, after


def tracer() -> aiohttp.TraceConfig:
    """An aiohttp trace noting, in a request's ``trace_request_ctx`` (a dict holding its
    ``t0``), when its headers went out and its answer's headers came in (ms after ``t0``)."""
    config = aiohttp.TraceConfig()

    def mark(name: str) -> Any:
        async def hook(session: Any, context: Any, params: Any) -> None:
            marks = context.trace_request_ctx
            if marks is not None:
                marks[name] = (time.perf_counter() - marks["t0"]) * 1e3

        return hook

    config.on_request_headers_sent.append(mark("sent"))
    config.on_request_end.append(mark("answered"))
    return config


async def timed_post(
    http: aiohttp.ClientSession, body: dict[str, Any], kind: str, begun: float, posts: list[Post]
) -> tuple[str, float]:
    """POST a mission, recording it; (mission id, when it was sent)."""
    t0 = time.perf_counter()
    marks: dict[str, float] = {"t0": t0}
    async with http.post("/missions", json=body, trace_request_ctx=marks) as r:
        answer = await r.json()
        timing = r.headers.get("server-timing", "")
    ms = (time.perf_counter() - t0) * 1e3
    assert r.status == 201, answer
    sent, answered = marks.get("sent", float("nan")), marks.get("answered", float("nan"))
    phases = {"before": sent, "flight": answered - sent, "after": ms - answered}
    posts.append(Post(kind, t0 - begun, ms, timing, phases))
    return str(answer["id"]), t0


async def poster(
    http: aiohttp.ClientSession, stop: asyncio.Event, begun: float, posts: list[Post]
) -> None:
    """A steady trickle of POST /missions while the burst runs; each is cancelled at once."""
    while not stop.is_set():
        mission_id, _ = await timed_post(
            http, {**MISSION, "name": "trickle"}, "trickle", begun, posts
        )
        async with http.post(f"/missions/{mission_id}/cancel") as r:
            await r.read()
        await asyncio.sleep(POST_EVERY)


def seconds(mission: dict[str, Any], status: str) -> float | None:
    """Wall seconds from the mission's creation to its first ``status`` transition."""
    at = [t["at"] for t in mission["transitions"] if t["status"] == status]
    if not at:
        return None
    created = datetime.fromisoformat(mission["created_at"])
    return (datetime.fromisoformat(at[0]) - created).total_seconds()


async def load_round(base: str, n: int) -> dict[str, Any]:
    """The burst, the clients and the request streams; the figures and the missions."""
    # The client is aiohttp, not httpx: httpx's async client took ~2 ms of CPU per POST here
    # (encode/httpx#3215), more than the server's ~1.5 ms, on the cores it measures; the
    # burst's slowest POSTs then timed the client (~25 ms before the last was sent).
    timeout = aiohttp.ClientTimeout(total=60)
    async with aiohttp.ClientSession(base, timeout=timeout, trace_configs=[tracer()]) as http:
        # The client's first request sets up what the session creates lazily: done before the
        # burst, or the burst's first POST measures the client.
        async with http.get("/livez") as r:
            assert r.status == 200
        lags: list[float] = []
        watch = asyncio.create_task(loop_lag(lags))
        t0 = time.perf_counter()
        posts: list[Post] = []
        posted = await asyncio.gather(
            *(timed_post(http, {**MISSION, "seed": k}, "burst", t0, posts) for k in range(n))
        )
        ids = [mission_id for mission_id, _ in posted]
        stop = asyncio.Event()
        gets: list[float] = []
        streams = [
            asyncio.create_task(getter(http, ids, stop, gets)),
            asyncio.create_task(poster(http, stop, t0, posts)),
        ]
        results = await asyncio.wait_for(
            asyncio.gather(*(client(base, i, at) for i, at in posted)), ROUND_TIMEOUT
        )
        wall = time.perf_counter() - t0
        stop.set()
        await asyncio.gather(*streams)
        watch.cancel()
        missions = []
        for i in ids:
            async with http.get(f"/missions/{i}") as r:
                missions.append(await r.json())
    started = [seconds(m, "planning") for m in missions]
    executing = [seconds(m, "executing") for m in missions]
    return {
        "wall": wall,
        "get_p50": float(np.percentile(gets, 50)),
        "get_p99": float(np.percentile(gets, 99)),
        "gets": len(gets),
        "post_list": posts,
        "lag_p99": float(np.percentile(lags, 99)),
        "lag_max": max(lags),
        "ended": int(sum(r["ended"] for r in results)),
        "frames": int(sum(r["frames"] for r in results)),
        "start_first": min(s for s in started if s is not None),
        "start_p50": float(np.median([s for s in started if s is not None])),
        "start_max": max(s for s in started if s is not None),
        "executing_first": min(s for s in executing if s is not None),
        "frame_first": float(np.nanmin([r["running"] for r in results])),
        "frame_p50": float(np.nanmedian([r["running"] for r in results])),
        "missions": missions,
    }


def outcome(mission: dict[str, Any]) -> tuple[Any, ...]:
    """What must not depend on where a seeded mission ran."""
    goals = tuple((g["reached"], g["error"]) for g in mission["goals"])
    pose = tuple(sorted(mission["pose"].items(), key=lambda kv: kv[0]))
    return (
        mission["status"],
        mission["reason"],
        goals,
        mission["model_time"],
        mission["collisions"],
        mission["replans"],
        str(pose),
    )


def wait_warm(base: str, timeout: float = WARM_TIMEOUT) -> dict[str, int]:
    """Poll /readyz until it is 200 with every worker warm (``warm == size``): the burst then
    measures the service, not its start-up. The workers' count as /readyz last said it."""
    deadline = time.monotonic() + timeout
    while True:
        r = httpx.get(f"{base}/readyz", timeout=10)
        workers: dict[str, int] = r.json().get("workers") or {}
        if r.status_code == 200 and workers["warm"] == workers["size"]:
            return workers
        if r.status_code not in (200, 503) or time.monotonic() > deadline:
            raise AssertionError(f"workers not warm after {timeout:g} s: {r.status_code} {r.text}")
        time.sleep(READY_POLL)


def run(executor: str, n: int, load: bool, pool: int | None) -> dict[str, Any]:
    # The workers warm up as the service's do by default (the test servers' do not).
    env = {"SCREWSNAKE_EXECUTOR": executor, "SCREWSNAKE_WARM_UP": "1"}
    if pool is not None:
        env["SCREWSNAKE_MAX_RUNNING"] = str(pool)
    with tempfile.TemporaryDirectory() as tmp, burner(load):
        t0 = time.perf_counter()
        proc, base = start_server(Path(tmp) / "load.db", **env)
        ready = time.perf_counter() - t0
        try:
            wait_warm(base)
            warm = time.perf_counter() - t0
            result = asyncio.run(load_round(base, n))
        finally:
            proc.terminate()
            proc.wait(timeout=60)
    result["ready"], result["warm"] = ready, warm
    return result


def percentiles(ms: list[float]) -> str:
    return f"p50 {np.percentile(ms, 50):6.1f} ms  p99 {np.percentile(ms, 99):6.1f} ms"


def slow_posts(posts: list[Post], shown: int = SLOW_SHOWN) -> None:
    """The slowest POSTs: when they came, the client's share (before the request went out,
    after its answer came in), and where the server says its time went (in flight beyond the
    server's ``total``: the connection and uvicorn, before and after the app)."""
    print(f"  the {shown} slowest POSTs (ms; the server's spans):")
    for post in sorted(posts, key=lambda p: p.ms, reverse=True)[:shown]:
        spans = "  ".join(f"{k} {v:.1f}" for k, v in post.spans.items() if k != "total")
        total = post.spans.get("total", float("nan"))
        before, flight, after = (post.phases[k] for k in ("before", "flight", "after"))
        print(
            f"    {post.kind:>7} at {post.at:6.1f} s: {post.ms:6.1f} = client {before:5.1f}"
            f" + in flight {flight:5.1f} + client {after:5.1f}; server {total:5.1f}  [{spans}]"
        )
    names = sorted({k for p in posts for k in p.spans})
    print(
        "  server spans over all POSTs, p50 / p99 ms: "
        + ", ".join(
            f"{k} {np.percentile([p.spans.get(k, 0.0) for p in posts], 50):.1f}"
            f"/{np.percentile([p.spans.get(k, 0.0) for p in posts], 99):.1f}"
            for k in names
        )
    )


def report(executor: str, n: int, r: dict[str, Any]) -> None:
    """Print one run's figures."""
    ok = sum(m["status"] == "succeeded" for m in r["missions"])
    posts: list[Post] = r["post_list"]
    every = [p.ms for p in posts]  # the target counts every POST: the burst and the trickle
    post_p99 = float(np.percentile(every, 99))
    verdict = "ok" if max(r["get_p99"], post_p99) <= 100 and r["ended"] == n else "MISSED"
    size = r["pool"] or f"{cores()} (the cores)"
    print(
        f"\nexecutor={executor}, pool of {size}: server ready in {r['ready']:.1f} s,"
        f" workers warm in {r['warm']:.1f} s (/readyz: every worker warm; then the burst)"
    )
    burst = [p.ms for p in posts if p.kind == "burst"]
    print(
        f"  {n} missions posted at once: POST p50 {np.median(burst):.0f} ms,"
        f" slowest {max(burst):.0f} ms (burst, queued at once)"
    )
    print(
        f"  start latency (POST -> planning): first {r['start_first'] * 1e3:.0f} ms,"
        f" median {r['start_p50']:.2f} s, last {r['start_max']:.2f} s;"
        f" first executing {r['executing_first'] * 1e3:.0f} ms"
    )
    print(
        f"  POST -> first frame showing it running (client side): first"
        f" {r['frame_first'] * 1e3:.0f} ms, median {r['frame_p50']:.2f} s"
    )
    print(
        f"  GET /plan      p50 {r['get_p50']:6.1f} ms  p99 {r['get_p99']:6.1f} ms  ({r['gets']} requests)"
    )
    trickle = [p.ms for p in posts if p.kind == "trickle"]
    print(
        f"  POST /missions {percentiles(every)}  ({len(every)} requests: the burst and the trickle)"
    )
    print(f"    the trickle  {percentiles(trickle)}  ({len(trickle)} requests)")
    print(
        f"  end frames {r['ended']}/{n}, frames {r['frames']}, succeeded {ok}/{n},"
        f" wall {r['wall']:.1f} s, {n / r['wall']:.2f} missions/s"
        f"  [target p99 <= 100 ms, every end frame: {verdict}]"
    )
    print(
        f"  the bench's own event loop: delays p99 {r['lag_p99']:.1f} ms, max {r['lag_max']:.1f} ms"
        " (a client-side share of any latency above)"
    )
    slow_posts(posts)


def compare(n: int, local: dict[str, Any], ray: dict[str, Any]) -> None:
    print(f"\nthe same {n} seeded missions, local pool vs Ray:")
    print(f"{'seed':>5}{'status':>11}{'reached':>9}{'model t [s]':>13}{'collisions':>12}  same")
    same = 0
    for seed, (a, b) in enumerate(zip(local["missions"], ray["missions"], strict=True)):
        equal = outcome(a) == outcome(b)
        same += equal
        reached = sum(g["reached"] for g in a["goals"])
        print(
            f"{seed:>5}{a['status']:>11}{reached:>6}/{len(a['goals'])}{a['model_time']:>13.2f}"
            f"{a['collisions']:>12}  {'yes' if equal else 'NO: ' + str(outcome(b))}"
        )
    print(f"identical outcomes: {same}/{n}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--missions", type=int, default=20)
    parser.add_argument("--executor", choices=("local", "ray", "both"), default="local")
    parser.add_argument("--no-burner", action="store_true", help="leave the other core idle")
    parser.add_argument(
        "--pool", type=int, default=None, help="SCREWSNAKE_MAX_RUNNING (default: the cores)"
    )
    args = parser.parse_args()
    n = args.missions
    print(
        f"{n} x fig9b-obstacles (seeds 0..{n - 1}) at speed 0, one websocket client each,"
        f" GET /plan every {GET_EVERY * 1e3:.0f} ms, a POST every {POST_EVERY:g} s;"
        f" {'a CPU burner on the other core' if not args.no_burner else 'no burner'}"
    )
    executors = ("local", "ray") if args.executor == "both" else (args.executor,)
    results = {}
    for executor in executors:
        results[executor] = run(executor, n, not args.no_burner, args.pool) | {"pool": args.pool}
        report(executor, n, results[executor])
    if len(results) == 2:
        compare(n, results["local"], results["ray"])


if __name__ == "__main__":
    main()
