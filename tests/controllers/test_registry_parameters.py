"""A controller's public parameters come from its parameter dataclass, and a request can set them: validated by
name, type and bounds, with an error that names the parameter, and carried to the parts that use them."""

from __future__ import annotations

import dataclasses
import math
import pickle

import pytest
from hypothesis import given
from hypothesis import strategies as hs
from support.constant_driver import ConstantDriver

from controllers.fixed_line import FixedLinePlanner
from controllers.hierarchical import HierarchicalController
from controllers.lane_follower import LaneFollowerController
from controllers.lq.presets import FIXED_LINE_TRACKING, FIXED_LINE_TRAFFIC, MCTS_TRACKING, MCTS_TRAFFIC
from controllers.lq.tracker import LQNGTracker
from controllers.parameters import Parameter, ParameterError, parameter, parameters_of
from controllers.registry import (
    REGISTRY,
    ControllerSpec,
    controller_factory,
    controller_names,
    make_agent,
    make_controller,
    parse_agent,
    validate_agent,
    validate_parameters,
)
from controllers.rl.agents import E2EController
from controllers.rl.filters import GiveRoomAlongside, KeepDistance, KeepToLaneLimit, LineSpeedCeiling, RecoverFromStall
from controllers.rl.tracker import RLTracker
from controllers.tactical.game import GameParams
from controllers.tactical.high_level import MCTSPlanner, TacticalParams


@pytest.mark.parametrize("name", controller_names())
def test_published_parameters_are_the_dataclass_fields_and_defaults_lie_within_bounds(name: str) -> None:
    spec = REGISTRY[name]
    assert spec.params_type is not None
    fields = dataclasses.fields(spec.params_type)
    assert [p.name for p in spec.parameter_list] == [f.name for f in fields]
    assert dict(spec.parameters) == {f.name: str(f.default) for f in fields}
    for p in spec.parameter_list:
        assert p.description, f"{name}.{p.name} is undocumented"
        if p.type == "bool":  # a switch has nothing to bound
            assert isinstance(p.default, bool)
            continue
        if p.type == "str":  # a name or a list of names: checked by its dataclass, not by bounds
            assert isinstance(p.default, str)
            continue
        assert p.minimum is not None and p.maximum is not None, f"{name}.{p.name} has no bounds"
        assert isinstance(p.default, int | float) and p.minimum <= p.default <= p.maximum
    assert validate_parameters(name, {}) == spec.params_type()


def test_the_published_defaults_keep_the_documented_names() -> None:
    shared = {
        "iterations": "2000",
        "horizon": "8",
        "planner_rate_hz": "1.0",
        "deviation_gain_s": "0.1",
        "own_pace": "1.0",
    }
    assert dict(REGISTRY["mcts-lqng"].parameters) == {**shared, "hold_gain_s": "0.05", "lqng_horizon_steps": "4"}
    assert dict(REGISTRY["mcts-rl"].parameters) == {
        **shared,
        "lane_change_slack": "2",
        "speed_ceiling_margin_mps": "1.0",
        "keep_distance_lookahead_s": "0.8",
        "side_clearance_m": "1.1",
        "lane_limit_margin_m": "0.15",
    }
    assert dict(REGISTRY["fixed-lqng"].parameters) == {
        "line_margin_m": "1.0",
        "lqng_horizon_steps": "4",
        "speed_scale": "1.0",
    }


def test_the_hierarchical_agents_publish_few_parameters_and_share_the_tactical_ones() -> None:
    """A public parameter is a quantity to vary, not a version: at most 7 for mcts-lqng and 10 for mcts-rl (its
    tracker's filters and the two traffic rules' margins), the tactical planner's declared once
    (TacticalParams) for both."""
    lqng, rl = REGISTRY["mcts-lqng"].params_type, REGISTRY["mcts-rl"].params_type
    assert lqng is not None and rl is not None
    assert len(dataclasses.fields(lqng)) <= 7 and len(dataclasses.fields(rl)) <= 10
    assert issubclass(lqng, TacticalParams) and issubclass(rl, TacticalParams)
    for name in controller_names():
        spec = REGISTRY[name]
        assert spec.params_type is not None
        switches = [p.name for p in spec.parameter_list if p.type == "bool"]
        assert switches in ([], ["deterministic"]), f"{name} publishes version switches {switches}"


def test_overrides_reach_the_parts_that_use_them() -> None:
    driver = make_controller(
        "mcts-lqng",
        iterations=300,
        horizon=5,
        planner_rate_hz=2,
        lqng_horizon_steps=6,
        deviation_gain_s=0.3,
        hold_gain_s=0.2,
        own_pace=1.05,
    )
    assert isinstance(driver, HierarchicalController)
    assert isinstance(driver.planner, MCTSPlanner) and isinstance(driver.tracker, LQNGTracker)
    search = driver.planner
    assert search.iterations == 300 and search.params.horizon == 5
    assert search.rate_hz == 2.0 and isinstance(search.rate_hz, float)
    assert search.deviation_gain == 0.3 and search.hold_gain == 0.2
    assert search.pace_model and search.own_pace == 1.05  # every kart at its measured pace
    assert driver.tracker.params == dataclasses.replace(MCTS_TRACKING, horizon=6)
    assert driver.tracker.rules == MCTS_TRAFFIC
    rl = make_controller("mcts-rl")
    assert isinstance(rl, HierarchicalController) and isinstance(rl.planner, MCTSPlanner)
    assert rl.planner.deviation_gain == 0.1  # the racing line unless the search gains, as mcts-lqng's
    assert rl.planner.hold_gain is None  # every plan chosen afresh (mcts-lqng's pass commitment is its own)
    assert rl.planner.pace_model and rl.planner.own_pace == 1.0
    assert not rl.planner.planned_speeds_behind  # its KeepDistance filter keeps the distance
    narrow = make_controller("fixed-lqng", lqng_horizon_steps=9)
    assert isinstance(narrow, HierarchicalController) and isinstance(narrow.tracker, LQNGTracker)
    assert narrow.tracker.params.horizon == 9 and make_controller("fixed-lqng").tracker.params.horizon == 4  # type: ignore[attr-defined]
    for name in ("mcts-rl", "fixed-rl"):
        shielded = make_controller(
            name,
            speed_ceiling_margin_mps=2.0,
            keep_distance_lookahead_s=0.4,
            side_clearance_m=1.5,
            lane_limit_margin_m=0.3,
        )
        assert isinstance(shielded, HierarchicalController) and isinstance(shielded.tracker, RLTracker)
        ceiling, distance, lanes, alongside, recovery = shielded.tracker.filters
        assert isinstance(ceiling, LineSpeedCeiling) and ceiling.margin == 2.0
        assert isinstance(distance, KeepDistance) and distance.lookahead == 0.4
        assert isinstance(lanes, KeepToLaneLimit) and lanes.margin == 0.3
        assert isinstance(alongside, GiveRoomAlongside) and alongside.clearance == 1.5
        assert isinstance(recovery, RecoverFromStall)
    e2e = make_controller("e2e", keep_distance_lookahead_s=0.5)
    assert isinstance(e2e, E2EController)
    assert [type(f) for f in e2e.tracker.filters] == [
        KeepDistance,
        KeepToLaneLimit,
        GiveRoomAlongside,
        RecoverFromStall,
    ]
    assert e2e.tracker.filters[0].lookahead == 0.5  # type: ignore[attr-defined]
    fixed_rl = make_controller("fixed-rl", line_margin_m=1.5)
    assert isinstance(fixed_rl, HierarchicalController) and isinstance(fixed_rl.tracker, RLTracker)
    assert fixed_rl.tracker.filters[0].line_margin == 1.5  # type: ignore[attr-defined]
    slack = make_controller("mcts-rl", lane_change_slack=1, horizon=6)
    assert isinstance(slack, HierarchicalController) and isinstance(slack.planner, MCTSPlanner)
    assert slack.planner.lane_change_slack == 1 and slack.planner.params.horizon == 6
    fixed = make_controller("fixed-lqng", line_margin_m=1.5)
    assert isinstance(fixed, HierarchicalController) and isinstance(fixed.planner, FixedLinePlanner)
    assert fixed.planner.margin == 1.5
    follower = make_controller("lane-follower", acceleration_gain=2.0)
    assert isinstance(follower, LaneFollowerController) and follower.params.acceleration_gain == 2.0


def test_defaults_build_the_tuned_drivers() -> None:
    default = make_controller("mcts-lqng")
    assert isinstance(default, HierarchicalController) and isinstance(default.tracker, LQNGTracker)
    assert default.tracker.params == MCTS_TRACKING and default.tracker.rules == MCTS_TRAFFIC
    search = default.planner  # the search alone: no model of any other agent's code
    assert isinstance(search, MCTSPlanner) and search.params == GameParams()
    assert (search.iterations, search.rate_hz) == (2000, 1.0)
    fixed = make_controller("fixed-lqng")
    assert isinstance(fixed, HierarchicalController) and isinstance(fixed.tracker, LQNGTracker)
    assert fixed.tracker.params == FIXED_LINE_TRACKING and fixed.tracker.rules == FIXED_LINE_TRAFFIC
    e2e = make_controller("e2e")
    assert [type(f).__name__ for f in e2e.tracker.filters] == [  # type: ignore[attr-defined]
        "KeepDistance",
        "KeepToLaneLimit",
        "GiveRoomAlongside",
        "RecoverFromStall",
    ]


@pytest.mark.parametrize(
    ("overrides", "parameter_name", "message"),
    [
        ({"iterations": 0}, "iterations", "below its minimum 1"),
        ({"iterations": 1_000_000}, "iterations", "above its maximum"),
        ({"iterations": "2000"}, "iterations", "must be an int"),
        ({"iterations": 2000.0}, "iterations", "must be an int"),
        ({"iterations": True}, "iterations", "must be an int"),
        ({"planner_rate_hz": math.nan}, "planner_rate_hz", "finite"),
        ({"planner_rate_hz": math.inf}, "planner_rate_hz", "finite"),
        ({"planner_rate_hz": None}, "planner_rate_hz", "must be a float"),
        ({"search_depth": 3}, "search_depth", r"unknown \(known: iterations, horizon"),
    ],
)
def test_a_bad_parameter_is_refused_by_name(overrides: dict[str, object], parameter_name: str, message: str) -> None:
    with pytest.raises(ParameterError, match=message) as caught:
        validate_parameters("mcts-lqng", overrides)
    assert caught.value.controller == "mcts-lqng" and caught.value.parameter == parameter_name
    assert isinstance(caught.value, ValueError) and repr(parameter_name) in str(caught.value)
    with pytest.raises(ParameterError):
        make_controller("mcts-lqng", **overrides)


def test_a_parameter_error_crosses_a_process_boundary_whole() -> None:
    # a race's worker process pickles the error back to the tournament runner: it must arrive as itself
    with pytest.raises(ParameterError) as caught:
        validate_parameters("mcts-lqng", {"horizon": 0})
    copy_of = pickle.loads(pickle.dumps(caught.value))
    assert type(copy_of) is ParameterError and str(copy_of) == str(caught.value)
    assert (copy_of.controller, copy_of.parameter, copy_of.reason) == ("mcts-lqng", "horizon", caught.value.reason)


def test_an_unknown_controller_is_still_a_key_error() -> None:
    with pytest.raises(KeyError, match="unknown controller 'nope'"):
        validate_parameters("nope", {})
    with pytest.raises(KeyError, match="unknown controller 'nope'"):
        controller_factory("nope")


@given(data=hs.data())
def test_any_value_within_bounds_is_accepted_and_any_outside_refused(data: hs.DataObject) -> None:
    numeric = [(n, p) for n in controller_names() for p in REGISTRY[n].parameter_list if p.type in ("int", "float")]
    name, p = data.draw(hs.sampled_from(numeric))
    assert p.minimum is not None and p.maximum is not None
    if p.type == "int":
        inside: object = data.draw(hs.integers(math.ceil(p.minimum), int(p.maximum)))
        outside: object = data.draw(hs.integers(int(p.maximum) + 1) | hs.integers(max_value=int(p.minimum) - 1))
    else:
        inside = data.draw(hs.floats(p.minimum, p.maximum))
        outside = data.draw(hs.floats(min_value=p.maximum, exclude_min=True, allow_infinity=False))
    assert getattr(validate_parameters(name, {p.name: inside}), p.name) == inside
    with pytest.raises(ParameterError):
        validate_parameters(name, {p.name: outside})


def test_a_switch_takes_true_or_false_only() -> None:
    switches = [(n, p) for n in controller_names() for p in REGISTRY[n].parameter_list if p.type == "bool"]
    assert switches  # the RL agents' deterministic mode
    for name, p in switches:
        assert getattr(validate_parameters(name, {p.name: True}), p.name) is True
        with pytest.raises(ParameterError):
            validate_parameters(name, {p.name: 1})


def test_a_validated_factory_pickles_for_the_worker_processes() -> None:
    params = validate_parameters("mcts-lqng", {"iterations": 100})
    driver = pickle.loads(pickle.dumps(controller_factory("mcts-lqng", params)))()
    assert isinstance(driver, HierarchicalController) and isinstance(driver.planner, MCTSPlanner)
    assert driver.planner.iterations == 100
    for name in controller_names():
        assert pickle.loads(pickle.dumps(REGISTRY[name].factory))().name == name


class _Still(ConstantDriver):
    """A test-only driver without parameters: stands still."""

    name = "still"
    throttle = 0.0


def test_a_controller_without_a_parameter_dataclass_takes_none() -> None:
    spec: ControllerSpec[None] = ControllerSpec("still", "test-only", _Still)
    assert spec.parameters == {} and spec.parameter_list == ()
    assert spec.validate({}) is None and spec.factory_for(None) is _Still
    with pytest.raises(ParameterError, match="'speed' is unknown"):
        spec.validate({"speed": 1.0})


def test_parameters_of_reads_types_and_bounds_from_the_fields() -> None:
    @dataclasses.dataclass(frozen=True)
    class Tuning:
        gain: float = parameter(1.5, "how hard", unit="1/s", minimum=0.0, maximum=3.0)
        steps: int = 4
        verbose: bool = False

    assert parameters_of(Tuning) == (
        Parameter("gain", "float", 1.5, "how hard", "1/s", 0.0, 3.0),
        Parameter("steps", "int", 4),
        Parameter("verbose", "bool", False),
    )
    with pytest.raises(ValueError, match="minimum 2 > maximum 1"):
        parameter(1, minimum=2, maximum=1)


@pytest.mark.parametrize(
    ("agent", "name", "overrides"),
    [
        ("mcts-lqng", "mcts-lqng", {}),
        ("mcts-lqng:iterations=500", "mcts-lqng", {"iterations": 500}),
        (
            "fixed-lqng:lqng_horizon_steps=8:line_margin_m=2",
            "fixed-lqng",
            {"lqng_horizon_steps": 8, "line_margin_m": 2},
        ),
        ("fixed-lqng:line_margin_m=1.5@0.95", "fixed-lqng", {"line_margin_m": 1.5}),  # the pace is the kart's
        ("mcts-rl@0.9", "mcts-rl", {}),
        ("e2e:deterministic=false", "e2e", {"deterministic": False}),
        ("x:label=fast", "x", {"label": "fast"}),  # not JSON: kept as text (the parameter's check judges it)
    ],
)
def test_an_agent_string_is_a_name_and_its_parameters(agent: str, name: str, overrides: dict[str, object]) -> None:
    assert parse_agent(agent) == (name, overrides)


@pytest.mark.parametrize(
    ("agent", "error", "says"),
    [
        ("schumacher", KeyError, "unknown controller"),
        ("fixed-lqng:line_margin_m", ValueError, "is not KEY=VALUE"),
        ("fixed-lqng:=1", ValueError, "is not KEY=VALUE"),
        ("fixed-lqng:line_margin_m=0.8:line_margin_m=0.9", ValueError, "given twice"),
        ("fixed-lqng:line_margin_m=fast", ParameterError, "must be a float"),
        ("fixed-lqng@fast", ValueError, "is not a number"),
        ("fixed-lqng@1.2", ValueError, r"pace must be in \[0.5, 1\]"),
        ("fixed-lqng@0.3", ValueError, r"pace must be in \[0.5, 1\]"),
        ("mcts-lqng:horizon=17", ParameterError, "above its maximum"),
        ("mcts-lqng:temperature=3", ParameterError, "unknown"),
    ],
)
def test_a_bad_agent_string_says_what_is_wrong(agent: str, error: type[Exception], says: str) -> None:
    with pytest.raises(error, match=says):
        validate_agent(agent)


def test_an_agent_string_builds_the_controller_with_its_parameters() -> None:
    quick = make_agent("mcts-lqng:iterations=500:hold_gain_s=0")
    assert (quick.planner.iterations, quick.planner.hold_gain) == (500, 0.0)  # type: ignore[attr-defined]
    assert make_agent("mcts-lqng").planner.iterations == 2000  # type: ignore[attr-defined]
