"""Fast Downward on exported PDDL, for comparison: its driver run directly (translate and search,
their own times read from its log) and the same planner through unified-planning's
``OneshotPlanner`` (the whole call), each in its own process group under a time limit.

Both come from the ``up-fast-downward`` package (a test extra); without it every run says
``missing``.
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

# https://www.fast-downward.org/ExitCodes
UNSOLVABLE_CODES = (10, 11, 12)
TIMEOUT_CODES = (21, 23)

# Run in a child so that a call stuck in unified-planning's problem writer can be stopped.
UP_CHILD = """
import json, sys, time
t0 = time.perf_counter()
from unified_planning.io import PDDLReader
from unified_planning.shortcuts import OneshotPlanner, get_environment
get_environment().credits_stream = None
imported = time.perf_counter()
problem = PDDLReader().parse_problem(sys.argv[1], sys.argv[2])
parsed = time.perf_counter()
with OneshotPlanner(name="fast-downward") as planner:  # lama-first
    result = planner.solve(problem)
done = time.perf_counter()
print(json.dumps({
    "status": result.status.name,
    "parse": parsed - imported,
    "solve": done - parsed,
    "length": len(result.plan.actions) if result.plan is not None else None,
}))
"""


@dataclass
class FdRun:
    """One Fast Downward run: how it ended and what it took (seconds; None where unknown)."""

    status: str  # solved | unsolvable | timeout | error | missing
    wall: float | None = None  # the whole process, as seen from here
    translate: float | None = None  # the translator's own wall-clock figure
    search: float | None = None  # the search component's "Search time"
    search_total: float | None = None  # the search component's "Total time" (reading, landmarks)
    length: int | None = None
    read: float | None = None  # unified-planning's reading of the PDDL (its call only)
    detail: str = ""


def driver() -> Path | None:
    """The ``fast-downward.py`` driver bundled with ``up_fast_downward``, if installed."""
    spec = importlib.util.find_spec("up_fast_downward")
    if spec is None or spec.origin is None:
        return None
    path = Path(spec.origin).parent / "downward" / "fast-downward.py"
    return path if path.exists() else None


def _run(cmd: list[str], cwd: str, limit: float) -> tuple[int | None, str, float]:
    """Run ``cmd`` in its own process group; past ``limit`` seconds the group is killed."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        cmd,
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        out, _ = proc.communicate(timeout=limit)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the driver's translate/search children too
        out, _ = proc.communicate()
        return None, out, time.perf_counter() - t0
    return proc.returncode, out, time.perf_counter() - t0


def _seconds(pattern: str, text: str) -> float | None:
    found = re.findall(pattern, text)
    return float(found[-1]) if found else None


def run_driver(domain: str, problem: str, limit: float, alias: str = "lama-first") -> FdRun:
    """Fast Downward's driver on the PDDL text: translate, then search with ``alias``."""
    path = driver()
    if path is None:
        return FdRun("missing", detail="up-fast-downward is not installed")
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "domain.pddl").write_text(domain)
        Path(tmp, "problem.pddl").write_text(problem)
        cmd = [sys.executable, str(path), "--alias", alias]
        cmd += ["--overall-time-limit", f"{math.ceil(limit)}s", "--plan-file", "plan"]
        cmd += ["domain.pddl", "problem.pddl"]
        code, log, wall = _run(cmd, tmp, limit + 5.0)
    run = FdRun(
        "error",
        wall,
        _seconds(r"Done! \[[\d.]+s CPU, ([\d.]+)s wall-clock\]", log),
        _seconds(r"\] Search time: ([\d.]+)s", log),
        _seconds(r"\] Total time: ([\d.]+)s", log),
    )
    length = re.findall(r"Plan length: (\d+) step", log)
    run.length = int(length[-1]) if length else None
    if code == 0 and run.length is not None:
        run.status = "solved"
    elif code in UNSOLVABLE_CODES:
        run.status = "unsolvable"
    elif code is None or code in TIMEOUT_CODES:
        run.status = "timeout"
    else:
        run.detail = f"exit code {code}: {log.strip().splitlines()[-1:]}"
    return run


def run_unified_planning(domain: str, problem: str, limit: float) -> FdRun:
    """The whole unified-planning call: read the PDDL, then ``OneshotPlanner("fast-downward")``
    (which writes the problem out again and runs the driver); ``wall`` is both together."""
    if driver() is None or importlib.util.find_spec("unified_planning") is None:
        return FdRun("missing", detail="unified-planning / up-fast-downward are not installed")
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "domain.pddl").write_text(domain)
        Path(tmp, "problem.pddl").write_text(problem)
        cmd = [sys.executable, "-c", UP_CHILD, "domain.pddl", "problem.pddl"]
        code, out, wall = _run(cmd, tmp, limit)
    if code is None:
        return FdRun("timeout", wall)
    try:
        result = json.loads(out.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return FdRun("error", wall, detail=out.strip()[-300:])
    status = {"SOLVED_SATISFICING": "solved", "SOLVED_OPTIMALLY": "solved"}.get(
        result["status"], result["status"].lower()
    )
    return FdRun(
        status,
        float(result["parse"]) + float(result["solve"]),
        length=result["length"],
        read=float(result["parse"]),
    )
