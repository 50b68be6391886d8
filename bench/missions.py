"""Every mission of examples/, examples/hard/, examples/untuned/ and examples/periodic/ (the
periodic gait's), as fast as possible, checked against what it expects (bench/README.md,
targets: accuracy, contacts, model time / wall time).

    python -m bench.missions [--only PATTERN] [--set DIR] [--noise SIGMA] [--repeat N] [--workers 2]
        [--cap 120] [--server] [--load] [--json FILE]

A mission is ``ok`` when it ends as its ``expect`` says (``examples/`` without one: succeeded)
and, for a success, every goal is within its tolerance and nothing known was touched (known
obstacles and the arena walls; hidden obstacles may be found by touch). Missions run in a pool
of processes, each under a wall-clock cap; a crash or a timeout is a row, never the bench's end.

``--server`` runs the same missions through a real server instead (uvicorn, one mission worker,
posted one after another): a row's wall time is the service's own, from the ``planning``
transition to the end (what a user of the API waits), its replans' latencies the service's
records; what is checked is the status and the goals (contacts by kind are simulator truth the
API does not show). ``--load`` keeps another core busy meanwhile (a spinning process): the
figures a loaded machine gives.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, TypeVar

from app.executor.context import MissionResult
from app.executor.runner import MissionRunner
from app.executor.warm import warm_up
from app.missions.spec import MissionSpec, load_mission
from primitives.library import Library, load_bundled

ROOT = Path(__file__).resolve().parents[1]
SETS = {
    "examples": ROOT / "examples",
    "hard": ROOT / "examples" / "hard",
    "untuned": ROOT / "examples" / "untuned",
    "periodic": ROOT / "examples" / "periodic",
}
GRACE = 30.0  # wall seconds past the cap before the parent stops waiting for a stuck worker
J = TypeVar("J")
R = TypeVar("R")


@dataclass(frozen=True)
class Job:
    set: str
    path: str
    noise: float | None
    repeat: int
    cap: float


@dataclass
class Row:
    """One mission's outcome: one line of the table."""

    set: str
    name: str
    expected: str
    status: str
    ok: bool = False
    reached: int = 0
    goals: int = 0
    max_error_cm: float = float("nan")
    contacts: int = 0
    known_contacts: int = 0
    repeated_contacts: int = 0  # contacts with a hidden obstacle after the first
    replans: int = 0
    model_time: float = 0.0
    wall_time: float = float("nan")
    cpu_time: float = float(
        "nan"
    )  # this process's CPU seconds (what a loaded machine disturbs less)
    reason: str = ""
    latencies: list[float] = field(default_factory=list)  # each replan's planning, wall ms
    worker: int | None = None  # --server: the pid of the worker that ran it

    @property
    def ratio(self) -> float:
        """Model seconds per wall second; NaN for a crash, a timeout, or a mission that ended
        before any model time passed (e.g. no plan exists): nothing ran to compare."""
        if self.status.startswith(("error", "timeout")) or not self.wall_time > 0:
            return float("nan")
        if not self.model_time > 0:
            return float("nan")
        return self.model_time / self.wall_time

    @property
    def cpu_ratio(self) -> float:
        """Model seconds per CPU second of the mission's process (NaN as for ``ratio``)."""
        if self.ratio != self.ratio or not self.cpu_time > 0:
            return float("nan")
        return self.model_time / self.cpu_time


class Deadline:
    """A cancel flag that sets itself once ``cap`` wall seconds have passed (the runner polls it
    every control interval, so a slow mission ends cleanly instead of holding a worker)."""

    def __init__(self, cap: float) -> None:
        self.until = time.perf_counter() + cap
        self.fired = False

    def is_set(self) -> bool:
        self.fired = self.fired or time.perf_counter() > self.until
        return self.fired


_LIBRARY: list[Library] = []  # one per worker process, built on first use


def _library() -> Library:
    if not _LIBRARY:
        library = load_bundled()
        _LIBRARY.append(library)
    return _LIBRARY[0]


def expected_of(spec: MissionSpec) -> tuple[str, str | None]:
    """The expected status and reason substring (an example without ``expect`` should succeed)."""
    if spec.expect is None:
        return "succeeded", None
    return spec.expect.status, spec.expect.reason


def _warm_worker() -> None:
    """A pool process's start: the warm-up mission, as the service's workers run it."""
    warm_up(_library())


def with_noise(spec: MissionSpec, noise: float | None) -> MissionSpec:
    """The mission with every range sensor's noise set to ``noise`` (``None``: as it is)."""
    if noise is None:
        return spec
    data = spec.model_dump(by_alias=True)
    data["sensors"]["noise"] = noise
    return MissionSpec.model_validate(data)


@dataclass
class Run:
    """One mission run: its row, and the runner and result of its last repetition (for
    benches that read more of it than the row holds)."""

    row: Row
    runner: MissionRunner
    result: MissionResult


def run_spec(set_name: str, spec: MissionSpec, repeat: int, cap: float) -> Run:
    """Run ``spec`` ``repeat`` times (best wall time) in this process, each under ``cap`` wall
    seconds, and check it against its expectation."""
    status, reason = expected_of(spec)
    row = Row(set_name, spec.name, status + (f":{reason}" if reason else ""), "error")
    library = _library()
    best, best_cpu = float("inf"), float("inf")
    last: tuple[MissionRunner, MissionResult] | None = None
    for _ in range(repeat):
        flag = Deadline(cap)
        t0, c0 = time.perf_counter(), time.process_time()
        runner = MissionRunner(spec, library, cancel=flag)
        last = runner, runner.run()
        best = min(best, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
        if flag.fired:
            break
    assert last is not None  # repeat >= 1
    runner, result = last
    row.wall_time, row.cpu_time = best, best_cpu
    row.model_time = result.model_time
    row.status = "timeout" if flag.fired else result.status
    row.reason = f"over the {cap:g} s wall cap" if flag.fired else result.reason
    row.goals = len(result.goals)
    row.reached = sum(g.reached for g in result.goals)
    errors = [g.error for g in result.goals if g.error is not None]
    row.max_error_cm = max(errors) * 100 if errors else float("nan")
    row.contacts = result.collisions
    row.replans = len(result.replans)
    row.latencies = [r.latency_ms for r in result.replans]
    # Simulator truth (the executor never sees it): what each contact touched.
    touched = [i for _, i in getattr(runner.robot, "truth_contacts", [])]
    known = {i for i, o in enumerate(spec.obstacles) if o.known} | {-1}  # -1: the arena wall
    row.known_contacts = sum(1 for i in touched if i in known)
    hidden = [i for i in touched if i not in known]
    row.repeated_contacts = len(hidden) - len(set(hidden))
    met = row.status == status and (reason is None or reason in row.reason)
    if status == "succeeded":
        accurate = all(
            g.reached and g.error is not None and g.error <= g.tolerance for g in result.goals
        )
        # the target (bench/README.md): nothing known touched, a hidden obstacle at most once (found by touch)
        met = met and accurate and row.known_contacts == 0 and row.repeated_contacts == 0
    row.ok = met
    return Run(row, runner, result)


def run_job(job: Job) -> Row:
    """Run one mission file ``job.repeat`` times (best wall time) in this process; never raises."""
    path = Path(job.path)
    row = Row(job.set, path.stem, "?", "error")
    try:
        spec = with_noise(load_mission(path), job.noise)
        status, reason = expected_of(spec)
        row.name, row.expected = spec.name, status + (f":{reason}" if reason else "")
        return run_spec(job.set, spec, job.repeat, job.cap).row
    except BaseException as exc:  # the bench reports a crash, it does not die of it
        row.status = f"error: {type(exc).__name__}: {exc}".splitlines()[0][:200]
        traceback.print_exc(limit=-3, file=sys.stderr)  # where it broke, for whoever fixes it
        return row


def missions(only: str | None) -> list[Job]:
    """Jobs for every mission file of every set, filtered by ``--only`` (glob or substring)."""
    found = []
    for name, folder in SETS.items():
        for path in sorted(folder.glob("*.json")):
            key = f"{name}/{path.stem}"
            if (
                only is None
                or only in key
                or any(fnmatch.fnmatch(k, only) for k in (key, path.stem))
            ):
                found.append((name, path))
    return [Job(s, str(p), None, 1, 0.0) for s, p in found]


HEADER = (
    f"{'set':<9}{'mission':<41}{'expected':<21}{'status':<11}{'ok':<4}{'goals':>6}"
    f"{'err [cm]':>9}{'contacts':>9}{'known':>6}{'again':>6}{'replans':>8}{'model [s]':>10}{'wall [s]':>9}"
    f"{'ratio':>8}{'mdl/cpu':>9}"
)


def line(row: Row) -> str:
    status = row.status if len(row.status) <= 10 else row.status[:10]
    return (
        f"{row.set:<9}{row.name[:40]:<41}{row.expected[:20]:<21}{status:<11}"
        f"{'yes' if row.ok else 'NO':<4}{f'{row.reached}/{row.goals}':>6}"
        f"{row.max_error_cm:>9.1f}{row.contacts:>9}{row.known_contacts:>6}"
        f"{row.repeated_contacts:>6}{row.replans:>8}"
        f"{row.model_time:>10.0f}{row.wall_time:>9.2f}{row.ratio:>7.0f}x{row.cpu_ratio:>8.0f}x"
    )


def run_pool(
    jobs: Sequence[J],
    work: Callable[[J], R],
    workers: int,
    wait: Callable[[J], float],
    failed: Callable[[J, str, str], R],
    show: Callable[[R], None],
) -> list[R]:
    """Run ``work`` on every job in a pool of ``workers`` warm processes, calling ``show`` on
    each result in order as it ends; a job gets ``wait(job)`` wall seconds.

    A worker that dies takes the pool with it: the jobs it held become ``failed(job, status,
    reason)`` rows and a fresh pool runs the rest. A worker stuck past its wait (inside one
    tick) is reported ``timeout`` and its process ended when the bench finishes.
    """
    rows: dict[int, R] = {}
    todo = list(range(len(jobs)))
    stuck: list[ProcessPoolExecutor] = []
    leftovers: list[Any] = []  # worker processes of pools with a stuck worker
    while todo:
        pool = ProcessPoolExecutor(max_workers=workers, initializer=_warm_worker)
        futures: dict[int, Future[R]] = {i: pool.submit(work, jobs[i]) for i in todo}
        broken = False
        for i in list(todo):
            job = jobs[i]
            try:
                rows[i] = futures[i].result(timeout=wait(job))
            except TimeoutError:
                why = f"no answer within the cap + {GRACE:g} s (stuck in one tick)"
                rows[i] = failed(job, "timeout", why)
                stuck.append(pool)
                leftovers.extend((getattr(pool, "_processes", None) or {}).values())
            except BrokenProcessPool as exc:
                rows[i] = failed(job, f"error: worker died ({exc})", "")
                broken = True
            except BaseException as exc:
                rows[i] = failed(job, f"error: {exc}", "")
            todo.remove(i)
            show(rows[i])
            if broken:
                break
        pool.shutdown(wait=not broken and pool not in stuck, cancel_futures=True)
    for process in leftovers:  # only processes this bench started, all work done by now
        if process.is_alive():
            process.terminate()
    return [rows[i] for i in range(len(jobs))]


def run_all(jobs: list[Job], workers: int, cap: float) -> list[Row]:
    """The mission files' jobs in a pool (``run_pool``), printing each row as it ends."""

    def failed(job: Job, status: str, reason: str) -> Row:
        row = Row(job.set, Path(job.path).stem, "?", status, reason=reason)
        if status == "timeout":
            row.wall_time = cap
        return row

    return run_pool(
        jobs,
        run_job,
        workers,
        lambda job: cap * job.repeat + GRACE,
        failed,
        lambda row: print(line(row), flush=True),
    )


def summary(rows: list[Row]) -> list[str]:
    out = []
    for name in SETS:
        subset = [r for r in rows if r.set == name]
        if subset:
            passed = sum(r.ok for r in subset)
            out.append(f"{name}: passed {passed}/{len(subset)}")
    ratios = [r.ratio for r in rows if r.ratio == r.ratio]
    idle = sum(
        1 for r in rows if r.model_time == 0 and not r.status.startswith(("error", "timeout"))
    )
    if ratios:
        left_out = f" ({idle} ended before any model time passed, left out)" if idle else ""
        out.append(
            f"model/wall ratio over {len(ratios)} missions that ran{left_out}: median "
            f"{statistics.median(ratios):.0f}x, minimum {min(ratios):.0f}x"
        )
        cpu = [r.cpu_ratio for r in rows if r.cpu_ratio == r.cpu_ratio]
        if cpu:
            out.append(
                f"model/CPU ratio (the worker's own CPU time): median "
                f"{statistics.median(cpu):.0f}x, minimum {min(cpu):.0f}x"
            )
    latencies = sorted(v for r in rows for v in r.latencies)
    if latencies:
        p95 = latencies[min(len(latencies) - 1, round(0.95 * (len(latencies) - 1)))]
        out.append(
            f"replan latency over {len(latencies)} replans: median "
            f"{statistics.median(latencies):.1f} ms, p95 {p95:.1f} ms"
        )
    for r in rows:
        if not r.ok:
            why = r.status if r.status.startswith("error") else f"{r.status}: {r.reason}"
            out.append(f"  not ok: {r.set}/{r.name}: {why[:200]}")
    return out


def spin() -> None:
    """Keep a core busy (``--load``) until terminated."""
    while True:
        pass


def worker_pid(mission: dict[str, Any]) -> int | None:
    """The worker process running a mission (its ``planning`` transition names it)."""
    for t in mission["transitions"]:
        words = t["reason"].split()
        if t["status"] == "planning" and words[:2] == ["worker", "pid"]:
            return int(words[2])
    return None


def cpu_seconds(pid: int | None) -> float:
    """A local process's CPU seconds so far (user + system; NaN if unknown)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS
    except (OSError, ValueError, IndexError, TypeError):
        return float("nan")


POLL_SECONDS = 0.25  # between looks at a served mission (its times are the service's own)
CLOCK_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def served_row(client: Any, job: Job, cap: float, last: int | None = None) -> Row:
    """Post one mission file to the server, wait for its end, read its row from the API.
    ``last``: the worker pid the previous mission ran on; its CPU is read before the post, so
    that a mission ending within the first poll is not counted from the poll (it was)."""
    path = Path(job.path)
    spec = load_mission(path)
    status, reason = expected_of(spec)
    row = Row(job.set, spec.name, status + (f":{reason}" if reason else ""), "error")
    body = json.loads(path.read_text())
    before = cpu_seconds(last)
    created = client.post("/missions", json=body)
    if created.status_code != 201:
        row.status = f"error: POST {created.status_code}"
        row.reason = created.text[:200]
        return row
    mission_id = created.json()["id"]
    deadline = time.monotonic() + cap + GRACE
    pid, cpu = None, 0.0
    while True:
        mission = client.get(f"/missions/{mission_id}").json()
        if pid is None:
            pid = worker_pid(mission)
            cpu = before if pid is not None and pid == last else cpu_seconds(pid)
        if mission["status"] in ("succeeded", "failed", "cancelled"):
            row.cpu_time = cpu_seconds(pid) - cpu
            break
        if time.monotonic() > deadline:
            client.post(f"/missions/{mission_id}/cancel")
            row.status, row.reason, row.wall_time = "timeout", f"over {cap:g} s", cap
            return row
        time.sleep(POLL_SECONDS)
    at = {t["status"]: datetime.fromisoformat(t["at"]) for t in mission["transitions"]}
    row.wall_time = (at[mission["status"]] - at["planning"]).total_seconds()
    row.status, row.reason = mission["status"], mission["reason"]
    row.worker = pid
    row.model_time = mission["model_time"]
    row.goals = len(mission["goals"])
    row.reached = sum(g["reached"] for g in mission["goals"])
    errors = [g["error"] for g in mission["goals"] if g["error"] is not None]
    row.max_error_cm = max(errors) * 100 if errors else float("nan")
    row.contacts = mission["collisions"]
    replans = client.get(f"/missions/{mission_id}/plan").json().get("replans", [])
    row.latencies = [r["latency_ms"] for r in replans]
    row.replans = len(row.latencies)
    met = row.status == status and (reason is None or reason in row.reason)
    if status == "succeeded":
        met = met and all(
            g["reached"] and g["error"] is not None and g["error"] <= g["tolerance"]
            for g in mission["goals"]
        )
    row.ok = met
    return row


def run_served(jobs: list[Job], cap: float) -> list[Row]:
    """The mission files through a real server (``--server``), one at a time, printing each
    row as it ends."""
    import httpx

    from tests.service.test_readiness import wait_ready
    from tests.service.test_server import start_server

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # Its worker warms up as the service's do by default (the test servers' do not):
        # /readyz answers 200 once it has, and the figures are those of a warm service.
        env = {
            "SCREWSNAKE_MAX_RUNNING": "1",
            "SCREWSNAKE_WALL_LIMIT": f"{cap:g}",
            "SCREWSNAKE_WARM_UP": "1",
        }
        proc, base = start_server(Path(tmp) / "bench.db", **env)
        try:
            with httpx.Client(base_url=base, timeout=60) as client:
                wait_ready(client.get)
                server_cpu = cpu_seconds(proc.pid)
                last: int | None = None  # the one mission worker's pid, once known
                for job in jobs:
                    try:
                        row = served_row(client, job, cap, last)
                        last = row.worker or last
                    except Exception as exc:  # a row, never the bench's end
                        row = Row(job.set, Path(job.path).stem, "?", f"error: {exc}"[:200])
                    rows.append(row)
                    print(line(row), flush=True)
                server_cpu = cpu_seconds(proc.pid) - server_cpu
                workers_cpu = sum(r.cpu_time for r in rows if r.cpu_time == r.cpu_time)
                print(
                    f"CPU seconds: the mission worker {workers_cpu:.2f}, the server process (API, "
                    f"supervisor, store, frames, the bench's polls) {server_cpu:.2f}",
                    flush=True,
                )
        finally:
            proc.terminate()
            proc.wait(timeout=30)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="missions whose set/name matches (glob or substring)")
    parser.add_argument("--noise", type=float, help="override every range sensor's noise [m]")
    parser.add_argument("--repeat", type=int, default=1, help="runs per mission, best wall time")
    parser.add_argument("--workers", type=int, default=2, help="processes in the pool")
    parser.add_argument("--cap", type=float, default=120.0, help="wall seconds per mission run")
    parser.add_argument(
        "--server", action="store_true", help="through a real server (one mission worker)"
    )
    parser.add_argument("--load", action="store_true", help="keep another core busy meanwhile")
    parser.add_argument(
        "--json",
        metavar="FILE",
        type=Path,
        help="also write every row (with each replan's latency) to FILE as JSON",
    )
    parser.add_argument(
        "--set",
        action="append",
        metavar="DIR",
        help="run the missions of this folder instead of the built-in sets (repeatable; the "
        "set is named after the folder)",
    )
    args = parser.parse_args(argv)
    if args.repeat < 1 or args.workers < 1 or not args.cap > 0:
        parser.error("--repeat and --workers must be >= 1 and --cap > 0")
    if args.noise is not None and not 0 <= args.noise <= 0.5:
        parser.error("--noise must lie in [0, 0.5] m")
    if args.set:
        folders = [Path(d) for d in args.set]
        if missing := [str(d) for d in folders if not d.is_dir()]:
            parser.error(f"--set: no such folder: {', '.join(missing)}")
        SETS.clear()  # the named folders replace the built-in sets (rows and summary)
        SETS.update({d.resolve().name: d for d in folders})
    jobs = [Job(j.set, j.path, args.noise, args.repeat, args.cap) for j in missions(args.only)]
    if not jobs:
        print(f"no mission matches {args.only!r}", file=sys.stderr)
        return 1
    load = multiprocessing.get_context("spawn").Process(target=spin, daemon=True)
    if args.load:
        load.start()
    try:
        print(HEADER, flush=True)
        rows = run_served(jobs, args.cap) if args.server else run_all(jobs, args.workers, args.cap)
    finally:
        if args.load:
            load.terminate()  # the process this bench started
            load.join()
    print("\n".join(summary(rows)))
    if args.json is not None:
        fields = [{**asdict(r), "ratio": r.ratio, "cpu_ratio": r.cpu_ratio} for r in rows]
        args.json.write_text(json.dumps(fields, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
