"""The navigation scoreboard: generated worlds and example missions, per set and noise level.

    python -m bench.scoreboard --family posts --seeds 1000-1199 --noise own 0.02 --workers 2
    python -m bench.scoreboard --family all --seeds 0-19 --examples --json out/board.json

**Seeds are split (issue 28): tune on seeds 0-99; report on seeds 1000-1199, never looked at
while tuning** (``bench.worlds.TUNING_SEEDS``, ``REPORT_SEEDS``). A change is measured on the
report seeds once it is made, before and after, and nothing is tuned on what they show.

Per set and noise level (``own``: each mission's own noise; or a σ in metres on every range
sensor): runs; succeeded; succeeded with no contact at all; contacts per 10 m travelled (the
body centroid's path); false ``unreachable`` (a failure ending ``unreachable`` that the same
world with every obstacle known turns into a success: the known twin runs for every failed
row, and a failure of any other kind it rescues is counted as rescued); as expected; the
deepest penetration of the simulated body into an obstacle (simulator truth at every step:
should be 0); model time (median of the successes); planning latency p95 (every plan and
replan record's ``latency_ms``); then contacts by body part (head, units 1-4) and by the kind
of motion running when it touched (read from the executed log: ``lat-straight-t025-a180`` is
a translation at body angle 180°, head first, since the heading points from head to tail).
Generated worlds carry the flood fill's verdict (``bench.feasibility``): feasible ones and
``reshape`` ones (passable only if the body changes shape on the way, listed apart too) expect
success, infeasible ones ``unreachable``, and borderline ones are listed apart and left out of
the figures.
Simulator truth is read here only, never by the executor. ``--json`` keeps every row and
figure for comparing runs later.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
import subprocess
import sys
import time
import traceback
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.missions.spec import MissionSpec
from bench.missions import GRACE, ROOT, run_pool, run_spec, with_noise
from bench.worlds import FAMILIES, generate, known_twin, parse_seeds
from sim.obstacles import Circle, Polygon, point_segment_distance
from sim.robot import Array, centroid
from sim.world import World, footprint

# The example missions (112 with these folders): every set but the paper's figures.
EXAMPLE_SETS = (
    "examples",
    "hard",
    "untuned",
    "untuned2",
    "untuned3",
    "untuned4",
    "untuned5",
    "untuned6",
)
PARTS = ("head", "unit 1", "unit 2", "unit 3", "unit 4")
KINDS = (
    "head first",
    "oblique head first",
    "sideways",
    "oblique tail first",
    "tail first",
    "turn in place",
    "back-off",
    "recovery spin",
    "final approach",
    "reshape",
    "hold",
)
_PRIMITIVE = re.compile(r"lat-[a-z-]+?-(?:t\d+-a(?P<angle>\d{3})|r(?P<sign>[pm])\d+p\d+)")


@dataclass(frozen=True)
class Job:
    """One run: a generated world (``family`` and ``seed``) or a mission file (``path``)."""

    set: str
    noise: float | None  # None: the mission's own
    cap: float
    family: str | None = None
    seed: int = 0
    known: bool = False  # a generated world with every obstacle known
    path: str | None = None


@dataclass
class Score:
    """One run's figures (and its known twin's outcome when it failed)."""

    set: str
    name: str
    noise: str
    verdict: str = ""  # the flood fill's: feasible, reshape, borderline, infeasible ("" for files)
    expected: str = "succeeded"
    status: str = "error"
    reason: str = ""
    ok: bool = False  # as expected, as bench.missions judges it
    contacts: int = 0
    known_contacts: int = 0  # simulator truth: known obstacles and the arena wall
    touches: list[tuple[int, str]] = field(default_factory=list)  # (part, motion kind)
    travelled: float = 0.0  # m, the body centroid's path
    penetration: float = 0.0  # m, deepest overlap of the simulated body with an obstacle
    model_time: float = 0.0
    wall_time: float = float("nan")
    latencies: list[float] = field(default_factory=list)  # ms, every plan and replan
    twin_status: str = ""  # the known twin's, for a failed row
    twin_reason: str = ""

    @property
    def succeeded(self) -> bool:
        return self.status == "succeeded"

    @property
    def false_unreachable(self) -> bool:
        return "unreachable" in self.reason and self.twin_status == "succeeded"

    @property
    def rescued(self) -> bool:
        """Failed, and the known twin succeeded."""
        return not self.succeeded and self.twin_status == "succeeded"


def motion_kind(action: str) -> str:
    """The kind of motion an executed action is, from its name (the planner's PDDL action)."""
    verb = action.strip("()").split(" ")[0] if action else ""
    if verb in ("", "hold"):
        return "hold"
    if verb == "visit":
        return "final approach"
    if verb == "reshape":
        return "reshape"
    found = _PRIMITIVE.search(action)
    if found is None:
        return verb  # another domain's action (the reactive one, a chain step)
    if verb == "spin" or (verb == "back-off" and found["sign"] is not None):
        return "recovery spin"
    if found["sign"] is not None:
        return "turn in place"
    if verb == "back-off":
        return "back-off"
    angle = int(found["angle"]) % 360
    angle = min(angle, 360 - angle)  # 0 tail first .. 180 head first, either side
    return {
        0: "tail first",
        45: "oblique tail first",
        90: "sideways",
        135: "oblique head first",
        180: "head first",
    }.get(angle, f"translation at {angle}°")


def touches(
    events: Sequence[dict[str, Any]], executed: Sequence[dict[str, Any]]
) -> list[tuple[int, str]]:
    """Each contact's body part and the kind of motion that was running when it happened: the
    action the event names, or else the executed entry whose ticks led up to its model time."""
    out = []
    for e in events:
        if e["kind"] != "collision":
            continue
        action = e.get("action")
        if action is None:
            running = [x for x in executed if x["from"] < e["t"] - 1e-9]
            action = running[-1]["action"] if running else ""
        out.append((int(e.get("part", -1)), motion_kind(str(action))))
    return out


def travelled(trajectory: Sequence[Sequence[float]]) -> float:
    """Length of the body centroid's path over rows ``[t, x, y, ψ, φ1, φ2, φ3]``."""
    rows = np.asarray(trajectory, dtype=float)
    if len(rows) < 2:
        return 0.0
    c = centroid(rows[:, 1:4], rows[:, 4:7])
    return float(np.sum(np.linalg.norm(np.diff(c, axis=0), axis=1)))


def penetration(world: World, trajectory: Sequence[Sequence[float]]) -> float:
    """Deepest overlap (m) of the body with an obstacle or the arena wall over the rows, from
    the simulated world: the simulator stops the body before a contact, so this should be 0."""
    deepest = 0.0
    for row in trajectory:
        fp = footprint(np.asarray(row[1:4], dtype=float), np.asarray(row[4:7], dtype=float))
        if world.free_within(fp, 0.0):
            continue
        deepest = max(deepest, _depth(world, fp.starts, fp.ends, fp.radii))
    return deepest


def _depth(world: World, starts: Array, ends: Array, radii: Array) -> float:
    """How deep capsules overlap: radius less the signed distance of their axes (sampled every
    centimetre; negative inside a polygon)."""
    ends_all = np.concatenate([starts, ends])
    walls = float(np.max(np.concatenate([radii, radii]) - world.bounds.wall_clearance(ends_all)))
    deepest = max(0.0, walls)
    s = np.linspace(0.0, 1.0, 24)
    axis = starts[:, None, :] + s[None, :, None] * (ends - starts)[:, None, :]  # [5, 24, 2]
    for ob in world.obstacles:
        if isinstance(ob, Circle):
            d = point_segment_distance(ob.centre, starts, ends) - ob.radius
            deepest = max(deepest, float(np.max(radii - d)))
        elif isinstance(ob, Polygon):
            flat = axis.reshape(-1, 2)
            ea, eb = ob.edges
            dist = point_segment_distance(flat[:, None, :], ea, eb).min(axis=-1)
            signed = np.where(ob.contains(flat), -dist, dist).reshape(axis.shape[:2])
            deepest = max(deepest, float(np.max(radii - signed.min(axis=1))))
    return deepest


def _mission(job: Job) -> tuple[dict[str, Any], str]:
    if job.family is not None:
        world = generate(job.family, job.seed, job.known)
        return world.mission, world.verdict.label
    assert job.path is not None
    return json.loads(Path(job.path).read_text()), ""


def score_job(job: Job) -> Score:
    """Run one job (and its known twin when it fails) in this process; never raises."""
    noise = "own" if job.noise is None else f"{job.noise:g}"
    name = f"{job.family}-{job.seed:04d}" if job.family else Path(job.path or "?").stem
    score = Score(job.set, name, noise)
    try:
        mission, score.verdict = _mission(job)
        spec = with_noise(MissionSpec.model_validate(mission), job.noise)
        run = run_spec(job.set, spec, 1, job.cap)
        row, result, runner = run.row, run.result, run.runner
        score.name, score.expected, score.status = spec.name, row.expected, row.status
        score.reason, score.ok = row.reason, row.ok
        score.contacts, score.known_contacts = row.contacts, row.known_contacts
        score.touches = touches(result.events, result.executed)
        score.model_time, score.wall_time = row.model_time, row.wall_time
        score.latencies = [round(r.latency_ms, 3) for r in runner.ctx.replans]
        # Simulator truth, for the bench only: where the simulated body really went.
        sim = runner.robot.sim  # type: ignore[attr-defined]
        score.travelled = travelled(sim.trajectory)
        score.penetration = penetration(sim.world, sim.trajectory)
        if not score.succeeded:
            twin = with_noise(MissionSpec.model_validate(known_twin(mission)), job.noise)
            other = run_spec(job.set, twin, 1, job.cap).row
            score.twin_status, score.twin_reason = other.status, other.reason
    except BaseException as exc:  # the bench reports a crash, it does not die of it
        score.status = f"error: {type(exc).__name__}: {exc}".splitlines()[0][:200]
        traceback.print_exc(limit=-3, file=sys.stderr)
    return score


def _failed(job: Job, status: str, reason: str) -> Score:
    name = f"{job.family}-{job.seed:04d}" if job.family else Path(job.path or "?").stem
    noise = "own" if job.noise is None else f"{job.noise:g}"
    return Score(job.set, name, noise, status=status, reason=reason)


def line(s: Score) -> str:
    twin = f"  known twin: {s.twin_status}" if s.twin_status else ""
    status = s.status if s.succeeded else f"{s.status}: {s.reason[:60]}"
    return (
        f"{s.set:<9}{s.name[:34]:<35}{s.noise:>5} {s.verdict[:10]:<11}"
        f"{'ok' if s.ok else 'NO':<3}{s.contacts:>4} contacts {s.travelled:>5.1f} m "
        f"{s.model_time:>7.0f} s {s.wall_time:>6.1f} s  {status}{twin}"
    )


def _p95(values: Sequence[float]) -> float:
    if not values:
        return float("nan")
    return float(np.percentile(np.asarray(values), 95))


def figures(rows: Sequence[Score]) -> dict[str, Any]:
    """One set's figures at one noise level; borderline worlds are left out (listed apart)."""
    counted = [r for r in rows if r.verdict != "borderline"]
    should = [r for r in counted if r.expected == "succeeded"]
    succeeded = [r for r in should if r.succeeded]
    metres = sum(r.travelled for r in counted)
    parts = Counter(p for r in counted for p, _ in r.touches)
    kinds = Counter(k for r in counted for _, k in r.touches)
    return {
        "runs": len(counted),
        "should_succeed": len(should),
        "borderline": len(rows) - len(counted),
        "succeeded": len(succeeded),
        "clean": sum(1 for r in succeeded if r.contacts == 0),
        "touched": sum(1 for r in counted if r.contacts > 0),
        "contacts": sum(r.contacts for r in counted),
        "contacts_per_10m": 10 * sum(r.contacts for r in counted) / metres if metres else 0.0,
        "false_unreachable": sum(r.false_unreachable for r in counted),
        "rescued": sum(r.rescued for r in counted),
        "as_expected": sum(r.ok for r in counted),
        "penetration": max((r.penetration for r in counted), default=0.0),
        "model_median": statistics.median([r.model_time for r in succeeded])
        if succeeded
        else float("nan"),
        "plan_p95_ms": _p95([v for r in counted for v in r.latencies]),
        "errors": sum(r.status.startswith(("error", "timeout")) for r in counted),
        "parts": {PARTS[p] if 0 <= p < len(PARTS) else str(p): n for p, n in sorted(parts.items())},
        "kinds": dict(kinds.most_common()),
    }


def _groups(rows: Sequence[Score]) -> dict[tuple[str, str], list[Score]]:
    groups: dict[tuple[str, str], list[Score]] = {}
    for r in rows:
        groups.setdefault((r.set, r.noise), []).append(r)
    return groups


def report(rows: Sequence[Score]) -> list[str]:
    """The tables: figures per set and noise level, contacts by part and by motion kind, then
    the runs worth a look (reshape, borderline and infeasible worlds, false unreachable,
    rescues, disagreements with the flood fill)."""
    groups = _groups(rows)
    out = [
        "",
        f"{'set':<10}{'noise':>6}{'runs':>6}{'succeeded':>14}{'no contact':>14}{'touched':>9}"
        f"{'c/10m':>7}{'false unr':>10}{'rescued':>8}{'expected':>9}{'penetr':>8}"
        f"{'model s':>9}{'plan p95':>10}",
    ]
    for (name, noise), group in groups.items():
        f = figures(group)
        n = f["runs"]
        succ = f"{f['succeeded']}/{f['should_succeed']}"
        clean = f"{f['clean']}/{f['should_succeed']}"
        extra = f"  ({f['borderline']} borderline apart)" if f["borderline"] else ""
        extra += f"  ({f['errors']} errors or timeouts)" if f["errors"] else ""
        out.append(
            f"{name:<10}{noise:>6}{n:>6}{succ:>14}{clean:>14}{f['touched']:>9}"
            f"{f['contacts_per_10m']:>7.2f}{f['false_unreachable']:>10}{f['rescued']:>8}"
            f"{f['as_expected']:>9}{f['penetration']:>8.3f}{f['model_median']:>9.0f}"
            f"{f['plan_p95_ms']:>8.1f}ms{extra}"
        )
    out += ["", "contacts by part:", f"{'set':<10}{'noise':>6}" + "".join(f"{p:>8}" for p in PARTS)]
    for (name, noise), group in groups.items():
        parts = figures(group)["parts"]
        out.append(f"{name:<10}{noise:>6}" + "".join(f"{parts.get(p, 0):>8}" for p in PARTS))
    seen = [k for k in KINDS if any(k in figures(g)["kinds"] for g in groups.values())]
    seen += sorted({k for g in groups.values() for k in figures(g)["kinds"]} - set(seen))
    out += [
        "",
        "contacts by motion kind:",
        f"{'set':<10}{'noise':>6}" + "".join(f"{k[:12]:>13}" for k in seen),
    ]
    for (name, noise), group in groups.items():
        kinds = figures(group)["kinds"]
        out.append(f"{name:<10}{noise:>6}" + "".join(f"{kinds.get(k, 0):>13}" for k in seen))
    notes = []
    for r in rows:
        where = f"{r.set}/{r.name} @{r.noise}"
        if r.verdict in ("reshape", "borderline", "infeasible"):
            notes.append(f"  {r.verdict}: {where}: {r.status} {r.reason[:80]}")
        if r.false_unreachable:
            notes.append(f"  false unreachable: {where}: {r.reason[:80]}")
        elif r.rescued:
            notes.append(f"  rescued by the known twin: {where}: {r.status}: {r.reason[:80]}")
        if r.verdict in ("feasible", "reshape") and r.twin_status not in ("", "succeeded"):
            notes.append(
                f"  flood fill says {r.verdict}, known twin {r.twin_status}: {where}: "
                f"{r.twin_reason[:80]}"
            )
        if r.verdict == "infeasible" and r.succeeded:
            notes.append(f"  flood fill says infeasible, but it succeeded: {where}")
        if r.penetration > 0:
            notes.append(f"  penetration {r.penetration:.4f} m: {where}")
    if notes:
        out += ["", "runs apart:", *notes]
    return out


def jobs_for(args: argparse.Namespace) -> list[Job]:
    families = list(FAMILIES) if "all" in (args.family or []) else list(args.family or [])
    seeds = parse_seeds(args.seeds) if args.seeds else []
    folders: list[tuple[str, Path]] = []
    if args.examples:
        folders += [
            (n, ROOT / "examples" if n == "examples" else ROOT / "examples" / n)
            for n in EXAMPLE_SETS
        ]
    folders += [(Path(d).resolve().name, Path(d)) for d in args.set or []]
    jobs = []
    for noise in args.noise:
        for family in families:
            jobs += [
                Job(family, noise, args.cap, family=family, seed=s, known=args.known) for s in seeds
            ]
        for name, folder in folders:
            jobs += [Job(name, noise, args.cap, path=str(p)) for p in sorted(folder.glob("*.json"))]
    return jobs


def _noise(text: str) -> float | None:
    if text == "own":
        return None
    value = float(text)
    if not 0 <= value <= 0.5:
        raise argparse.ArgumentTypeError("a noise level is 'own' or a σ in [0, 0.5] m")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--family",
        action="append",
        choices=[*FAMILIES, "all"],
        help="a family of generated worlds (repeatable; all: every family)",
    )
    parser.add_argument(
        "--seeds", help="the worlds' seeds: 1000-1199 (report), 0-99 (tuning), 1,5,7-9"
    )
    parser.add_argument(
        "--known", action="store_true", help="generated worlds with every obstacle known"
    )
    parser.add_argument("--examples", action="store_true", help="the 112 example missions too")
    parser.add_argument(
        "--set", action="append", metavar="DIR", help="a folder of missions (repeatable)"
    )
    parser.add_argument(
        "--noise",
        nargs="+",
        type=_noise,
        default=[None],
        metavar="SIGMA",
        help="noise levels: own (the missions' own), or σ in m (default: own)",
    )
    parser.add_argument("--workers", type=int, default=1, help="processes in the pool")
    parser.add_argument("--cap", type=float, default=300.0, help="wall seconds per mission run")
    parser.add_argument("--json", type=Path, help="write every row and figure here")
    args = parser.parse_args(argv)
    if args.family and not args.seeds:
        parser.error("--family needs --seeds")
    if args.workers < 1 or not args.cap > 0:
        parser.error("--workers must be >= 1 and --cap > 0")
    jobs = jobs_for(args)
    if not jobs:
        parser.error("nothing to run: give --family and --seeds, --examples or --set")
    t0 = time.perf_counter()
    rows = run_pool(
        jobs,
        score_job,
        args.workers,
        lambda j: 2 * j.cap + GRACE,
        _failed,
        lambda s: print(line(s), flush=True),
    )
    text = report(rows)
    print("\n".join(text))
    print(f"\n{len(rows)} runs in {time.perf_counter() - t0:.0f} s wall")
    if args.json:
        groups = _groups(rows)
        payload = {
            "commit": _commit(),
            "argv": sys.argv[1:] if argv is None else argv,
            "figures": [{"set": s, "noise": n, **figures(g)} for (s, n), g in groups.items()],
            "rows": [asdict(r) for r in rows],
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(_finite(payload), indent=1) + "\n")
    return 0


def _finite(value: Any) -> Any:
    """NaN and infinities as null: JSON has neither."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        )
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


if __name__ == "__main__":
    sys.exit(main())
