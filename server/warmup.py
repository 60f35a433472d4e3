"""The one warm-up path: load the compiled kernels a process will use before its first race, so no tick (and no
first plan) pays for loading them.

The server process (:func:`warm_tick_path`: the world step and sensors, plus the trackers when controllers run
in its threads), every controller host (:func:`warm_drivers`) and every planner worker (:func:`warm_planner`)
start with it. Everything runs on the oval with two karts.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable

import numpy as np

from controllers.base import RaceContext
from controllers.registry import ControllerSpec
from server.drivers import KartDriver
from server.race_config import KartEntry
from sim_core.conditions import condition_set
from sim_core.observation import Observation, observe
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World

log = logging.getLogger(__name__)

PLANNER_ITERATIONS = 50  # a small search budget: enough to run every kernel once


def _oval(step: bool) -> tuple[World, RaceContext, Observation]:
    track = get_track("oval")
    params = SimParams()
    world = World(track, 1, 2, params, laps=1)
    if step:
        world.step()
    context = RaceContext(track, params.kart, 0, 2, world.lane_change_limit, 0)
    return world, context, observe(world, 0)[0]


def warm_drivers(specs: Iterable[ControllerSpec], *, step_world: bool = False) -> None:
    """Reset each controller of ``specs`` the way the server does and let it decide once (and, with
    ``step_world``, step a world first). A controller that fails is logged and skipped."""
    _world, context, observation = _oval(step_world)
    for spec in specs:
        try:
            driver = KartDriver(KartEntry(0, spec.name, spec.name), spec.factory())
            driver.reset(context)
            driver.compute(observation)
        except Exception:
            log.exception("warming up %s failed", spec.name)


def warm_tick_path(specs: Iterable[ControllerSpec]) -> None:
    """The server process: the world step and sensors, the drivers' imprecision of the ``varied`` conditions, and
    the trackers of ``specs`` (those that will run in its threads; none when controller hosts run them)."""
    imprecision = condition_set("varied").draw(0, 2).imprecision()
    if imprecision is not None:
        imprecision.perturb(np.zeros((2, 2)), np.ones(2, dtype=bool))
    warm_drivers(specs, step_world=True)


def warm_planner() -> float:
    """A planner worker: plan once on the oval with a small budget; returns the seconds it took."""
    from controllers.tactical.high_level import MCTSPlanner

    start = time.perf_counter()
    _world, context, observation = _oval(False)
    planner = MCTSPlanner(iterations=PLANNER_ITERATIONS)
    planner.reset(context)
    planner.plan(observation)
    return time.perf_counter() - start
