"""The second untuned set (examples/untuned2) is well-formed: every mission parses, declares
what it expects, starts clear, and an expected success is solvable for the body's width while an
expected `unreachable` really is cut off (the same free-space checks as examples/hard). Nothing
here runs a mission end to end: `python -m bench.missions --set examples/untuned2` does."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.missions.spec import DropoutEvent
from tests.app import test_hard_missions as hard

UNTUNED2 = sorted(Path(__file__).parents[2].joinpath("examples", "untuned2").glob("*.json"))


def test_the_set_covers_what_it_claims() -> None:
    specs = [hard.spec(p) for p in UNTUNED2]
    assert 12 <= len(specs) <= 16
    assert len({s.name for s in specs}) == len(specs)
    assert any(s.sensors.noise >= 0.04 for s in specs)
    assert any(
        isinstance(e, DropoutEvent) and "joints" in e.sensors for s in specs for e in s.events
    )
    assert any(e.type == "deform" for s in specs for e in s.events)
    assert any(s.order == "any" and len(s.goals) >= 7 for s in specs)
    assert any(s.bounds.xmax - s.bounds.xmin >= 30 for s in specs)
    unreachable = [s for s in specs if s.expect and s.expect.reason == "unreachable"]
    assert len(unreachable) >= 2


@pytest.mark.parametrize("path", UNTUNED2, ids=lambda p: p.stem)
def test_parses_and_declares_an_expectation(path: Path) -> None:
    hard.test_parses_and_declares_an_expectation(path)


@pytest.mark.parametrize("path", UNTUNED2, ids=lambda p: p.stem)
def test_start_footprint_is_clear(path: Path) -> None:
    hard.test_start_footprint_is_clear(path)


@pytest.mark.parametrize("path", UNTUNED2, ids=lambda p: p.stem)
def test_expected_outcome_matches_the_free_space(path: Path) -> None:
    hard.test_expected_outcome_matches_the_free_space(path)
