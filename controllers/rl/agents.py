"""The three learned agents as registered controllers: ``mcts-rl``, ``fixed-rl`` and ``e2e``.

* ``mcts-rl``: the MCTS tactical planner (:class:`~controllers.tactical.high_level.MCTSPlanner`) composed with
  the RL tracker (:class:`~controllers.rl.tracker.RLTracker`), which targets the plan's lanes and speeds;
* ``fixed-rl``: the fixed racing-line planner (:class:`~controllers.fixed_line.FixedLinePlanner`) with the RL
  tracker targeting its lanes at top speed;
  both brake when over the racing line's speed profile plus 1 m/s (:mod:`controllers.rl.shield`, a public
  parameter: ``line_speed_shield``);
* ``e2e``: the RL policy alone (checkpoint centres as targets), a plain :class:`~controllers.base.Controller`.
  The paper ran a background MCTS for E2E's delta-r / delta-v metrics only; it is left out here.

Weights come from ``controllers/rl/weights/AGENT/policy.npz`` (shipped; see its ``manifest.json``). The
folder is not a public parameter: requests name controllers, never paths. Every agent is registered whether
or not its weights exist, so the registry always loads; a driver without weights raises
:class:`~controllers.rl.policy.MissingWeightsError` at ``reset`` naming the folder and how to fill it.

The ``build_*`` functions are module level so that their ``functools.partial`` factories pickle into the
server's controller hosts and planner workers. Nothing here imports torch.
"""

from __future__ import annotations

from dataclasses import dataclass

from controllers.base import Action, Controller, RaceContext
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.parameters import parameter
from controllers.rl.tracker import RLTracker
from controllers.tactical.high_level import (
    DEVIATION_GAIN,
    DEVIATION_GAIN_HELP,
    OWN_PACE_HELP,
    PACE_MODEL_HELP,
    RACING_LINE_DEFAULT_HELP,
    MCTSPlanner,
)
from sim_core.observation import Observation

RL_RATE_HZ = 50.0  # called every step; the tracker itself decides at 25 Hz and holds its action


SPEED_CEILING_HELP = (
    "brake when over the racing line's speed profile by more than this (the LQNG tracker's ceiling); "
    "0 m/s: exactly the profile (ours, not the paper's: controllers.rl.shield)"
)
SHIELD_HELP = "never faster than the racing line's speed profile plus the margin (ours, not the paper's)"
KEEP_SIDE_HELP = "never steer toward a kart alongside faster than the lateral room to it allows (ours, not the paper's)"
LOOKAHEAD_HELP = "how far ahead the karts' sideways motion is extrapolated to tell whether a kart is in the path"
KEEP_DISTANCE_HELP = (
    "brake rather than close on a kart ahead in the path faster than it could stop short of the rules' buffer "
    "(ours, not the paper's)"
)

STALL_RECOVERY_HELP = (
    "after 0.5 s stalled, drive off (or back off a wall) for 1 s; the policy never reverses (ours, not the paper's)"
)


@dataclass(frozen=True)
class MCTSRLParams:
    """Public parameters of ``mcts-rl``."""

    iterations: int = parameter(2000, "MCTS iterations per plan", minimum=1, maximum=20_000)
    horizon: int = parameter(8, "checkpoints the tactical game looks ahead", minimum=1, maximum=16)
    planner_rate_hz: float = parameter(1.0, "re-plans per second", unit="Hz", minimum=0.1, maximum=10.0)
    lane_change_slack: int = parameter(
        2,
        "lanes of the rule's limit per straight the plans leave unused, for the policy's tracking error "
        "(ours, not the paper's)",
        minimum=0,
        maximum=4,
    )
    # the racing line unless the search gains, with every kart timed at its measured pace: the search's own lanes
    # near another kart cost it the time it is faster (107 s behind mcts-lqng's 106.3 s on complex, 102.7 s
    # alone); the line with one model of the kart for everyone closed up and hit the kart ahead (0.65 collisions
    # at fault per race against fixed-lqng, session 12). With both: 20-0 against fixed-lqng on complex, no
    # collision at fault, 14-6 against mcts-lqng (session 13, results/rl/session13)
    racing_line_default: bool = parameter(True, RACING_LINE_DEFAULT_HELP)
    deviation_gain_s: float = parameter(DEVIATION_GAIN, DEVIATION_GAIN_HELP, unit="s", minimum=0.0, maximum=5.0)
    pace_model: bool = parameter(True, PACE_MODEL_HELP)
    own_pace: float = parameter(1.0, OWN_PACE_HELP, minimum=0.8, maximum=1.3)
    deterministic: bool = parameter(
        True, "decide by the policy's Gaussian (mean steer, most likely pedal) instead of sampling it (seeded)"
    )
    stall_recovery: bool = parameter(True, STALL_RECOVERY_HELP)
    line_speed_shield: bool = parameter(True, SHIELD_HELP)
    speed_ceiling_margin_mps: float = parameter(1.0, SPEED_CEILING_HELP, unit="m/s", minimum=0.0, maximum=5.0)
    keep_distance: bool = parameter(True, KEEP_DISTANCE_HELP)
    # as fixed-rl's: driving the line's speed behind another kart (its planner sends no slower speeds there, the
    # shield keeps the distance), it meets that kart's sideways moves as fixed-rl does (0.75 collisions at fault
    # per race against mcts-lqng on complex looking 0 s ahead, 0.40 looking 0.8 s ahead; session 12)
    keep_distance_lookahead_s: float = parameter(0.8, LOOKAHEAD_HELP, unit="s", minimum=0.0, maximum=2.0)
    keep_side: bool = parameter(False, KEEP_SIDE_HELP)


@dataclass(frozen=True)
class FixedRLParams:
    """Public parameters of ``fixed-rl``."""

    line_margin_m: float = parameter(
        1.0, "how far the planner's racing line keeps inside the walls", unit="m", minimum=0.5, maximum=3.0
    )
    deterministic: bool = parameter(
        True, "decide by the policy's Gaussian (mean steer, most likely pedal) instead of sampling it (seeded)"
    )
    stall_recovery: bool = parameter(True, STALL_RECOVERY_HELP)
    line_speed_shield: bool = parameter(True, SHIELD_HELP)
    speed_ceiling_margin_mps: float = parameter(1.0, SPEED_CEILING_HELP, unit="m/s", minimum=0.0, maximum=5.0)
    keep_distance: bool = parameter(True, KEEP_DISTANCE_HELP)
    keep_distance_lookahead_s: float = parameter(0.8, LOOKAHEAD_HELP, unit="s", minimum=0.0, maximum=2.0)
    keep_side: bool = parameter(False, KEEP_SIDE_HELP)


@dataclass(frozen=True)
class E2EParams:
    """Public parameters of ``e2e`` (the policy is the whole driver)."""

    deterministic: bool = parameter(
        True, "decide by the policy's Gaussian (mean steer, most likely pedal) instead of sampling it (seeded)"
    )
    stall_recovery: bool = parameter(True, STALL_RECOVERY_HELP)
    line_speed_shield: bool = parameter(
        False, SHIELD_HELP + ": the racing line is a planner's, which the end-to-end agent has not"
    )
    speed_ceiling_margin_mps: float = parameter(1.0, SPEED_CEILING_HELP, unit="m/s", minimum=0.0, maximum=5.0)
    keep_distance: bool = parameter(False, KEEP_DISTANCE_HELP + ": off, as the end-to-end agent is the policy alone")


def _ceiling_margin(params: MCTSRLParams | FixedRLParams | E2EParams) -> float | None:
    """The shield's margin [m/s], or None with the shield off."""
    return params.speed_ceiling_margin_mps if params.line_speed_shield else None


def build_mcts_rl(params: MCTSRLParams) -> Controller:
    """MCTS planner + RL tracker."""
    planner = MCTSPlanner.from_settings(
        params,
        lane_change_slack=params.lane_change_slack,
        # the following shield keeps the distance to a kart ahead; the game's coarse speed bins behind it only
        # held mcts-rl 5-17 m back, too far to ever pass (session 12)
        planned_speeds_behind=not params.keep_distance,
    )
    return HierarchicalController(
        "mcts-rl",
        planner,
        RLTracker(
            "mcts-rl",
            deterministic=params.deterministic,
            stall_recovery=params.stall_recovery,
            speed_ceiling_margin=_ceiling_margin(params),
            keep_distance=params.keep_distance,
            keep_distance_lookahead=params.keep_distance_lookahead_s,
            keep_side=params.keep_side,
        ),
        rate_hz=RL_RATE_HZ,
    )


def build_fixed_rl(params: FixedRLParams) -> Controller:
    """Fixed racing-line planner + RL tracker."""
    planner = FixedLinePlanner(margin=params.line_margin_m)
    return HierarchicalController(
        "fixed-rl",
        planner,
        RLTracker(
            "fixed-rl",
            deterministic=params.deterministic,
            stall_recovery=params.stall_recovery,
            speed_ceiling_margin=_ceiling_margin(params),
            line_margin=params.line_margin_m,
            keep_distance=params.keep_distance,
            keep_distance_lookahead=params.keep_distance_lookahead_s,
            keep_side=params.keep_side,
        ),
        rate_hz=RL_RATE_HZ,
    )


class E2EController:
    """The end-to-end agent: the RL policy on checkpoint-centre targets, no planner."""

    name = "e2e"
    rate_hz = RL_RATE_HZ

    def __init__(
        self,
        folder: str | None = None,
        deterministic: bool = True,
        stall_recovery: bool = False,
        speed_ceiling_margin: float | None = None,
        keep_distance: bool = False,
    ) -> None:
        self.tracker = RLTracker(
            "e2e", folder, deterministic, stall_recovery, speed_ceiling_margin, keep_distance=keep_distance
        )

    def reset(self, context: RaceContext) -> None:
        """Load the weights and start a race."""
        self.tracker.reset(context)

    def act(self, observation: Observation) -> Action:
        """The policy's inputs (a new decision every 40 ms)."""
        return self.tracker.act(observation, None)


def build_e2e(params: E2EParams) -> Controller:
    """The end-to-end agent."""
    return E2EController(
        deterministic=params.deterministic,
        stall_recovery=params.stall_recovery,
        speed_ceiling_margin=_ceiling_margin(params),
        keep_distance=params.keep_distance,
    )
