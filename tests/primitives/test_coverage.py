"""One definition of "a shape the library covers": a library shape within the joint
tolerance, or interpolable between library shapes (Figs. 8 and 13b), or none."""

import math

import pytest
from pydantic import ValidationError

from primitives.coverage import JOINT_TOLERANCE, covers
from primitives.library import Library, load_bundled

LIB = load_bundled()


@pytest.mark.parametrize(
    ("joints", "shape"),
    [((0, 0, 0), "straight"), ((0.5, -0.5, -0.1), "semi-zigzag"), ((0.42, -0.4, 0.36), "zigzag")],
)
def test_a_library_shape_within_the_tolerance(joints, shape) -> None:
    c = LIB.covers(joints)
    assert (c.kind, c.shape) == ("library", shape) and c.error <= JOINT_TOLERANCE


def test_a_blend_of_library_shapes_is_covered_by_interpolation() -> None:
    c = LIB.covers((0.25, -0.25, -0.05))  # Fig. 8: half straight, half semi-zigzag
    assert c.kind == "interpolated" and c.shape in c.sources
    weights = dict(zip(c.sources, c.weights, strict=True))
    assert weights == pytest.approx({"straight": 0.5, "semi-zigzag": 0.5}, abs=0.01)
    assert math.isclose(sum(c.weights), 1.0, abs_tol=1e-6)


@pytest.mark.parametrize(
    "joints", [(1.2, 1.2, 1.2), (0.5, 0.5, -0.5), (math.nan, 0, 0), (0.1, 0.2)]
)
def test_shapes_outside_the_library_are_not_covered(joints) -> None:
    c = covers(joints, LIB.shapes())
    assert c.kind == "none" and c.shape is None and not c.covered
    assert "not interpolable" in c.describe()


def test_coverage_follows_the_library_not_the_named_shapes() -> None:
    only_straight = Library([e for e in LIB if e.shape == "straight"])
    assert only_straight.covers((0.5, -0.5, -0.1)).kind == "none"
    assert only_straight.covers((0.05, 0.0, -0.05)).kind == "library"


def test_the_tolerance_is_a_setting() -> None:
    assert LIB.covers((0.6, -0.5, 0.5)).kind == "library"
    assert LIB.covers((0.6, -0.5, 0.5), tolerance=0.05).kind != "library"


def test_a_blended_start_shape_learns_on_the_lattice_and_blends_in_the_papers_moves() -> None:
    from app.executor.runner import MissionError, MissionRunner
    from app.missions.spec import MissionSpec

    base = {"goals": [{"x": -1, "y": 0}], "bounds": {"xmin": -3, "xmax": 3, "ymin": -3, "ymax": 3}}
    blend = {"shape": {"joints": [0.25, -0.25, -0.05]}}
    # On the lattice the nearest shape's motions would land elsewhere: the shape is learned.
    lattice = MissionRunner(MissionSpec.model_validate({**base, **blend}), LIB)
    assert lattice.ctx.shape == "body-p025-m025-m005" and lattice.ctx.learn is not None
    # The paper's moves blend paper primitives: the nearest library shape runs.
    reactive = {**base, **blend, "planner": {"domain": "reactive"}}
    ok = MissionRunner(MissionSpec.model_validate(reactive), LIB)
    assert ok.ctx.shape in ("straight", "semi-zigzag") and ok.ctx.learn is None
    # A shape no library shape covers is refused there when posted, naming the field ...
    with pytest.raises(ValidationError, match=r"shape\.joints"):
        MissionSpec.model_validate({**reactive, "shape": {"joints": [1.2, 1.2, 1.2]}})
    # ... as is one outside the joint limits anywhere.
    with pytest.raises(ValidationError, match=r"shape\.joints.*joint limits"):
        MissionSpec.model_validate({**base, "shape": {"joints": [1.55, 0.0, 0.0]}})
    # ... and by the runner for a library that lacks the shapes (a spec built without checks).
    spec = MissionSpec.model_validate(reactive)
    only_arc = Library([e for e in LIB if e.shape == "arc"])
    with pytest.raises(MissionError, match="not interpolable"):
        MissionRunner(spec, only_arc)
