"""The one closed registry of controllers. A request names a controller; it never names a Python path.

The CLI, the server and tournaments all build drivers through :func:`make_controller`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from controllers.base import Action, Controller, RaceContext
from controllers.hierarchical import FixedLinePlanner, HierarchicalController, MCTSPlanner
from controllers.lane_follower import LaneFollower
from controllers.lq.tracker import LQNGParams, LQNGTracker, LQNGWeights
from sim_core.observation import Observation
from sim_core.params import SIM_HZ


class LaneFollowerController:
    """The pure-pursuit baseline as a registered driver: it follows the lane it started in."""

    name = "lane-follower"
    rate_hz = float(SIM_HZ)

    def __init__(self) -> None:
        self._follower: LaneFollower | None = None
        self._lateral = 0.0

    def reset(self, context: RaceContext) -> None:
        """Pick the start lane's offset to follow."""
        self._follower = LaneFollower(context.track, context.kart)
        self._lateral = float("nan")

    def act(self, observation: Observation) -> Action:
        """Pure pursuit on its lane with a curvature-limited speed."""
        assert self._follower is not None, "reset() first"
        me = observation.me
        if self._lateral != self._lateral:
            self._lateral = me.lateral
        steer, throttle = self._follower.act(
            np.array([me.x, me.y]),
            np.array(me.heading),
            np.array(me.speed),
            np.array(me.progress),
            np.array(me.wear),
            self._lateral,
        )
        return Action(float(steer), float(throttle))


@dataclass(frozen=True)
class ControllerSpec:
    """A registered controller: its name, what it is, its parameters, and how to build one."""

    name: str
    description: str
    factory: Callable[[], Controller]
    parameters: Mapping[str, str] = field(default_factory=dict)


def _mcts_lqng() -> Controller:
    # the game's speed bins are coarse: planned speeds are a ceiling 3 m/s above the bin, the line's profile binds
    return HierarchicalController("mcts-lqng", MCTSPlanner(), LQNGTracker(LQNGParams(speed_margin=3.0)))


def _fixed_lqng() -> Controller:
    fixed = LQNGParams(traffic_lane_tolerance=1.25, weights=LQNGWeights(heading=1.9, deny=0.1, avoid_scale=0.45))
    return HierarchicalController("fixed-lqng", FixedLinePlanner(), LQNGTracker(fixed))


_SPECS = (
    ControllerSpec(
        "mcts-lqng",
        "MCTS tactical planner (1 Hz, 2,000 iterations, horizon 8) tracked by the LQ Nash game tracker (50 Hz).",
        _mcts_lqng,
        {"planner_rate_hz": "1.0", "iterations": "2000", "horizon": "8", "lqng_horizon_steps": "4"},
    ),
    ControllerSpec(
        "fixed-lqng",
        "The offline optimised racing line tracked by the LQ Nash game tracker (50 Hz).",
        _fixed_lqng,
        {"line_margin_m": "1.0", "lqng_horizon_steps": "4"},
    ),
    ControllerSpec(
        "lane-follower",
        "Pure pursuit on its start lane with a curvature-limited speed profile (a simple baseline).",
        LaneFollowerController,
        {},
    ),
)

_BY_NAME: dict[str, ControllerSpec] = {spec.name: spec for spec in _SPECS}
REGISTRY: Mapping[str, ControllerSpec] = MappingProxyType(_BY_NAME)


def register(spec: ControllerSpec) -> None:
    """Add a controller under ``spec.name`` in this process (a plug-in, an example, a test driver).

    Requests still name controllers, never Python paths: only code that runs here can register one. A live
    server's controller-host processes know the built-in controllers (and any that the modules they import
    register). A name that is taken raises ``ValueError``.
    """
    if spec.name in _BY_NAME:
        raise ValueError(f"controller {spec.name!r} is already registered")
    _BY_NAME[spec.name] = spec


def controller_names() -> list[str]:
    """Names of every registered controller."""
    return sorted(REGISTRY)


def make_controller(name: str) -> Controller:
    """A new controller by registered name; ``KeyError`` names the known ones."""
    try:
        spec = REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown controller {name!r}; known: {controller_names()}") from None
    return spec.factory()
