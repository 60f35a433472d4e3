"""Faulty controllers never stall a race: one that raises, one that hangs, one that is too slow and one whose
reset fails each leave the tick running at 50 Hz; their karts brake, their faults are counted and shown.

The faulty drivers reach the server through ``create_app(controllers=...)``, never the public registry.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from test_server_harness import LiveServer, server_settings, start_race, wait_for, wait_status

from controllers.base import Action, RaceContext
from controllers.registry import REGISTRY, ControllerSpec
from sim_core.observation import Observation

HANG_S = 0.3
RELEASE = threading.Event()  # set at the end so the hung threads finish


class Raiser:
    """Raises on every decision."""

    name = "raiser"
    rate_hz = 50.0

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def act(self, observation: Observation) -> Action:
        """Fails."""
        raise ZeroDivisionError("raiser always fails")


class Hanger(Raiser):
    """Drives for 20 decisions, then never returns."""

    name = "hanger"

    def __init__(self) -> None:
        self.calls = 0

    def act(self, observation: Observation) -> Action:
        """Full throttle, then a hang."""
        self.calls += 1
        if self.calls > 20:
            RELEASE.wait(60)
        return Action(0.0, 1.0)


class Sluggard(Raiser):
    """Takes 50 ms (2.5 ticks) per decision."""

    name = "sluggard"

    def act(self, observation: Observation) -> Action:
        """Full throttle, late."""
        time.sleep(0.05)
        return Action(0.0, 1.0)


class BadReset(Raiser):
    """Cannot prepare for a race."""

    name = "bad-reset"

    def reset(self, context: RaceContext) -> None:
        """Fails."""
        raise RuntimeError("no track for me")


FAULTY = {
    cls.name: ControllerSpec(cls.name, f"test-only: {cls.__doc__}", cls) for cls in (Raiser, Hanger, Sluggard, BadReset)
}


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("faults") / "karting.db"
    settings = server_settings(db, speedup=1.0, controller_hang_s=HANG_S, controller_hold_s=0.3)
    with LiveServer(settings, controllers={**REGISTRY, **FAULTY}) as server:
        yield server
    RELEASE.set()


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


def race_against_lane_follower(client: httpx.Client, controller: str) -> dict[str, Any]:
    """A running race: ``controller`` (kart 0) against the lane follower (kart 1)."""
    race = start_race(client, track="oval", laps=3, karts=[{"controller": controller}, {"controller": "lane-follower"}])
    return wait_status(client, race["id"], ("running",), 30)


def standings_when_kart_1_passed(client: httpx.Client, race_id: str, checkpoints: int) -> dict[int, Any]:
    """The standings (by kart) once kart 1 has passed ``checkpoints`` checkpoints."""

    def passed() -> dict[int, Any] | None:
        standings = {s["index"]: s for s in client.get(f"/api/races/{race_id}").json()["standings"]}
        return standings if standings[1]["checkpoints_passed"] >= checkpoints else None

    result: dict[int, Any] = wait_for(passed, 10, 0.1)
    return result


def ticks_per_second(client: httpx.Client, race_id: str, seconds: float = 1.0) -> float:
    """Ticks the race ran per wall-clock second over ``seconds``."""
    first = client.get(f"/api/races/{race_id}").json()["tick_stats"]["ticks"]
    start = time.monotonic()
    time.sleep(seconds)
    last = client.get(f"/api/races/{race_id}").json()["tick_stats"]["ticks"]
    return (last - first) / (time.monotonic() - start)


def test_faulty_controllers_are_not_public(client: httpx.Client) -> None:
    listed = {c["name"] for c in client.get("/api/controllers").json()}
    assert "raiser" in listed  # this server was given them...
    assert not set(FAULTY) & set(REGISTRY)  # ...the registry was not


def test_a_raising_controller_brakes_its_kart_and_is_counted(client: httpx.Client) -> None:
    race = race_against_lane_follower(client, "raiser")
    assert 40 <= ticks_per_second(client, race["id"]) <= 60
    detail = client.get(f"/api/races/{race['id']}").json()
    raiser, follower = detail["drivers"]
    assert raiser["exceptions"] > 20 and raiser["controller_faults"] >= raiser["exceptions"]
    assert "ZeroDivisionError: raiser always fails" in raiser["last_error"]
    assert raiser["braking"] and not raiser["disabled"]
    assert follower["controller_faults"] <= 5 and follower["exceptions"] == 0
    assert {s["index"]: s for s in detail["standings"]}[0]["controller_faults"] > 20  # shown in the standings too
    assert standings_when_kart_1_passed(client, race["id"], 3)[0]["checkpoints_passed"] == 0
    client.post(f"/api/races/{race['id']}/stop")
    result = client.get(f"/api/races/{race['id']}/result").json()
    assert result["karts"][0]["controller_faults"] > 20


def test_a_hanging_controller_is_given_up_and_the_others_drive_on(client: httpx.Client) -> None:
    race = race_against_lane_follower(client, "hanger")

    def hung() -> dict[str, Any] | None:
        detail: dict[str, Any] = client.get(f"/api/races/{race['id']}").json()
        return detail if detail["drivers"][0]["hangs"] else None

    detail = wait_for(hung, 5)
    hanger = detail["drivers"][0]
    assert hanger["disabled"] and hanger["hangs"] == 1 and "did not return" in hanger["last_error"]
    assert 40 <= ticks_per_second(client, race["id"]) <= 60
    assert standings_when_kart_1_passed(client, race["id"], 3)[1]["controller_faults"] <= 5
    assert client.get(f"/api/races/{race['id']}").json()["drivers"][0]["braking"]
    client.post(f"/api/races/{race['id']}/stop")


def test_a_slow_controller_misses_deadlines_but_never_delays_the_tick(client: httpx.Client) -> None:
    race = race_against_lane_follower(client, "sluggard")
    assert 40 <= ticks_per_second(client, race["id"]) <= 60
    detail = client.get(f"/api/races/{race['id']}").json()
    sluggard = detail["drivers"][0]
    assert sluggard["missed_deadlines"] > 20 and sluggard["hangs"] == 0
    assert detail["tick_stats"]["overruns"] <= 2
    client.post(f"/api/races/{race['id']}/stop")


def test_a_controller_whose_reset_fails_brakes_from_the_start(client: httpx.Client) -> None:
    race = race_against_lane_follower(client, "bad-reset")
    bad = client.get(f"/api/races/{race['id']}").json()["drivers"][0]
    assert bad["disabled"] and bad["exceptions"] == 1 and "no track for me" in bad["last_error"]
    assert standings_when_kart_1_passed(client, race["id"], 3)[0]["checkpoints_passed"] == 0
    client.post(f"/api/races/{race['id']}/stop")
