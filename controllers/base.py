"""The controller interface: a small typed Protocol for drivers, and the parts hierarchical drivers are built
from (a high-level planner that produces a :class:`~controllers.plan.Plan` and a tracker that follows it)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from controllers.plan import Plan
from sim_core.observation import Observation
from sim_core.params import KartParams
from sim_core.track import Track


@dataclass(frozen=True)
class Action:
    """Driver inputs: steer in [-1, 1] (positive = left) and throttle in [-1, 1] (negative brakes)."""

    steer: float
    throttle: float


@dataclass(frozen=True)
class RaceContext:
    """What a controller learns when a race starts."""

    track: Track
    kart: KartParams  # the kart it drives: the race's reference kart at ``pace``
    ego: int  # index of the kart it drives
    n_karts: int
    lane_change_limit: int
    seed: int
    pace: float = 1.0  # the kart's pace handicap (sim_core.params.KartParams.paced)
    teams: tuple[int, ...] = ()  # each kart's team number, from 1 (empty: every kart for itself; team_numbers)


def team_numbers(teams: Sequence[str | None]) -> tuple[int, ...]:
    """:attr:`RaceContext.teams` from each kart's team name: numbers from 1 in order of first appearance, a kart
    without a team (None) alone in its own (empty: no kart has a team)."""
    if all(team is None for team in teams):
        return ()
    labels = [team if team is not None else f"\0{k}" for k, team in enumerate(teams)]
    numbers = {label: n for n, label in enumerate(dict.fromkeys(labels), start=1)}
    return tuple(numbers[label] for label in labels)


@runtime_checkable
class Controller(Protocol):
    """A driver for one kart: reset once per race, then asked to act on every decision step."""

    name: str
    rate_hz: float  # decisions per second; the simulation holds the last action in between

    def reset(self, context: RaceContext) -> None:
        """Prepare for a new race."""

    def act(self, observation: Observation) -> Action:
        """The inputs for the next step(s)."""


class HighLevelPlanner(Protocol):
    """Produces waypoints (for the ego kart, and predictions for the others) from an observation."""

    rate_hz: float

    def reset(self, context: RaceContext) -> None:
        """Prepare for a new race."""

    def plan(self, observation: Observation) -> Plan:
        """Waypoints from the state in ``observation``."""


class Tracker(Protocol):
    """Turns the current plan into inputs at the simulation rate."""

    def reset(self, context: RaceContext) -> None:
        """Prepare for a new race."""

    def act(self, observation: Observation, plan: Plan | None) -> Action:
        """Inputs that follow ``plan`` (or a sensible default without one)."""


@runtime_checkable
class TimeBoundedPlanner(Protocol):
    """A high-level planner that can cut a plan short to a wall-clock budget. A live host sets
    ``plan_budget_s`` so that a plan arrives while it is still worth driving; headless races leave it ``None``
    and every plan is whole and deterministic."""

    plan_budget_s: float | None  # [s] wall-clock seconds one plan may take (None: no limit)


@runtime_checkable
class PlanningDriver(Protocol):
    """A driver that plans off the tick: a high-level planner at its own (slow) rate and a tracker at the
    simulation rate. Hosts ask this capability instead of a concrete class: headless races plan in line
    (``act`` does everything), the live server plans in a worker with :meth:`wants_plan`,
    :meth:`mark_plan_requested` and :meth:`deliver`, and tracks with :meth:`track`.
    """

    name: str
    rate_hz: float
    planner: HighLevelPlanner
    plan_latency: float  # [s] simulated delay between requesting and applying a plan (headless races)
    plans_applied: int
    active_plan: Plan | None

    def reset(self, context: RaceContext) -> None:
        """Prepare for a new race."""

    def act(self, observation: Observation) -> Action:
        """Plan when due (in line), apply ready plans and track."""

    def wants_plan(self, time: float) -> bool:
        """Whether a re-plan is due at race time ``time``."""

    def mark_plan_requested(self, time: float) -> None:
        """Record that a plan was requested elsewhere at race time ``time``."""

    def deliver(self, plan: Plan) -> None:
        """Make ``plan`` the active plan."""

    def track(self, observation: Observation) -> Action:
        """The tracker's inputs for the active plan, without planning."""


@runtime_checkable
class ActionFilter(Protocol):
    """A part between a driver's decision and the kart: it may change the action (a shield that brakes, a
    recovery that takes over). Filters of one driver apply in order, each to the one before's output."""

    def reset(self, context: RaceContext) -> None:
        """Prepare for a new race."""

    def apply(self, action: Action, observation: Observation) -> Action:
        """The action to send instead of ``action`` (``action`` itself when the filter has nothing to say)."""

    @property
    def took_over(self) -> bool:
        """Whether the last action applied is the filter's own rather than a change of the driver's (the driver
        then does not count it as its own decision)."""
