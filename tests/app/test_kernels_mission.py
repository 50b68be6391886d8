"""A mission runs the same with the compiled kernels as with the numpy paths (every compiled
path off, as ``SCREWSNAKE_KERNELS=numpy`` turns them off for a process): same trajectory, same
contacts, same events (what a user sees of a mission)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from domain import kernels
from primitives.library import load_bundled
from sim import collision_kernel

EXAMPLES = Path(__file__).parents[2] / "examples"

pytestmark = pytest.mark.skipif(
    not (kernels.AVAILABLE and collision_kernel.AVAILABLE), reason="kernels are off"
)


def outcome(name: str) -> dict[str, Any]:
    """What a user sees of a mission, as JSON (replans are left out: they carry latencies)."""
    result = MissionRunner(load_mission(EXAMPLES / name), load_bundled()).run()
    events = [
        {k: v for k, v in e.items() if k != "latency_ms"}
        for e in result.events
        if e["kind"] != "replan"
    ]
    data = {
        "status": result.status,
        "reason": result.reason,
        "trajectory": result.trajectory,
        "collisions": result.collisions,
        "events": events,
        "executed": result.executed,
    }
    out: dict[str, Any] = json.loads(json.dumps(data, default=str))
    return out


# A hidden post found by touch (a contact, its evidence, a back-off, replans) and a noisy
# clutter (log-odds rising and decaying): every kernel runs, most of their branches too.
@pytest.mark.parametrize(
    "name", ["hard/tail-first-hidden-post.json", "hard/noisy-sensors-clutter.json"]
)
def test_mission_with_kernels_equals_numpy(name: str) -> None:
    code = f"import json; from tests.app.test_kernels_mission import outcome; print(json.dumps(outcome({name!r})))"
    numpy_run = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "SCREWSNAKE_KERNELS": "numpy"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert numpy_run.returncode == 0, numpy_run.stderr
    reference = json.loads(numpy_run.stdout)
    compiled = outcome(name)
    assert compiled["status"] == "succeeded"
    assert compiled == reference
