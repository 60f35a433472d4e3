"""Every message between the server and its worker processes, one small frozen dataclass each; receivers
``match`` on the type.

Controller hosts (:mod:`server.hosts`): the server sends :class:`Open`, :class:`Act`, :class:`DeliverPlan`,
:class:`Close` and :class:`Stop`; a host answers :class:`Ready`, :class:`Failed`, :class:`ActionOut` and
:class:`Error`. ``kart`` is the host's id of a kart (unique per server process, not the grid slot).

Planner workers (:mod:`server.planning`): the server submits :class:`OpenPlanner`, :class:`RequestPlan`,
:class:`ClosePlanners` and :class:`WarmPlanner`; the answer is the call's return value (seconds, a
:class:`~controllers.plan.Plan`, nothing) or its exception.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from controllers.base import Controller, RaceContext
from controllers.plan import Plan
from sim_core.observation import Observation


# ----------------------------------------------------------------------------------------- server -> host
@dataclass(frozen=True)
class Open:
    """Build a kart's controller with ``factory`` (the registry's zero-argument factory of the request's
    parameters, picklable) and reset it for the race."""

    kart: int
    controller: str  # registered name (for error messages)
    factory: Callable[[], Controller]
    context: RaceContext


@dataclass(frozen=True)
class Act:
    """The kart's newest observation, of race step ``step``."""

    kart: int
    step: int
    observation: Observation


@dataclass(frozen=True)
class DeliverPlan:
    """Make ``plan`` the active plan of the host's copy of the kart's controller."""

    kart: int
    plan: Plan


@dataclass(frozen=True)
class Close:
    """Forget the kart (a call still running is abandoned)."""

    kart: int


@dataclass(frozen=True)
class Stop:
    """End the host process."""


ToHost = Open | Act | DeliverPlan | Close | Stop


# ----------------------------------------------------------------------------------------- host -> server
@dataclass(frozen=True)
class Ready:
    """The kart's controller was built and reset."""

    kart: int


@dataclass(frozen=True)
class Failed:
    """Building or resetting the kart's controller failed: the kart is disabled."""

    kart: int
    error: str


@dataclass(frozen=True)
class ActionOut:
    """The controller's inputs for the observation of race step ``step``."""

    kart: int
    step: int
    steer: float
    throttle: float


@dataclass(frozen=True)
class Error:
    """A decision raised (the kart holds its last input)."""

    kart: int
    error: str


FromHost = Ready | Failed | ActionOut | Error


# ----------------------------------------------------------------------------------------- planner workers
@dataclass(frozen=True)
class PlannerSetup:
    """How a worker builds one kart's planner: the controller factory (the registry's zero-argument factory of
    the request's parameters, picklable) whose ``.planner`` it uses, the race context to reset it with, and the
    wall-clock budget per plan of a planner that can cut a plan short (:class:`~controllers.base.TimeBoundedPlanner`;
    None: no limit)."""

    factory: Callable[[], Controller]
    context: RaceContext
    plan_budget_s: float | None = None  # [s]


@dataclass(frozen=True)
class OpenPlanner:
    """Build and reset the planner of ``key``; answered with the seconds it took."""

    key: str
    setup: PlannerSetup


@dataclass(frozen=True)
class RequestPlan:
    """Plan for ``key`` from ``observation`` (building the planner first when ``setup`` is given); answered with
    the :class:`~controllers.plan.Plan`."""

    key: str
    observation: Observation
    setup: PlannerSetup | None


@dataclass(frozen=True)
class ClosePlanners:
    """Forget the planners of ``keys``."""

    keys: tuple[str, ...]


@dataclass(frozen=True)
class WarmPlanner:
    """Plan once with a small budget so every compiled kernel is loaded; answered with the seconds it took."""


ToPlanner = OpenPlanner | RequestPlan | ClosePlanners | WarmPlanner
