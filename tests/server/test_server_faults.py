"""Faulty controllers never stall a race: one that raises, one that hangs, one that is too slow and one whose
reset fails each leave the tick running at 50 Hz; their karts brake, their faults are counted and shown.

The faulty drivers reach the server through ``create_app(controllers=...)``, never the public registry.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from support.live_server import LiveServer, server_settings, start_race, wait_for, wait_status

from controllers.base import Action, RaceContext
from controllers.registry import REGISTRY, ControllerSpec
from sim_core.observation import Observation

HANG_S = 0.3
HANG_FOR_S = 30.0  # [s] the hanger's hang (its thread is abandoned; a daemon, it does not keep the process)


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
    """Answers 20 decisions, then never returns."""

    name = "hanger"

    def __init__(self) -> None:
        self.calls = 0

    def act(self, observation: Observation) -> Action:
        """Stands still, then hangs."""
        self.calls += 1
        if self.calls > 20:
            time.sleep(HANG_FOR_S)
        return Action(0.0, 0.0)


class Sluggard(Raiser):
    """Takes 50 ms (2.5 ticks) per decision."""

    name = "sluggard"

    def act(self, observation: Observation) -> Action:
        """Stands still, late."""
        time.sleep(0.05)
        return Action(0.0, 0.0)


class BadReset(Raiser):
    """Cannot prepare for a race."""

    name = "bad-reset"

    def reset(self, context: RaceContext) -> None:
        """Fails."""
        raise RuntimeError("no track for me")


class NotANumber(Raiser):
    """Answers NaN steering (and infinite throttle) after 20 good decisions."""

    name = "nan"

    def __init__(self) -> None:
        self.calls = 0

    def act(self, observation: Observation) -> Action:
        """Drives, then answers what no kart can take."""
        self.calls += 1
        return Action(0.0, 1.0) if self.calls <= 20 else Action(float("nan"), float("inf"))


FAULTY = {
    cls.name: ControllerSpec(cls.name, f"test-only: {cls.__doc__}", cls)
    for cls in (Raiser, Hanger, Sluggard, BadReset, NotANumber)
}


@pytest.fixture(scope="module", params=[1, 0], ids=["controller-host", "threads"])
def live(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """A real-time server whose controllers run in a host process, or (0 hosts) in threads of the server."""
    db = tmp_path_factory.mktemp("faults") / "karting.db"
    settings = server_settings(
        db, speedup=1.0, controller_hang_s=HANG_S, controller_hold_s=0.3, controller_hosts=request.param
    )
    with LiveServer(settings, controllers={**REGISTRY, **FAULTY}) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


@pytest.fixture(scope="module")
def faulty_race(client: httpx.Client) -> Iterator[dict[str, Any]]:
    """One race: the lane follower (kart 0) against the raiser, the hanger, the sluggard, the bad reset and the
    NaN answerer (karts 1-5), followed until the hanger was given up and the lane follower passed three checkpoints."""
    names = ("lane-follower", "raiser", "hanger", "sluggard", "bad-reset", "nan")
    karts = [{"controller": name} for name in names]
    race = start_race(client, track="oval", laps=3, karts=karts)
    wait_status(client, race["id"], ("running",), 30)

    def follower_on_and_hanger_given_up() -> dict[str, Any] | None:
        detail: dict[str, Any] = client.get(f"/api/races/{race['id']}").json()
        passed = {s["index"]: s["checkpoints_passed"] for s in detail["standings"]}[0]
        return detail if passed >= 3 and detail["drivers"][2]["hangs"] else None

    wait_for(follower_on_and_hanger_given_up, 15, 0.1)
    ticks = client.get(f"/api/races/{race['id']}").json()["tick_stats"]["ticks"]
    start = time.monotonic()
    time.sleep(1.0)
    detail = client.get(f"/api/races/{race['id']}").json()
    rate = (detail["tick_stats"]["ticks"] - ticks) / (time.monotonic() - start)
    yield {"race": race, "detail": detail, "ticks_per_second": rate}
    client.post(f"/api/races/{race['id']}/stop")


def test_faulty_controllers_are_not_public(client: httpx.Client) -> None:
    listed = {c["name"] for c in client.get("/api/controllers").json()}
    assert "raiser" in listed  # this server was given them...
    assert not set(FAULTY) & set(REGISTRY)  # ...the registry was not


def test_the_tick_keeps_its_rate_whatever_the_controllers_do(faulty_race: dict[str, Any]) -> None:
    assert 40 <= faulty_race["ticks_per_second"] <= 60
    assert faulty_race["detail"]["tick_stats"]["overruns"] <= 5


def test_the_healthy_kart_drives_on(faulty_race: dict[str, Any]) -> None:
    detail = faulty_race["detail"]
    follower = detail["drivers"][0]
    assert follower["exceptions"] == 0 and follower["controller_faults"] <= 5 and not follower["braking"]
    passed = {s["index"]: s["checkpoints_passed"] for s in detail["standings"]}
    assert passed[0] >= 3 and all(passed[k] <= 0 for k in (1, 2, 3, 4, 5))


def test_a_raising_controller_brakes_its_kart_and_is_counted(faulty_race: dict[str, Any]) -> None:
    raiser = faulty_race["detail"]["drivers"][1]
    assert raiser["exceptions"] > 20 and raiser["controller_faults"] >= raiser["exceptions"]
    assert "ZeroDivisionError: raiser always fails" in raiser["last_error"]
    assert raiser["braking"] and not raiser["disabled"]
    standings = {s["index"]: s for s in faulty_race["detail"]["standings"]}
    assert standings[1]["controller_faults"] > 20  # shown in the standings (and every frame)


def test_a_hanging_controller_is_given_up(faulty_race: dict[str, Any]) -> None:
    hanger = faulty_race["detail"]["drivers"][2]
    assert hanger["disabled"] and hanger["hangs"] == 1 and hanger["braking"]
    assert f"act did not return within {HANG_S:g} s" in hanger["last_error"]


def test_a_slow_controller_misses_deadlines(faulty_race: dict[str, Any]) -> None:
    sluggard = faulty_race["detail"]["drivers"][3]
    assert sluggard["missed_deadlines"] > 20 and sluggard["hangs"] == 0 and not sluggard["disabled"]


def test_a_controller_whose_reset_fails_brakes_from_the_start(faulty_race: dict[str, Any]) -> None:
    bad = faulty_race["detail"]["drivers"][4]
    assert (
        bad["disabled"] and bad["exceptions"] == 1 and "reset raised RuntimeError: no track for me" in bad["last_error"]
    )


def test_a_controller_answering_nan_is_counted_and_its_kart_brakes(faulty_race: dict[str, Any]) -> None:
    nan = faulty_race["detail"]["drivers"][5]
    assert nan["exceptions"] > 20 and "non-finite action (nan, inf)" in nan["last_error"]
    assert nan["braking"] and not nan["disabled"]


def test_faults_are_in_the_result(client: httpx.Client, faulty_race: dict[str, Any]) -> None:
    race_id = faulty_race["race"]["id"]
    client.post(f"/api/races/{race_id}/stop")
    karts = client.get(f"/api/races/{race_id}/result").json()["karts"]
    assert karts[1]["controller_faults"] > 20 and "ZeroDivisionError" in karts[1]["last_error"]
    assert karts[2]["controller_faults"] >= 1 and karts[4]["controller_faults"] == 1
    assert karts[5]["exceptions"] > 20 and "non-finite action" in karts[5]["last_error"]
