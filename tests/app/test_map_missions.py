"""Missions on maps, headless: a field of 2,000 posts as a known map reaches its goal with no
contact, and its simulated world and planner agree cell for cell on what is occupied."""

from __future__ import annotations

import base64

import numpy as np

from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from bench.maps import HALF, RES, field_image, post_field
from primitives.library import Library, bundled_library_path
from sim.raster import OCCUPIED
from tests.maps_fixtures import pgm


def field_mission(known: bool) -> MissionSpec:
    image = field_image(post_field(2000))
    the_map = {
        "image": base64.b64encode(pgm(image)).decode(),
        "resolution": RES,
        "origin": [-HALF, -HALF, 0.0],
        "known": known,
    }
    return MissionSpec.model_validate(
        {"goals": [{"x": -4.0, "y": -4.0, "tolerance": 0.15}], "maps": [the_map]}
    )


def test_a_field_of_two_thousand_posts_as_a_known_map_is_crossed() -> None:
    spec = field_mission(known=True)
    assert spec.bounds.xmin == -HALF and spec.bounds.xmax == HALF  # the map's extent
    runner = MissionRunner(spec, Library.load(bundled_library_path()))
    # the planner's static layer holds exactly the map's occupied cells (same grid here)
    ((raster, _),) = spec.world_maps()
    assert np.array_equal(runner.ctx.world.occupied(), raster.cells == OCCUPIED)
    result = runner.run()
    assert result.status == "succeeded", result.reason
    assert result.collisions == 0
