"""The server asks drivers what they can do, not what they are: a driver that plans off the tick but is no
``HierarchicalController`` (the shape of an RL tracker composed with a planner) gets its plans from the planner
workers, and a race request's controller parameters reach the controller wherever it runs (controller host
process or thread); a bad parameter is a 422 naming it."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import httpx
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_for, wait_status

from controllers.base import Action, HighLevelPlanner, PlanningDriver, RaceContext
from controllers.parameters import parameter
from controllers.plan import Plan
from controllers.registry import REGISTRY, ControllerSpec
from sim_core.observation import Observation


class ComposedDriver:
    """A planning driver of its own making: the registry's fixed-line planner and a tracker that holds the wheel
    straight at ``throttle`` once it has a plan (and waits for one before)."""

    name = "composed"
    rate_hz = 50.0
    plan_latency = 0.1

    def __init__(self, throttle: float = 0.5) -> None:
        self.planner: HighLevelPlanner = REGISTRY["fixed-lqng"].factory().planner  # type: ignore[attr-defined]
        self.throttle = throttle
        self.plans_applied = 0
        self.active_plan: Plan | None = None
        self._next_request = 0.0

    def reset(self, context: RaceContext) -> None:
        """Reset the planner; forget plans."""
        self.planner.reset(context)
        self.active_plan = None
        self.plans_applied = 0
        self._next_request = 0.0

    def wants_plan(self, time: float) -> bool:
        """At the planner's rate."""
        return time >= self._next_request - 1e-9

    def mark_plan_requested(self, time: float) -> None:
        """The next plan is due one planner period later."""
        self._next_request = time + 1.0 / self.planner.rate_hz

    def deliver(self, plan: Plan) -> None:
        """Make ``plan`` the active plan."""
        self.active_plan = plan
        self.plans_applied += 1

    def track(self, observation: Observation) -> Action:
        """Straight on at the set throttle, once planned."""
        return Action(0.0, self.throttle if self.active_plan is not None else 0.0)

    def act(self, observation: Observation) -> Action:
        """Headless races: plan in line."""
        if self.wants_plan(observation.time):
            self.mark_plan_requested(observation.time)
            self.deliver(self.planner.plan(observation))
        return self.track(observation)


@dataclass(frozen=True)
class ComposedParams:
    """The composed driver's one public parameter."""

    throttle: float = parameter(0.5, "throttle held once it has a plan", minimum=0.01, maximum=1.0)


def build_composed(params: ComposedParams) -> ComposedDriver:
    """A composed driver with ``params`` (module level: the registry's factories are pickled to workers)."""
    return ComposedDriver(params.throttle)


COMPOSED = ControllerSpec(
    "composed",
    "test-only: plans off the tick, no HierarchicalController",
    ComposedDriver,
    ComposedParams,
    build_composed,
)


def test_the_composed_driver_has_the_capability() -> None:
    assert isinstance(ComposedDriver(), PlanningDriver)


@pytest.fixture(scope="module", params=[1, 0], ids=["controller-host", "threads"])
def live(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("capabilities") / "karting.db"
    settings = server_settings(db, speedup=5.0, controller_hosts=request.param)
    with LiveServer(settings, controllers={**REGISTRY, "composed": COMPOSED}) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


def test_a_planning_driver_of_any_class_gets_plans_and_its_parameters(client: httpx.Client) -> None:
    karts = [{"controller": "composed", "params": {"throttle": 0.3}}, {"controller": "lane-follower"}]
    race = start_race(client, track="oval", laps=1, karts=karts)
    assert race["karts"][0]["params"] == {"throttle": 0.3}
    wait_status(client, race["id"], ("running",), 30)

    def planned_twice() -> bool:
        return client.get(f"/api/races/{race['id']}").json()["drivers"][0]["plans_applied"] >= 2

    wait_for(planned_twice, 30, 0.1)
    client.post(f"/api/races/{race['id']}/stop")
    result = client.get(f"/api/races/{race['id']}/result").json()
    kart = result["karts"][0]
    # no errors (a missed deadline is the loaded machine's, not the driver's: the tick never waits for it)
    assert kart["plans_applied"] >= 2 and kart["exceptions"] == kart["hangs"] == kart["planner_faults"] == 0
    replay = client.get(f"/api/races/{race['id']}/replay").json()
    assert {p["kart"] for p in replay["plans"]} == {0}  # only the composed driver plans
    throttles = {round(step[0][5], 6) for step in replay["poses"]}
    # its own parameter, in the process that runs it (never the default 0.5; 0 and +-1 are waiting and braking)
    assert 0.3 in throttles and throttles <= {0.0, 0.3, -1.0, 1.0}


def test_a_bad_parameter_is_a_422_naming_it(client: httpx.Client) -> None:
    karts = [{"controller": "composed", "params": {"throttle": -1, "boost": 2}}]
    response = client.post("/api/races", json={"track": "oval", "karts": karts})
    assert response.status_code == 422
    errors = {tuple(e["loc"]): e["msg"] for e in response.json()["detail"]}
    assert "below its minimum" in errors[("body", "karts", 0, "params", "throttle")]
    assert "'boost' is unknown" in errors[("body", "karts", 0, "params", "boost")]
