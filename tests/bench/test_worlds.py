"""The generated worlds the scoreboard runs: the same world for the same (family, seed), valid
missions, and a flood fill that tells an open world from a sealed one."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.missions.spec import MissionSpec, load_mission
from bench.feasibility import check, verdict
from bench.scoreboard import motion_kind
from bench.worlds import FAMILIES, REPORT_SEEDS, TUNING_SEEDS, known_twin, layout, main

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
        ("(visit s9 g0)", "final approach"),
        ("hold", "hold"),
    ],
)
def test_contacts_are_told_by_the_motion_running(action: str, kind: str) -> None:
    assert motion_kind(action) == kind
