"""The one closed registry of controllers. A request names a controller; it never names a Python path.

The CLI, the server and tournaments all build drivers through this module. Each :class:`ControllerSpec`
carries the controller's parameter dataclass, and its published parameters (names, types, defaults, units,
bounds) are derived from that dataclass's fields (:mod:`controllers.parameters`), so the API documentation
cannot drift from the code.

Building a driver
    ``make_controller(name)`` builds one with its defaults; ``make_controller(name, iterations=500)``
    overrides parameters. An unknown name raises ``KeyError`` naming the known ones; an unknown parameter, a
    value of the wrong type or one out of bounds raises :class:`~controllers.parameters.ParameterError` (a
    ``ValueError``) naming the controller and the parameter.

For the server (validate a request once, build later, possibly in another process)
    ``params = validate_parameters(name, request_parameters)`` checks a request's ``{name: value}`` mapping
    and returns the controller's parameter dataclass instance (``None`` for a controller without parameters);
    a :class:`~controllers.parameters.ParameterError` there is the request's fault (HTTP 422), its ``str`` the
    detail. ``controller_factory(name, params)`` then gives a zero-argument, picklable factory for the
    controller hosts and planner workers (``spec.factory`` is the one with the defaults). A server with a
    catalogue of its own (tests add faulty controllers) calls the same methods on the spec:
    ``spec.validate(request_parameters)`` and ``spec.factory_for(params)``. ``spec.parameter_list`` is the
    documented list (:class:`~controllers.parameters.Parameter`); ``spec.parameters`` the defaults as text.

Adding a controller
    1. Write the driver (the :class:`~controllers.base.Controller` Protocol: ``name``, ``rate_hz``,
       ``reset(context)``, ``act(observation)``), or compose one from parts with
       :class:`~controllers.hierarchical.HierarchicalController` (a :class:`~controllers.base.HighLevelPlanner`
       and a :class:`~controllers.base.Tracker`; the server then plans it off the tick through the
       :class:`~controllers.base.PlanningDriver` capability, with no server change).
    2. Put its public parameters in a frozen dataclass of ``int``/``float``/``bool``/``str`` fields with
       defaults, declared with :func:`~controllers.parameters.parameter` for a description, unit and bounds.
    3. Write a module-level ``build(params) -> Controller`` (module level: the server pickles it to worker
       processes) and add ``_spec(name, description, build, ParamsType)`` to ``_SPECS``. Its name must be
       new; the defaults must give the controller as tuned (a race with defaults is the reference).
    4. ``tests/controllers/test_registry.py`` then checks it resets and acts within budget on three tracks; the
       server lists it at ``/api/controllers``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from types import MappingProxyType
from typing import Any, Generic, TypeVar

from controllers.base import Controller
from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.lane_follower import LaneFollowerController, LaneFollowerParams
from controllers.lq.presets import fixed_line_tracker, mcts_tracker
from controllers.parameters import Parameter, ParameterError, parameter, parameters_of, with_overrides
from controllers.rl.agents import (
    E2EParams,
    FixedRLParams,
    MCTSRLAdaptiveParams,
    MCTSRLParams,
    build_e2e,
    build_fixed_rl,
    build_mcts_rl,
    build_mcts_rl_adaptive,
)
from controllers.tactical.high_level import HOLD_GAIN, AdaptiveOpponentParams, MCTSPlanner, TacticalParams
from sim_core.params import MIN_PACE

P = TypeVar("P")


@dataclass(frozen=True)
class ControllerSpec(Generic[P]):
    """A registered controller: its name, what it is, how to build one, and its parameter dataclass."""

    name: str
    description: str
    factory: Callable[[], Controller]  # a driver with the default parameters
    params_type: type[P] | None = None  # frozen dataclass of the public parameters (None: it has none)
    build: Callable[[P], Controller] | None = None  # a driver from a ``params_type`` instance

    @property
    def parameter_list(self) -> tuple[Parameter, ...]:
        """The public parameters, derived from ``params_type``."""
        return () if self.params_type is None else parameters_of(self.params_type)

    @property
    def parameters(self) -> Mapping[str, str]:
        """Each public parameter's default as text (what ``/api/controllers`` lists)."""
        return {p.name: str(p.default) for p in self.parameter_list}

    def validate(self, overrides: Mapping[str, object]) -> P | None:
        """The parameters with ``overrides`` applied to the defaults; :class:`ParameterError` on a bad one."""
        if self.params_type is None:
            if overrides:
                raise ParameterError(self.name, next(iter(overrides)), "is unknown (known: none)")
            return None
        return with_overrides(self.name, self.params_type, overrides)

    def factory_for(self, params: P | None) -> Callable[[], Controller]:
        """A zero-argument factory of drivers with ``params`` (from :meth:`validate`); picklable when ``build``
        is a module-level function."""
        if params is None or self.build is None:
            return self.factory
        return partial(self.build, params)


def _spec(name: str, description: str, build: Callable[[P], Controller], params_type: type[P]) -> ControllerSpec[P]:
    return ControllerSpec(name, description, partial(build, params_type()), params_type, build)


LQNG_HORIZON_HELP = "steps of 0.02 s the LQ game looks ahead"


@dataclass(frozen=True)
class MCTSLQNGParams(TacticalParams):
    """Public parameters of ``mcts-lqng``: the tactical planner's (:class:`TacticalParams`) and its tracker's."""

    hold_gain_s: float = parameter(
        HOLD_GAIN,
        "a plan that left the racing line (a pass under way) is kept while its lanes still gain this much on the "
        "line's and no less than the new plan's less 0.05 s (ours, not the paper's: re-planned afresh every "
        "second, a pass was given up half way)",
        unit="s",
        minimum=0.0,
        maximum=5.0,
    )
    lqng_horizon_steps: int = parameter(4, LQNG_HORIZON_HELP, minimum=1, maximum=25)


@dataclass(frozen=True)
class MCTSLQNGAdaptiveParams(MCTSLQNGParams, AdaptiveOpponentParams):
    """Public parameters of ``mcts-lqng-adaptive``: ``mcts-lqng``'s and the opponent models it chooses from."""


@dataclass(frozen=True)
class FixedLQNGParams:
    """Public parameters of ``fixed-lqng``."""

    line_margin_m: float = parameter(
        1.0, "how far the planner's racing line keeps inside the walls", unit="m", minimum=0.5, maximum=3.0
    )
    lqng_horizon_steps: int = parameter(4, LQNG_HORIZON_HELP, minimum=1, maximum=25)
    speed_scale: float = parameter(
        1.0,
        "fraction of its speed targets it drives at (a driver holding back; a slower kart is a pace handicap, "
        "fixed-lqng@0.95)",
        minimum=0.5,
        maximum=1.0,
    )


def _mcts_lqng(params: MCTSLQNGParams) -> Controller:
    search = MCTSPlanner.from_settings(params, hold_gain=params.hold_gain_s)
    return HierarchicalController("mcts-lqng", search, mcts_tracker(params.lqng_horizon_steps))


def _mcts_lqng_adaptive(params: MCTSLQNGAdaptiveParams) -> Controller:
    search = MCTSPlanner.from_settings(params, hold_gain=params.hold_gain_s, agent_factory=make_agent)
    return HierarchicalController("mcts-lqng-adaptive", search, mcts_tracker(params.lqng_horizon_steps))


def _mcts_rl_adaptive(params: MCTSRLAdaptiveParams) -> Controller:
    return build_mcts_rl_adaptive(params, make_agent)


def _fixed_lqng(params: FixedLQNGParams) -> Controller:
    planner = FixedLinePlanner(margin=params.line_margin_m)
    tracker = fixed_line_tracker(params.lqng_horizon_steps, params.speed_scale)
    return HierarchicalController("fixed-lqng", planner, tracker)


_SPECS: tuple[ControllerSpec[Any], ...] = (
    _spec(
        "mcts-lqng",
        "MCTS tactical planner (1 Hz, 2,000 iterations, horizon 8) tracked by the LQ Nash game tracker (50 Hz).",
        _mcts_lqng,
        MCTSLQNGParams,
    ),
    _spec(
        "mcts-lqng-adaptive",
        "mcts-lqng playing each other kart in its game by the opponent model (racing line, held lane, best "
        "response, own last lap, a fixed-line agent simulated) that has forecast that kart's lanes best so far.",
        _mcts_lqng_adaptive,
        MCTSLQNGAdaptiveParams,
    ),
    _spec(
        "fixed-lqng",
        "The offline optimised racing line tracked by the LQ Nash game tracker (50 Hz) under mcts-lqng's rules of "
        "the road: the lanes its lane changes reach, room for a kart alongside, station behind a kart ahead, a "
        "faster kart let in.",
        _fixed_lqng,
        FixedLQNGParams,
    ),
    _spec(
        "lane-follower",
        "Pure pursuit on its start lane with a curvature-limited speed profile (a simple baseline).",
        LaneFollowerController,
        LaneFollowerParams,
    ),
    _spec(
        "mcts-rl",
        "MCTS tactical planner (1 Hz) tracked by a PPO self-play policy deciding at 25 Hz (the paper's MCTS-RL); "
        "the tracker keeps its distance to a kart ahead, to the lanes its spent lane changes leave on a straight, "
        "and never moves sideways into a kart alongside faster than the referee allows.",
        build_mcts_rl,
        MCTSRLParams,
    ),
    _spec(
        "mcts-rl-adaptive",
        "mcts-rl playing each other kart in its game by the opponent model that has forecast that kart's lanes "
        "best so far (as mcts-lqng-adaptive).",
        _mcts_rl_adaptive,
        MCTSRLAdaptiveParams,
    ),
    _spec(
        "fixed-rl",
        "The offline optimised racing line tracked by a PPO self-play policy deciding at 25 Hz (Fixed-RL), under "
        "mcts-rl's traffic rules.",
        build_fixed_rl,
        FixedRLParams,
    ),
    _spec(
        "e2e",
        "A PPO self-play policy driving end to end at 25 Hz toward the checkpoint centres, no planner (E2E), under "
        "the hierarchical RL agents' traffic rules.",
        build_e2e,
        E2EParams,
    ),
)

_BY_NAME: dict[str, ControllerSpec[Any]] = {spec.name: spec for spec in _SPECS}
REGISTRY: Mapping[str, ControllerSpec[Any]] = MappingProxyType(_BY_NAME)


def register(spec: ControllerSpec[Any]) -> None:
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


def controller_spec(name: str) -> ControllerSpec[Any]:
    """The spec of a registered controller; ``KeyError`` names the known ones."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"unknown controller {name!r}; known: {controller_names()}") from None


def validate_parameters(name: str, overrides: Mapping[str, object]) -> Any:
    """The parameter dataclass instance of controller ``name`` with ``overrides`` applied (``None`` for a
    controller without parameters). ``KeyError`` for an unknown controller, :class:`ParameterError` (a
    ``ValueError``) naming the unknown, mistyped or out-of-bounds parameter."""
    return controller_spec(name).validate(overrides)


def controller_factory(name: str, params: Any = None) -> Callable[[], Controller]:
    """A zero-argument, picklable factory of controller ``name`` with ``params`` (from
    :func:`validate_parameters`; ``None``: the defaults)."""
    return controller_spec(name).factory_for(params)


def make_controller(name: str, **overrides: object) -> Controller:
    """A new controller by registered name, with ``overrides`` of its public parameters.

    ``KeyError`` names the known controllers; :class:`ParameterError` the offending parameter.
    """
    spec = controller_spec(name)
    return spec.factory_for(spec.validate(overrides))()


# an agent is a registered name, or a name with parameters: ``mcts-lqng:hold_gain_s=0:iterations=500``
# (what tournaments and headless races take, where one string names a driver); ``@PACE`` at the end drives its kart
# at a pace handicap (``fixed-lqng@0.95``: sim_core.params.KartParams.paced)
AGENT_SEPARATOR = ":"
PACE_SEPARATOR = "@"


def agent_pace(agent: str) -> float:
    """The pace an agent string asks its kart to drive at: ``NAME...@PACE``, a ratio in [``MIN_PACE``, 1] (1
    without ``@``). ``ValueError`` for a pace that is not a number in that range."""
    _, at, text = agent.rpartition(PACE_SEPARATOR)
    if not at:
        return 1.0
    try:
        pace = float(text)
    except ValueError:
        raise ValueError(f"agent {agent!r}: pace {text!r} after {PACE_SEPARATOR!r} is not a number") from None
    if not MIN_PACE <= pace <= 1.0:
        raise ValueError(f"agent {agent!r}: pace must be in [{MIN_PACE:g}, 1], got {pace:g}")
    return pace


def without_pace(agent: str) -> str:
    """The agent string without its ``@PACE`` (the driver; the pace is its kart's)."""
    return agent.rpartition(PACE_SEPARATOR)[0] if PACE_SEPARATOR in agent else agent


def parse_agent(agent: str) -> tuple[str, dict[str, object]]:
    """The controller name and parameter overrides of an agent string ``NAME[:KEY=VALUE]...[@PACE]``; each value is
    read as JSON where it parses (``3``, ``0.5``, ``true``) and as text otherwise. ``ValueError`` for a part without
    ``=``, a key given twice or a bad pace (names and values are checked by :func:`validate_agent`; the pace is
    :func:`agent_pace`'s)."""
    agent_pace(agent)
    name, *settings = without_pace(agent).split(AGENT_SEPARATOR)
    overrides: dict[str, object] = {}
    for setting in settings:
        key, equals, text = setting.partition("=")
        if not equals or not key:
            raise ValueError(f"agent {agent!r}: {setting!r} is not KEY=VALUE")
        if key in overrides:
            raise ValueError(f"agent {agent!r}: {key} is given twice")
        try:
            overrides[key] = json.loads(text)
        except json.JSONDecodeError:
            overrides[key] = text
    return name, overrides


def validate_agent(agent: str) -> None:
    """Raise ``KeyError`` (unknown controller), :class:`ParameterError` or ``ValueError`` for a bad agent string."""
    name, overrides = parse_agent(agent)
    validate_parameters(name, overrides)


def make_agent(agent: str) -> Controller:
    """A new controller from an agent string (:func:`parse_agent`): ``make_controller(name, **overrides)``."""
    name, overrides = parse_agent(agent)
    return make_controller(name, **overrides)
