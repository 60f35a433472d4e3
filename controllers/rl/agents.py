"""The three learned agents as registered controllers: ``mcts-rl``, ``fixed-rl`` and ``e2e``.

* ``mcts-rl``: the MCTS tactical planner (:class:`~controllers.tactical.high_level.MCTSPlanner`) composed with
  the RL tracker (:class:`~controllers.rl.tracker.RLTracker`), which targets the plan's lanes and speeds;
* ``fixed-rl``: the fixed racing-line planner (:class:`~controllers.fixed_line.FixedLinePlanner`) with the RL
  tracker targeting its lanes at top speed;
  both brake when over the racing line's speed profile plus 1 m/s, keep their distance to a kart ahead, keep to
  the lanes their spent lane changes leave, give a kart alongside room and recover from a stall (the action
  filters of :mod:`controllers.rl.filters`);
* ``e2e``: the RL policy alone (checkpoint centres as targets) with the same filters but the speed ceiling (it
  has no line), a plain :class:`~controllers.base.Controller`.
  The paper ran a background MCTS for E2E's delta-r / delta-v metrics only; it is left out here.

Weights come from ``controllers/rl/weights/AGENT/policy.npz`` (shipped; see its ``manifest.json``). The
folder is not a public parameter: requests name controllers, never paths. Every agent is registered whether
or not its weights exist, so the registry always loads; a driver without weights raises
:class:`~controllers.rl.policy.MissingWeightsError` at ``reset`` naming the folder and how to fill it.

The ``build_*`` functions are module level so that their ``functools.partial`` factories pickle into the
server's controller hosts and planner workers. Nothing here imports torch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from controllers.base import Action, ActionFilter, Controller, RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.parameters import parameter
from controllers.rl.filters import (
    GiveRoomAlongside,
    KeepDistance,
    KeepToLaneLimit,
    LineSpeedCeiling,
    RecoverFromStall,
)
from controllers.rl.tracker import RLTracker
from controllers.tactical.high_level import AdaptiveOpponentParams, MCTSPlanner, TacticalParams
from controllers.tactical.opponents import AgentFactory
from sim_core.observation import Observation

RL_RATE_HZ = 50.0  # called every step; the tracker itself decides at 25 Hz and holds its action


SPEED_CEILING_HELP = (
    "brake when over the racing line's speed profile by more than this (the LQNG tracker's ceiling; ours, not "
    "the paper's: controllers.rl.filters.LineSpeedCeiling)"
)
LOOKAHEAD_HELP = (
    "how far ahead the karts' sideways motion is extrapolated to tell whether a kart ahead is in the path, which "
    "the tracker never closes on faster than it could stop short of the rules' buffer (ours, not the paper's: "
    "controllers.rl.filters.KeepDistance)"
)
LINE_MARGIN_HELP = "how far the planner's racing line keeps inside the walls"
LANE_LIMIT_MARGIN_HELP = (
    "on a straight whose lane changes are spent, how far short of where the referee would count another change the "
    "kart's sideways motion stops (ours, not the paper's: controllers.rl.filters.KeepToLaneLimit)"
)
SIDE_CLEARANCE_HELP = (
    "the gap across, centre to centre, to a kart alongside that the kart's own sideways motion closes no further; "
    "it turns away in time (ours, not the paper's: controllers.rl.filters.GiveRoomAlongside)"
)


@dataclass(frozen=True)
class TrafficRuleParams:
    """Public parameters of an RL agent's traffic rules: the room it gives a kart alongside and the lanes it keeps
    to once a straight's lane changes are spent."""

    side_clearance_m: float = parameter(1.1, SIDE_CLEARANCE_HELP, unit="m", minimum=0.9, maximum=3.0)
    lane_limit_margin_m: float = parameter(0.15, LANE_LIMIT_MARGIN_HELP, unit="m", minimum=0.0, maximum=0.5)


@dataclass(frozen=True)
class MCTSRLParams(TacticalParams, TrafficRuleParams):
    """Public parameters of ``mcts-rl``: the tactical planner's (:class:`TacticalParams`), its tracker's and its
    traffic rules' (:class:`TrafficRuleParams`)."""

    lane_change_slack: int = parameter(
        2,
        "lanes of the rule's limit per straight the plans leave unused, for the policy's tracking error "
        "(ours, not the paper's)",
        minimum=0,
        maximum=4,
    )
    speed_ceiling_margin_mps: float = parameter(1.0, SPEED_CEILING_HELP, unit="m/s", minimum=0.0, maximum=5.0)
    keep_distance_lookahead_s: float = parameter(0.8, LOOKAHEAD_HELP, unit="s", minimum=0.0, maximum=2.0)


@dataclass(frozen=True)
class MCTSRLAdaptiveParams(MCTSRLParams, AdaptiveOpponentParams):
    """Public parameters of ``mcts-rl-adaptive``: ``mcts-rl``'s and the opponent models it chooses from."""


@dataclass(frozen=True)
class FixedRLParams(TrafficRuleParams):
    """Public parameters of ``fixed-rl``: its line's, its tracker's and its traffic rules'."""

    line_margin_m: float = parameter(1.0, LINE_MARGIN_HELP, unit="m", minimum=0.5, maximum=3.0)
    speed_ceiling_margin_mps: float = parameter(1.0, SPEED_CEILING_HELP, unit="m/s", minimum=0.0, maximum=5.0)
    keep_distance_lookahead_s: float = parameter(0.8, LOOKAHEAD_HELP, unit="s", minimum=0.0, maximum=2.0)


@dataclass(frozen=True)
class E2EParams(TrafficRuleParams):
    """Public parameters of ``e2e``: how it decides, the distance it keeps and its traffic rules'."""

    deterministic: bool = parameter(
        True, "decide by the policy's Gaussian (mean steer, most likely pedal) instead of sampling it (seeded)"
    )
    keep_distance_lookahead_s: float = parameter(0.8, LOOKAHEAD_HELP, unit="s", minimum=0.0, maximum=2.0)


def _rl_filters(
    line_margin: float, ceiling_margin: float, lookahead: float, rules: TrafficRuleParams
) -> tuple[ActionFilter, ...]:
    """A hierarchical RL agent's filters: the line's speed ceiling, the distance kept, the traffic rules sideways
    (:func:`_traffic_rules`), the stall recovery last."""
    ceiling, keep = LineSpeedCeiling(ceiling_margin, line_margin), KeepDistance(lookahead)
    return (ceiling, keep, *_traffic_rules(rules), RecoverFromStall())


def _traffic_rules(rules: TrafficRuleParams) -> tuple[ActionFilter, ...]:
    """An RL agent's sideways traffic rules: the lanes its spent lane changes leave, then room for a kart alongside
    (last: where the two disagree, the room alongside wins)."""
    return (KeepToLaneLimit(rules.lane_limit_margin_m), GiveRoomAlongside(rules.side_clearance_m))


def build_mcts_rl(
    params: MCTSRLParams,
    name: str = "mcts-rl",
    agent_factory: AgentFactory | None = None,
    filters: tuple[ActionFilter, ...] | None = None,
) -> Controller:
    """MCTS planner + RL tracker (``agent_factory``: what builds the agents of simulated opponent models;
    ``filters``: the tracker's action filters, by default ``mcts-rl``'s)."""
    planner = MCTSPlanner.from_settings(
        params,
        agent_factory=agent_factory,
        lane_change_slack=params.lane_change_slack,
        # the tracker keeps its distance to a kart ahead (KeepDistance); the game's coarse speed bins behind it
        # held mcts-rl 5-17 m back, too far to ever pass
        planned_speeds_behind=False,
    )
    if filters is None:
        filters = _rl_filters(1.0, params.speed_ceiling_margin_mps, params.keep_distance_lookahead_s, params)
    return HierarchicalController(name, planner, RLTracker("mcts-rl", filters=filters), rate_hz=RL_RATE_HZ)


def build_mcts_rl_adaptive(params: MCTSRLAdaptiveParams, agent_factory: AgentFactory) -> Controller:
    """``mcts-rl`` with opponent models chosen by measured error."""
    return build_mcts_rl(params, "mcts-rl-adaptive", agent_factory)


def build_fixed_rl(
    params: FixedRLParams, name: str = "fixed-rl", filters: tuple[ActionFilter, ...] | None = None
) -> Controller:
    """Fixed racing-line planner + RL tracker (``filters``: the tracker's action filters, by default
    ``fixed-rl``'s)."""
    planner = FixedLinePlanner(margin=params.line_margin_m)
    if filters is None:
        margins = (params.line_margin_m, params.speed_ceiling_margin_mps, params.keep_distance_lookahead_s)
        filters = _rl_filters(*margins, params)
    return HierarchicalController(name, planner, RLTracker("fixed-rl", filters=filters), rate_hz=RL_RATE_HZ)


class E2EController:
    """The end-to-end agent: the RL policy on checkpoint-centre targets, no planner."""

    rate_hz = RL_RATE_HZ

    def __init__(
        self,
        folder: str | None = None,
        deterministic: bool = True,
        filters: Sequence[ActionFilter] = (),
        name: str = "e2e",
    ) -> None:
        self.name = name
        self.tracker = RLTracker("e2e", folder, deterministic, filters)

    def reset(self, context: RaceContext) -> None:
        """Load the weights and start a race."""
        self.tracker.reset(context)

    def act(self, observation: Observation) -> Action:
        """The policy's inputs (a new decision every 40 ms)."""
        return self.tracker.act(observation, None)


def build_e2e(params: E2EParams) -> Controller:
    """The end-to-end agent held to the hierarchical RL agents' traffic rules: the distance kept to a kart ahead
    in its path, the lanes its lane changes leave and the room given to one alongside, then the stall recovery
    (no speed ceiling: that is a planner's line)."""
    filters = (KeepDistance(params.keep_distance_lookahead_s), *_traffic_rules(params), RecoverFromStall())
    return E2EController(deterministic=params.deterministic, filters=filters)
