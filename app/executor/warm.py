"""Warming a mission process up: one short mission run untimed before the real ones.

A process's first mission loads what every later one reuses: the compiled kernels (numba's
disk cache: sensing, the world model, the lattice search, the reachability test), the lattice
motion tables and their compiled forms. That costs a few hundred milliseconds once, which a
mission posted to a fresh worker would otherwise wait for. The service's pool workers and the
benches' worker processes run this first.
"""

from __future__ import annotations

import gc
import logging
import time

from app.executor.robot import head_sensors
from app.executor.runner import MissionRunner, navigation_settings
from app.missions.spec import MissionSpec
from domain.navigation import HeadView, warm_tables
from domain.navigation.lattice import states as lattice_states
from primitives.library import Library
from sim import raster

log = logging.getLogger(__name__)

# Through a hidden post (sensing, a replan, the plan guard) and a forced deformation (another
# shape's motion table) to a goal beside a wall; then every library shape's motion table.
WARM_UP = {
    "name": "warm-up",
    "goals": [{"x": -2.0, "y": 0.9}],
    "bounds": {"xmin": -3, "xmax": 3, "ymin": -3, "ymax": 3},
    "obstacles": [
        {"type": "circle", "x": -1.0, "y": 0.4, "radius": 0.3, "known": False},
        {"type": "rectangle", "x": -2.0, "y": 1.6, "width": 1.5, "height": 0.3, "known": True},
    ],
    "events": [{"t": 20, "type": "deform", "joints": [0.3, 0.3, 0.3]}],
}


def warm_up(library: Library) -> float:
    """Run the warm-up mission, then load every library shape's motion tables and the
    feasibility flood (``domain.navigation.warm_tables``), untimed; then move what the process
    holds to the collector's permanent generation (``gc.freeze``). Returns the seconds it took.
    Never raises: a process that cannot warm up still runs missions (cold)."""
    started = time.perf_counter()
    try:
        spec = MissionSpec.model_validate(WARM_UP)
        MissionRunner(spec, library).run()
        # every shape's tables, as missions' planners make them (reshaping reads them)
        warm_tables(library, navigation_settings(spec), HeadView.of(head_sensors(spec)))
        raster.warm()  # the maps' compiled collision kernel
    except Exception:  # a warm-up is an optimisation, never a reason to stop
        log.exception("warm-up mission failed; missions will run cold")
    # What the process holds now (modules, the library, compiled kernels, motion tables) lives
    # as long as it does: out of the cyclic collector's full passes, which would rescan its
    # ~150,000 objects for 70-220 ms now and then inside a mission.
    gc.collect()
    gc.freeze()
    return time.perf_counter() - started


_seen = [0]  # the pauses that froze what they made (``lattice_states.freezes``) dealt with


def unfreeze_mission() -> None:
    """After a mission: if a pyperplan-heuristic grounding froze what was alive when it ended
    (``domain.lattice_states.no_cycle_collection``), let the collector have it again, collect
    what of the mission is garbage now and freeze the rest, as the warm-up did. Between
    missions: nothing waits for it."""
    if lattice_states.freezes[0] != _seen[0]:
        _seen[0] = lattice_states.freezes[0]
        gc.unfreeze()
        gc.collect()
        gc.freeze()
