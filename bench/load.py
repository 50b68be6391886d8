"""Load: N missions posted at once (as fast as possible), a websocket client each, and a stream
of GET requests, against a real uvicorn server on loopback (DESIGN §8: at 20 missions and 20
clients, every client gets its terminal frame and API p99 <= 100 ms).

Bounded: each round stops by itself (a timeout per round); only 127.0.0.1 is contacted.
"""

from __future__ import annotations

import asyncio
import json
import re
import sys
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np
import websockets

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.service.test_server import start_server

MISSION = json.loads(
    (Path(__file__).resolve().parents[1] / "examples" / "fig9b-obstacles.json").read_text()
)
ROUND_TIMEOUT = 300.0


async def client(base: str, mission_id: str) -> dict[str, float]:
    url = base.replace("http", "ws") + f"/missions/{mission_id}/ws"
    frames, ended, model_time = 0, 0.0, 0.0
    async with websockets.connect(url, max_size=2**22, open_timeout=30) as ws:
        async for raw in ws:
            frame = json.loads(raw)
            frames += 1
            if frame["type"] == "state":
                model_time = frame["t"]
            if frame["type"] == "end":
                ended = 1.0
                break
    return {"frames": frames, "ended": ended, "model_time": model_time}


async def getter(
    http: httpx.AsyncClient, ids: list[str], stop: asyncio.Event, latencies: list[float]
) -> None:
    i = 0
    while not stop.is_set():
        path = f"/missions/{ids[i % len(ids)]}" if i % 2 else "/missions?limit=10"
        t0 = time.perf_counter()
        r = await http.get(path)
        latencies.append((time.perf_counter() - t0) * 1e3)
        assert r.status_code == 200
        i += 1
        await asyncio.sleep(0.01)


async def round_of(base: str, n: int) -> dict[str, float]:
    async with httpx.AsyncClient(base_url=base, timeout=30) as http:
        t0 = time.perf_counter()
        posted = await asyncio.gather(
            *(http.post("/missions", json={**MISSION, "seed": k}) for k in range(n))
        )
        ids = [r.json()["id"] for r in posted]
        stop, latencies = asyncio.Event(), []
        get_task = asyncio.create_task(getter(http, ids, stop, latencies))
        results = await asyncio.wait_for(
            asyncio.gather(*(client(base, i) for i in ids)), ROUND_TIMEOUT
        )
        wall = time.perf_counter() - t0
        stop.set()
        await get_task
        missions = [(await http.get(f"/missions/{i}")).json() for i in ids]
        metrics = (await http.get("/metrics")).text
    dropped = float(re.search(r"^screwsnake_ws_frames_dropped_total (\S+)", metrics, re.M).group(1))
    return {
        "n": n,
        "wall": wall,
        "throughput": n / wall,
        "ratio": sum(m["model_time"] for m in missions) / wall,
        "p50": float(np.percentile(latencies, 50)),
        "p99": float(np.percentile(latencies, 99)),
        "requests": len(latencies),
        "frames": sum(r["frames"] for r in results),
        "dropped": dropped,
        "ended": sum(r["ended"] for r in results),
        "succeeded": sum(m["status"] == "succeeded" for m in missions),
    }


def main() -> None:
    print(
        "fig9b-obstacles missions at speed 0 (as fast as possible), one websocket client each, GETs every 10 ms"
    )
    for running in (4, 20):
        print(f"\nserver: SCREWSNAKE_MAX_RUNNING={running} (the rest queue)")
        print(
            f"{'N':>4}{'wall [s]':>10}{'missions/s':>12}{'model/wall':>12}{'API p50 [ms]':>14}{'p99 [ms]':>10}"
            f"{'GETs':>7}{'frames':>8}{'dropped':>9}{'end frames':>12}{'succeeded':>11}"
        )
        with tempfile.TemporaryDirectory() as tmp:
            proc, base = start_server(Path(tmp) / "load.db", SCREWSNAKE_MAX_RUNNING=str(running))
            try:
                previous_dropped = 0.0
                for n in (1, 5, 20, 50):
                    r = asyncio.run(round_of(base, n))
                    dropped, previous_dropped = r["dropped"] - previous_dropped, r["dropped"]
                    print(
                        f"{n:>4}{r['wall']:>10.2f}{r['throughput']:>12.2f}{r['ratio']:>11.0f}x{r['p50']:>14.1f}{r['p99']:>10.1f}"
                        f"{r['requests']:>7.0f}{r['frames']:>8.0f}{dropped:>9.0f}{r['ended']:>7.0f}/{n:<4}{r['succeeded']:>8.0f}/{n}",
                        flush=True,
                    )
            finally:
                proc.terminate()
                proc.wait(timeout=30)


if __name__ == "__main__":
    main()
