"""The server's typed seams without a server: result records round-trip through JSON (and older ones load), the
API's result and frame models follow the types they show, worker-process messages pickle and match, and race
requests' controller parameters are checked (422 entries naming the parameter)."""

from __future__ import annotations

import json
import pickle
from dataclasses import dataclass, fields
from typing import Any

import pytest
from fastapi.exceptions import RequestValidationError

from controllers.base import Action, RaceContext
from controllers.parameters import parameter
from controllers.registry import REGISTRY, ControllerSpec
from server.controller_params import build_controller, check_params, resolve_factory
from server.host_messages import Act, ActionOut, DeliverPlan, Open, PlannerSetup, Ready, RequestPlan
from server.models import FrameMessage, KartResultOut, RaceIn, ResultOut
from server.race_config import KartEntry
from server.results import DriverFaults, KartRecord, RaceRecord, race_record, record_name
from server.routes.races import race_config
from server.status import LIVE_STATUSES, OVER_STATUSES, RaceStatus
from sim_core.observation import Observation, observe
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import KartResult, World
from web.frame import RaceFrame


def finished_record() -> RaceRecord:
    world = World(get_track("oval"), 1, 2, SimParams(), laps=1)
    world.reset()
    for _ in range(200):
        world.step()
    karts = (KartEntry(0, "A", "lane-follower"), KartEntry(1, "B", "fixed-lqng", {"iterations": 10}))
    faults = (DriverFaults(), DriverFaults(exceptions=2, missed_deadlines=3, last_error="boom"))
    return race_record("r1", RaceStatus.STOPPED, "oval", 1, world.result(0), karts, faults)


def test_a_record_round_trips_through_json() -> None:
    record = finished_record()
    stored = json.loads(json.dumps(record.to_json()))
    assert RaceRecord.from_json(stored) == record
    kart = stored["karts"][1]
    assert kart["index"] == 1 and kart["controller_faults"] == 5 and kart["last_error"] == "boom"
    assert "kart" not in kart and "laps_completed" not in kart and kart["laps"] == 0


def test_a_record_has_every_referee_field_under_its_api_name() -> None:
    kart = finished_record().to_json()["karts"][0]
    assert {record_name(f.name) for f in fields(KartResult)} <= set(kart)
    assert {f.name for f in fields(DriverFaults)} <= set(kart)
    assert set(kart) == set(KartResultOut.model_fields)  # the API model is derived the same way


def test_a_record_from_an_older_version_loads_with_defaults() -> None:
    stored = finished_record().to_json()
    for kart in stored["karts"]:
        for name in ("buffer_violations", "delta_r", "plans_applied", "disabled"):
            del kart[name]
    record = RaceRecord.from_json(stored)
    kart = record.karts[1]
    assert kart.referee.buffer_violations is None and kart.referee.delta_r is None
    assert kart.faults.plans_applied == 0 and not kart.faults.disabled and kart.faults.exceptions == 2
    shown = ResultOut.model_validate(record.to_json()).model_dump()
    assert shown["karts"][1]["buffer_violations"] is None and shown["karts"][1]["controller_faults"] == 5


def test_statuses_are_one_vocabulary() -> None:
    assert set(RaceStatus) == LIVE_STATUSES | OVER_STATUSES and not LIVE_STATUSES & OVER_STATUSES
    assert RaceStatus.RUNNING.live and not RaceStatus.FINISHED.live
    assert json.dumps({"status": RaceStatus.ABORTED}) == '{"status": "aborted"}'


def test_the_frame_message_is_a_race_frame_with_its_type() -> None:
    assert set(FrameMessage.model_fields) == {"type", *(f.name for f in fields(RaceFrame))}


def test_worker_messages_pickle_and_match() -> None:
    track = get_track("oval")
    world = World(track, 1, 2, SimParams(), laps=1)
    observation = observe(world, 0)[0]
    context = RaceContext(track, SimParams().kart, 0, 2, world.lane_change_limit, 0)
    messages = [
        Open(3, "fixed-lqng", REGISTRY["fixed-lqng"].factory, context),
        Act(3, 17, observation),
        RequestPlan("race/0", observation, PlannerSetup(REGISTRY["fixed-lqng"].factory, context)),
        ActionOut(3, 17, 0.25, -1.0),
        Ready(3),
    ]
    for message in messages:
        copy = pickle.loads(pickle.dumps(message))
        assert type(copy) is type(message)
        match copy:
            case Act(kart, step, obs):
                assert (kart, step) == (3, 17) and isinstance(obs, Observation)
            case ActionOut(kart, step, steer, throttle):
                assert (kart, step, steer, throttle) == (3, 17, 0.25, -1.0)
            case Open() | RequestPlan() | Ready() | DeliverPlan():
                pass
            case _:
                raise AssertionError(copy)


# ---------------------------------------------------------------------------------------------- parameters
class Cruiser:
    """Holds the wheel straight at a set throttle."""

    name = "cruiser"
    rate_hz = 50.0

    def __init__(self, throttle: float = 0.5, laps_of_honour: int = 1) -> None:
        self.throttle = throttle
        self.laps_of_honour = laps_of_honour

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def act(self, observation: Observation) -> Action:
        """Straight on."""
        return Action(0.0, self.throttle)


@dataclass(frozen=True)
class CruiserParams:
    """The cruiser's public parameters."""

    throttle: float = parameter(0.5, "throttle it holds", minimum=0.01, maximum=1.0)
    laps_of_honour: int = parameter(1, "laps it keeps going after the finish", minimum=0, maximum=5)


def build_cruiser(params: CruiserParams) -> Cruiser:
    """A cruiser with ``params``."""
    return Cruiser(params.throttle, params.laps_of_honour)


CRUISER = ControllerSpec("cruiser", "test-only", Cruiser, CruiserParams, build_cruiser)
CATALOGUE = {**REGISTRY, "cruiser": CRUISER}


def problems(spec: ControllerSpec, **params: Any) -> dict[str, str]:
    return {p.name: p.message for p in check_params(spec, params)}


def test_parameters_are_checked_against_the_registry() -> None:
    assert problems(CRUISER, throttle=0.2, laps_of_honour=3) == {}
    assert problems(CRUISER, throttle=1) == {}  # an integer is a number
    found = problems(CRUISER, grip=2.0, throttle=-0.1, laps_of_honour=1.5)
    assert "'grip' is unknown" in found["grip"] and "laps_of_honour" in found["grip"]
    assert "= -0.1 is below its minimum" in found["throttle"]
    assert "must be an int, got 1.5" in found["laps_of_honour"]
    assert "must be a float" in problems(CRUISER, throttle="fast")["throttle"]
    assert "must be a float" in problems(CRUISER, throttle=True)["throttle"]
    assert "must be finite" in problems(CRUISER, throttle=float("nan"))["throttle"]
    # the built-in controllers take their registered parameters, within bounds
    assert problems(REGISTRY["mcts-lqng"], iterations=100) == {}
    assert "below its minimum" in problems(REGISTRY["mcts-lqng"], iterations=-5)["iterations"]
    assert "unknown" in problems(REGISTRY["lane-follower"], iterations=100)["iterations"]


def test_a_controller_is_built_with_its_parameters() -> None:
    cruiser = build_controller(resolve_factory(CRUISER, {"throttle": 0.2}))
    assert isinstance(cruiser, Cruiser) and cruiser.throttle == 0.2 and cruiser.laps_of_honour == 1


def race_errors(**body: Any) -> list[dict[str, Any]]:
    request = RaceIn.model_validate({"track": "oval", **body})
    with pytest.raises(RequestValidationError) as raised:
        race_config(request, CATALOGUE, 20)
    return list(raised.value.errors())


def test_race_requests_name_the_bad_parameter() -> None:
    errors = race_errors(karts=[{"controller": "lane-follower"}, {"controller": "cruiser", "params": {"x": 1}}])
    assert [e["loc"] for e in errors] == [("body", "karts", 1, "params", "x")]
    errors = race_errors(karts=[{"controller": "cruiser", "params": {"throttle": 0}}])
    assert errors[0]["loc"] == ("body", "karts", 0, "params", "throttle") and "below its minimum" in errors[0]["msg"]
    errors = race_errors(karts=[{"controller": "human", "params": {"throttle": 1}}])
    assert errors[0]["loc"] == ("body", "karts", 0, "params") and "no parameters" in errors[0]["msg"]
    config = race_config(
        RaceIn.model_validate({"track": "oval", "karts": [{"controller": "cruiser", "params": {"throttle": 0.2}}]}),
        CATALOGUE,
        20,
    )
    assert config.karts == (KartEntry(0, "cruiser 1", "cruiser", {"throttle": 0.2}),)


def test_kart_records_know_nothing_of_the_kart_result_field_list() -> None:
    record = finished_record().karts[0]
    assert isinstance(record, KartRecord) and isinstance(record.referee, KartResult)
    assert KartRecord.from_json(record.to_json()) == record
