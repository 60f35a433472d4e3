"""The one closed registry of controllers. A request names a controller; it never names a Python path.

The CLI, the server and tournaments all build drivers through :func:`make_controller`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from controllers.base import Controller
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.lane_follower import LaneFollowerController
from controllers.lq.tracker import FIXED_LINE_TRACKING, MCTS_TRACKING, LQNGTracker
from controllers.tactical.high_level import MCTSPlanner


@dataclass(frozen=True)
class ControllerSpec:
    """A registered controller: its name, what it is, its parameters, and how to build one."""

    name: str
    description: str
    factory: Callable[[], Controller]
    parameters: Mapping[str, str] = field(default_factory=dict)


def _mcts_lqng() -> Controller:
    return HierarchicalController("mcts-lqng", MCTSPlanner(), LQNGTracker(MCTS_TRACKING))


def _fixed_lqng() -> Controller:
    return HierarchicalController("fixed-lqng", FixedLinePlanner(), LQNGTracker(FIXED_LINE_TRACKING))


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

REGISTRY: Mapping[str, ControllerSpec] = MappingProxyType({spec.name: spec for spec in _SPECS})


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
