"""A mission runs the same with the compiled kernels as with the numpy paths: same trajectory,
same contacts, same events (what a user sees of a mission)."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from domain import occupancy_kernel
from primitives.library import load_bundled
from sim import collision_kernel

EXAMPLES = Path(__file__).parents[2] / "examples"

pytestmark = pytest.mark.skipif(
    not (occupancy_kernel.AVAILABLE and collision_kernel.AVAILABLE), reason="kernels are off"
)


def run(name: str) -> tuple[object, ...]:
    result = MissionRunner(load_mission(EXAMPLES / name), load_bundled()).run()
    events = [e for e in result.events if e["kind"] != "replan"]  # replans carry latencies
    return result.status, result.trajectory, result.collisions, events, result.executed


# A hidden post found by touch (contacts, suspected surfaces, replans) and a noisy clutter
# (log-odds rising and decaying): every kernel runs, most of their branches too.
@pytest.mark.parametrize(
    "name", ["hard/tail-first-hidden-post.json", "hard/noisy-sensors-clutter.json"]
)
def test_mission_with_kernels_equals_numpy(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    compiled = run(name)
    monkeypatch.setattr(occupancy_kernel, "AVAILABLE", False)
    monkeypatch.setattr(collision_kernel, "AVAILABLE", False)
    reference = run(name)
    assert compiled[0] == "succeeded"
    assert compiled == reference
