"""A worker's warm-up: a real short mission (sensing, a replan, a deformation), and never a
reason for a worker to stop."""

import gc
import logging
import weakref
from collections.abc import Iterator

import pytest

from app.executor import warm
from app.executor.robot import head_sensors
from app.executor.runner import MissionRunner, navigation_settings
from app.missions.spec import MissionSpec
from domain.navigation import HeadView, NavigationStrategy, Planner, held_joints, warm_tables
from domain.navigation.lattice import motions
from domain.navigation.lattice import states as lattice_states
from primitives.library import load_bundled
from primitives.shapes import SHAPES, learned_name
from sim.world import Bounds


@pytest.fixture(autouse=True)
def unfreeze() -> Iterator[None]:
    """The warm-up freezes what a worker holds; the test process goes on collecting."""
    yield
    gc.unfreeze()


def test_the_warm_up_mission_senses_replans_and_arrives() -> None:
    result = MissionRunner(MissionSpec.model_validate(warm.WARM_UP), load_bundled()).run()
    assert result.status == "succeeded", result.reason
    assert any(r.trigger != "initial" for r in result.replans)  # the hidden post was sensed
    assert any(e["kind"] == "deform" for e in result.events)


def test_a_failing_warm_up_is_logged_not_raised(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setitem(warm.WARM_UP, "goals", [{"x": 99.0, "y": 0.0}])  # outside the arena
    with caplog.at_level(logging.ERROR, logger=warm.__name__):
        seconds = warm.warm_up(load_bundled())
    assert seconds >= 0.0
    assert "warm-up mission failed" in caplog.text


def test_after_the_warm_up_every_shape_s_table_is_at_hand(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A reshape in a worker's first mission reads another shape's table: made in the warm-up,
    for the view and settings a mission's strategy asks with."""
    library = load_bundled()
    monkeypatch.setattr(motions, "_TABLES", {})
    warm.warm_up(library)
    made = {(key[0], key[2]) for key in motions._TABLES}  # (shape, joints)
    spec = MissionSpec.model_validate(warm.WARM_UP)
    settings = navigation_settings(spec)
    view = HeadView.of(head_sensors(spec))
    for shape in library.lattice_shapes():
        joints = held_joints(SHAPES[shape].joints)
        assert (shape, joints) in made
        before = len(motions._TABLES)
        planner = Planner(Bounds(-1.0, 1.0, -1.0, 1.0), settings)
        assert NavigationStrategy(library, planner, view).table_for(shape, joints) is not None
        assert len(motions._TABLES) == before  # the strategy finds it: no new table
    assert warm_tables(library, settings, view) == len(library.lattice_shapes())


def test_a_library_with_a_learned_shape_keeps_every_other_shape_s_table(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A worker runs a mission after one that learned a shape with a new library object (the
    bundled entries plus the learned ones): the shapes it already had keep their tables (each
    costs a mission hundreds of milliseconds to make again), the new shape gets its own."""
    library = load_bundled()
    monkeypatch.setattr(motions, "_TABLES", {})
    spec = MissionSpec.model_validate(warm.WARM_UP)
    settings, view = navigation_settings(spec), HeadView.of(head_sensors(spec))
    warm_tables(library, settings, view)
    shapes = library.lattice_shapes()
    learned_shape = shapes[0]
    # a "learned" shape: the first shape's lattice entries under a learned shape's name
    name = learned_name((0.9, -0.3, 0.6))
    learned = [
        e.model_copy(update={"id": f"{e.id}-learned", "shape": name})
        for e in library.lattice(learned_shape)
    ]
    bigger = library.with_entries(learned)
    assert bigger is not library and bigger.lattice_shapes() == sorted([*shapes, name])
    made = len(motions._TABLES)
    for shape in shapes:
        joints = held_joints(SHAPES[shape].joints)
        old = motions.motion_table(library, shape, joints, settings, view)
        assert motions.motion_table(bigger, shape, joints, settings, view) is old
    assert len(motions._TABLES) == made
    joints = held_joints(SHAPES[learned_shape].joints)
    new = motions.motion_table(bigger, name, joints, settings, view)
    assert new is not None and new.shape == name and len(motions._TABLES) == made + 1


def test_after_the_warm_up_what_the_process_holds_is_out_of_the_collector_s_way() -> None:
    """A full collection inside a mission would rescan the library, kernels and tables: the
    warm-up freezes them (``gc.freeze``), so a mission's full passes scan its own objects."""
    warm.warm_up(load_bundled())
    assert gc.get_freeze_count() > 10_000
    assert len(gc.get_objects()) < gc.get_freeze_count()


def test_what_a_mission_froze_is_collected_after_it() -> None:
    """A grounding for pyperplan's heuristics freezes what is alive when it ends; after the
    mission, its garbage goes and the worker's own objects are frozen again."""

    class Node:
        me: object

    warm.warm_up(load_bundled())
    node = Node()
    node.me = node  # a cycle: only the collector frees it
    ref = weakref.ref(node)
    with lattice_states.no_cycle_collection(freeze_after=True):  # as a big grounding
        grounding = [[i] for i in range(lattice_states.FREEZE_AFTER + 1_000)]
    del node, grounding
    gc.collect()
    frozen_alive = ref() is not None  # frozen: out of the collector's reach
    warm.unfreeze_mission()
    collected = ref() is None
    assert frozen_alive and collected
    assert gc.get_freeze_count() > 10_000
