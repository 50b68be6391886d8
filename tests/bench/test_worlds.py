"""The generated worlds the scoreboard runs: the same world for the same (family, seed), valid
missions, and a flood fill that tells an open world from a sealed one."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import bench.worlds
from app.missions.spec import MissionSpec, load_mission
from bench.feasibility import MARGIN, Verdict, check, verdict
from bench.scoreboard import motion_kind, touches
from bench.worlds import FAMILIES, REPORT_SEEDS, TUNING_SEEDS, generate, known_twin, layout, main
from primitives.shapes import SHAPES
from sim.obstacles import obstacle_from_dict
from sim.world import footprint

OPEN = {
    "name": "open",
    "start": {"x": -1.5, "y": 0.0, "psi": 0.0},  # facing away from the goal
    "goals": [{"x": 1.8, "y": 0.0}],
    "bounds": {"xmin": -2.5, "xmax": 2.5, "ymin": -1.5, "ymax": 1.5},
    "obstacles": [{"type": "circle", "x": 0.8, "y": 0.6, "radius": 0.3}],
}


def fence(gap: float) -> dict[str, object]:
    """``OPEN`` with a wall across the arena at x = 0.5 and a gap of ``gap`` in it (0: sealed)."""
    half = (3.0 - gap) / 2
    walls = [
        {"type": "rectangle", "x": 0.5, "y": s * (1.5 - half / 2), "width": 0.1, "height": half}
        for s in (1, -1)
    ]
    return {**OPEN, "obstacles": walls}


@pytest.mark.parametrize("family", FAMILIES)
def test_a_family_and_seed_always_give_the_same_valid_mission(family: str) -> None:
    first = layout(family, 3)
    assert layout(family, 3) == first
    assert layout(family, 4) != first
    spec = MissionSpec.model_validate(first)
    assert spec.name == f"{family}-0003" and spec.shape == "straight" and len(spec.goals) == 1
    assert spec.obstacles and not any(o.known for o in spec.obstacles)
    assert all(o.known for o in MissionSpec.model_validate(layout(family, 3, known=True)).obstacles)
    assert all(o["known"] for o in known_twin(first)["obstacles"])


def test_posts_walls_take_the_field_past_the_old_cap_of_200_obstacles() -> None:
    assert len(MissionSpec.model_validate(layout("posts", 0)).obstacles) > 200


def test_the_seeds_are_split() -> None:
    assert set(TUNING_SEEDS) == set(range(100))
    assert set(REPORT_SEEDS) == set(range(1000, 1200))


def test_the_flood_fill_tells_open_from_sealed() -> None:
    assert check(OPEN).reachable
    sealed = fence(0.0)
    assert not check(sealed).reachable
    assert verdict(sealed).label == "infeasible"


def test_a_gap_the_body_fits_only_without_a_margin_is_borderline() -> None:
    assert verdict(fence(0.30)).label == "feasible"
    assert verdict(fence(0.16)).label == "borderline"  # 0.15 m body, 0.01 m margin each side
    assert verdict(fence(0.12)).label == "infeasible"


def tunnel(plugged: bool = False) -> dict[str, Any]:
    """Two rooms joined only by a tunnel bent round a disc (0.62-0.9 m from its centre, 120°):
    the straight body (0.96 m) cannot turn through it; the library's arc (joints on a circle of
    0.76 m) rolls along it. ``plugged`` closes the tunnel in its middle."""

    def ring(r0: float, r1: float, a0: float, a1: float, n: int = 24) -> dict[str, object]:
        angles = [a0 + (a1 - a0) * i / n for i in range(n + 1)]
        outer = [[r1 * math.cos(a), r1 * math.sin(a)] for a in angles]
        inner = [[r0 * math.cos(a), r0 * math.sin(a)] for a in reversed(angles)]
        return {"type": "polygon", "points": outer + inner}

    obstacles = [
        {"type": "circle", "x": 0.0, "y": 0.0, "radius": 0.62},
        {"type": "rectangle", "x": 0.0, "y": -1.1, "width": 0.1, "height": 1.0},
        ring(0.9, 1.05, math.radians(30), math.radians(150)),
        {"type": "rectangle", "x": 0.0, "y": 1.3, "width": 0.1, "height": 0.7},
    ]
    if plugged:
        obstacles.append({"type": "rectangle", "x": 0.0, "y": 0.76, "width": 0.1, "height": 0.4})
    return {
        "name": "tunnel",
        "start": {"x": -1.9, "y": -1.0, "psi": 0.0},
        "goals": [{"x": 1.7, "y": -1.0}],
        "bounds": {"xmin": -2.2, "xmax": 2.2, "ymin": -1.6, "ymax": 1.6},
        "obstacles": obstacles,
    }


def test_the_arc_rolls_through_the_tunnel_by_the_simulators_geometry() -> None:
    """The test world itself: the arc's joints on its circle keep the margin all the way."""
    obstacles = [obstacle_from_dict(dict(o)) for o in tunnel()["obstacles"]]
    radius = 0.226 / (2 * math.sin(0.15))  # the arc's joints: 0.226 m apart, turning 0.3 rad
    arc = np.asarray(SHAPES["arc"].joints)
    for theta in np.radians(np.arange(-15.0, 140.0, 1.0)):
        pose = np.array(
            [radius * math.cos(theta), radius * math.sin(theta), theta + 0.15 + math.pi / 2]
        )
        fp = footprint(pose, arc)
        gap = min(
            float(np.min(o.segment_clearance(fp.starts, fp.ends) - fp.radii)) for o in obstacles
        )
        assert gap > MARGIN


def test_a_bend_only_an_arc_passes_is_feasible_by_reshaping() -> None:
    world = tunnel()
    assert not check(world).reachable
    assert not check(world, 0.0, sure=False).reachable  # not even loosely for the straight body
    reshaping = check(world, reshape=True)
    assert reshaping.reachable and reshaping.reshape and reshaping.start_free
    found = verdict(world)
    assert found.feasible and found.reshape and found.label == "reshape"
    assert verdict(OPEN).label == "feasible"  # the straight body is asked first


def test_reshaping_does_not_open_a_sealed_way() -> None:
    assert not check(tunnel(plugged=True), 0.0, sure=False, reshape=True).reachable
    assert verdict(tunnel(plugged=True)).label == "infeasible"
    assert not check(fence(0.0), 0.0, sure=False, reshape=True).reachable


def test_a_reshape_world_expects_success_and_says_so_in_its_name(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(bench.worlds, "verdict", lambda mission: Verdict(True, False, True, 0.0))
    world = generate("slots", 3)
    assert world.name == "slots-0003-reshape" and world.verdict.label == "reshape"
    assert world.mission["expect"] == {"status": "succeeded"}


def test_the_cli_writes_a_mission_with_its_expectation(tmp_path: Path) -> None:
    out = tmp_path / "posts-1000.json"
    assert main(["--family", "posts", "--seed", "1000", "--out", str(out)]) == 0
    spec = load_mission(out)
    assert spec.name.startswith("posts-1000") and spec.expect is not None
    assert json.loads(out.read_text())["seed"] == 1000


@pytest.mark.parametrize(
    ("action", "kind"),
    [
        ("(move s1 s2 lat-straight-t025-a180)", "head first"),
        ("(move s1 s2 lat-straight-t005-a000)", "tail first"),
        ("(move s1 s2 lat-zigzag-t025-a270)", "sideways"),
        ("(move s1 s2 lat-semi-arc-t025-a315)", "oblique tail first"),
        ("(move s1 s2 lat-straight-rp22p5)", "turn in place"),
        ("(back-off lat-straight-t005-a090)", "back-off"),
        ("(back-off lat-straight-rm45p0)", "recovery spin"),
        ("(spin lat-straight-rp22p5)", "recovery spin"),
        ("(visit s9 g0)", "final approach"),
        ("hold", "hold"),
    ],
)
def test_contacts_are_told_by_the_motion_running(action: str, kind: str) -> None:
    assert motion_kind(action) == kind


def test_a_contact_is_told_by_the_action_it_names_else_by_the_executed_log() -> None:
    executed = [
        {"from": 0.0, "action": "(move s1 s2 lat-straight-t025-a180)"},
        {"from": 5.0, "action": "(move s2 s3 lat-straight-t025-a000)"},
    ]
    events = [
        {"kind": "collision", "t": 6.0, "part": 4, "action": "(back-off lat-straight-t005-a180)"},
        {"kind": "collision", "t": 6.0, "part": 3},
        {"kind": "replan", "t": 6.5},
        {"kind": "collision", "t": 2.0, "part": 1},
    ]
    assert touches(events, executed) == [(4, "back-off"), (3, "tail first"), (1, "head first")]
