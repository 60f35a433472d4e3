"""Driving a human kart over the websocket of a real server (real time, 50 Hz): the race waits for its driver's
view and counts down with nothing moving, the kart moves and turns, events are told, bad connections are refused
with 4xxx close codes, bad messages get an error and the connection and the race go on, a silent driver's kart
brakes to a stop."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import httpx
import pytest
import viser
from support.live_server import LiveServer, server_settings, start_race, wait_for, wait_status
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect
from websockets.sync.connection import Connection

DRIVE_TIMEOUT_S = 0.3
COUNTDOWN_S = 0.6
VIEW_READY_WAIT_S = 2.0
HUMAN_RACE = {
    "track": "oval",
    "laps": 3,
    "karts": [{"controller": "human", "name": "Ada"}, {"controller": "lane-follower"}],
}


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("drive") / "karting.db"
    settings = server_settings(
        db,
        speedup=1.0,
        drive_timeout_s=DRIVE_TIMEOUT_S,
        viewer_enabled=True,
        countdown_s=COUNTDOWN_S,
        view_ready_wait_s=VIEW_READY_WAIT_S,
    )
    with LiveServer(settings) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


@pytest.fixture
def race(client: httpx.Client) -> Iterator[dict[str, Any]]:
    """A human (kart 0) against the lane follower, stopped after the test."""
    created = start_race(client, **HUMAN_RACE)
    wait_status(client, created["id"], ("waiting",), 30)
    yield created
    client.post(f"/api/races/{created['id']}/stop")


def drive_url(
    live: LiveServer, race: dict[str, Any], kart: int = 0, token: str | None = None, view: str | None = None
) -> str:
    """The drive websocket of ``kart`` (with its own token unless one is given; ``view``: the view parameter)."""
    token = race["drive_tokens"].get(str(kart), "") if token is None else token
    url = f"{live.ws_url}/api/races/{race['id']}/drive?kart={kart}&token={token}"
    return url if view is None else f"{url}&view={view}"


class Driver:
    """A scripted driver: sends inputs at 50 Hz and keeps every message the server sends back."""

    def __init__(self, ws: Connection) -> None:
        self.ws = ws
        self.states: list[dict[str, Any]] = []
        self.errors: list[str] = []
        self.events: list[dict[str, Any]] = []
        self.seq = 0

    def drain(self, seconds: float = 0.0) -> None:
        """Read what arrives within ``seconds``."""
        until = time.monotonic() + seconds
        while True:
            try:
                message = json.loads(self.ws.recv(timeout=max(0.0, until - time.monotonic())))
            except TimeoutError:
                return
            if message["type"] == "state":
                self.states.append(message)
            elif message["type"] == "error":
                self.errors.append(message["error"])
            elif message["type"] == "event":
                self.events.append(message)

    def until(self, condition: Callable[[], object], timeout: float = 5.0) -> None:
        """Keep reading until ``condition()`` holds."""
        give_up = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < give_up, "the server did not answer in time"
            self.drain(0.005)

    def drive(self, steer: float, throttle: float, seconds: float) -> None:
        """Hold ``steer`` and ``throttle`` for ``seconds``, sending them 50 times a second."""
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            self.seq += 1
            self.ws.send(json.dumps({"steer": steer, "throttle": throttle, "seq": self.seq}))
            self.drain(0.02)

    @property
    def kart(self) -> dict[str, Any]:
        """The kart in the newest state."""
        kart: dict[str, Any] = self.states[-1]["kart"]
        return kart


def closed_with(url: str) -> tuple[int, str]:
    """Connect to ``url`` and return the close code and reason the server answers with."""
    with connect(url, open_timeout=10) as ws, pytest.raises(ConnectionClosed) as closed:
        while True:
            ws.recv(timeout=10)
    assert closed.value.rcvd is not None
    return closed.value.rcvd.code, closed.value.rcvd.reason


def test_a_driven_kart_moves_and_turns(live: LiveServer, client: httpx.Client, race: dict[str, Any]) -> None:
    assert race["status"] == "starting" and set(race["drive_tokens"]) == {"0"}
    assert race["karts"][0]["drive_url"] == f"/races/{race['id']}/drive?kart=0&token={race['drive_tokens']['0']}"
    with connect(drive_url(live, race), open_timeout=10) as ws:
        wait_status(client, race["id"], ("running",), 10)  # the race waited for its driver
        driver = Driver(ws)
        driver.drive(0.0, 1.0, 1.5)
        straight = driver.kart
        assert straight["speed"] > 3.0 and straight["name"] == "Ada" and straight["controller"] == "human"
        driver.drive(0.3, 0.5, 0.6)  # a radius of about 10 m: well clear of the wall
        turned = driver.kart
    turn = (turned["heading"] - straight["heading"] + math.pi) % (2 * math.pi) - math.pi
    assert turn > 0.15  # steer > 0 turns left (counter-clockwise)
    assert math.hypot(turned["x"] - straight["x"], turned["y"] - straight["y"]) > 3.0
    applied = [s["input_seq"] for s in driver.states if s["input_seq"] is not None]
    assert applied == sorted(applied) and applied[-1] >= driver.seq - 5
    assert not driver.errors


def test_inputs_are_reflected_within_two_ticks(live: LiveServer, client: httpx.Client, race: dict[str, Any]) -> None:
    with connect(drive_url(live, race), open_timeout=10) as ws:
        wait_status(client, race["id"], ("running",), 10)
        driver = Driver(ws)
        driver.drive(0.0, 0.5, 0.3)
        delays = []
        for seq in range(1000, 1010):
            driver.drain(0.0)
            sent_at_step = driver.states[-1]["step"]
            ws.send(json.dumps({"steer": 0.0, "throttle": 0.5, "seq": seq}))
            driver.until(lambda s=seq: any(m["input_seq"] == s for m in driver.states))  # type: ignore[misc]
            reflected = next(m for m in driver.states if m["input_seq"] == seq)
            delays.append(reflected["step"] - sent_at_step)
    # Applied at the next tick; one more tick of slack for a state message still in flight when it was sent. The
    # step it was sent at is the last state this client had read: a client descheduled on a shared 2-core host reads
    # it late now and then, so most inputs, not every one, are held to two ticks, and none may wait long.
    assert sum(delay <= 2 for delay in delays) >= 8 and max(delays) <= 5, delays


def test_bad_connections_are_refused_with_close_codes(
    live: LiveServer, client: httpx.Client, race: dict[str, Any]
) -> None:
    assert closed_with(drive_url(live, race, token="not-the-token")) == (4403, "wrong token")
    code, reason = closed_with(drive_url(live, race, kart=1, token="x"))
    assert code == 4400 and "not a human kart" in reason
    assert closed_with(f"{live.ws_url}/api/races/{race['id']}/drive?kart=abc&token=x")[0] == 4400
    assert closed_with(f"{live.ws_url}/api/races/{race['id']}/drive?kart=7&token=x")[0] == 4400
    assert closed_with(f"{live.ws_url}/api/races/nosuchrace/drive?kart=0&token=x")[0] == 4404
    code, reason = closed_with(drive_url(live, race, view="yes"))
    assert code == 4400 and reason.startswith("view:"), reason
    code, reason = closed_with(drive_url(live, race, view="2"))
    assert code == 4400 and reason.startswith("view:") and "1" in reason, reason
    with connect(drive_url(live, race), open_timeout=10) as first:
        code, reason = closed_with(drive_url(live, race))
        assert code == 4409 and "already has a driver" in reason
        first.send(json.dumps({"steer": 0.0, "throttle": 1.0}))
        assert json.loads(first.recv(timeout=5))["type"] == "state"  # the first driver keeps the kart
    wait_for(lambda: not client.get(f"/api/races/{race['id']}").json()["drivers"][0]["driver_connected"], 5)
    with connect(drive_url(live, race), open_timeout=10) as again:  # a driver may come back
        assert json.loads(again.recv(timeout=5))["type"] == "state"
    client.post(f"/api/races/{race['id']}/stop")
    code, reason = closed_with(drive_url(live, race))
    assert code == 4410 and "over" in reason


def test_bad_messages_get_an_error_and_the_race_goes_on(
    live: LiveServer, client: httpx.Client, race: dict[str, Any]
) -> None:
    bad = {
        "not json": "Invalid JSON",
        '{"steer": 1.5, "throttle": 0}': "steer: Input should be less than or equal to 1",
        '{"steer": NaN, "throttle": 0}': "steer: Input should be a finite number",
        '{"steer": 0, "throttle": -Infinity}': "throttle: Input should be a finite number",
        '{"steer": 0}': "throttle: Field required",
        '{"steer": 0, "throttle": 0, "boost": 1}': "boost: Extra inputs are not permitted",
        "[0.1, 0.2]": "Input should be an object",
        "x" * 3000: "Invalid JSON",
        '{"steer": 0, "throttle": 0, "seq": -1}': "seq: Input should be greater than or equal to 0",
        '{"type": "redy"}': "type: Input should be 'ready'",
        '{"type": "ready", "steer": 0}': "steer: Extra inputs are not permitted",
    }
    with connect(drive_url(live, race), open_timeout=10) as ws:
        wait_status(client, race["id"], ("running",), 10)
        driver = Driver(ws)
        for message, says in bad.items():
            ws.send(message)
            driver.until(lambda: driver.errors)
            error = driver.errors.pop()
            assert says in error, (message, error)
        ws.send(json.dumps({"steer": 0.1, "throttle": 0.8, "seq": 42}))
        driver.until(lambda: any(s["input_seq"] == 42 for s in driver.states))
    before = client.get(f"/api/races/{race['id']}").json()
    time.sleep(0.3)
    after = client.get(f"/api/races/{race['id']}").json()
    assert after["status"] == "running" and after["step"] > before["step"]


def test_a_silent_driver_brakes_to_a_stop_without_reversing(
    live: LiveServer, client: httpx.Client, race: dict[str, Any]
) -> None:
    with connect(drive_url(live, race), open_timeout=10) as ws:
        wait_status(client, race["id"], ("running",), 10)
        driver = Driver(ws)
        driver.drive(0.0, 1.0, 1.5)
        fast = driver.kart["speed"]
        assert fast > 4.0 and not driver.states[-1]["braking"]
        silent_from = len(driver.states)
        driver.drain(DRIVE_TIMEOUT_S + 0.2)  # silence
        # the states read may lag the race on a loaded machine: judge from the first one that brakes
        driver.until(lambda: driver.states[-1]["braking"], 10)
        onset = next(i for i in range(silent_from, len(driver.states)) if driver.states[i]["braking"])
        assert driver.states[onset]["kart"]["speed"] >= 0.5 * fast  # it was still going when the brakes came on
        driver.drain(fast / 6.0 + 1.0)  # the paper kart brakes at 6 m/s^2
        assert driver.kart["speed"] < driver.states[onset]["kart"]["speed"]
    speeds = [s["kart"]["speed"] for s in driver.states[-10:]]
    assert all(-0.05 <= v < 0.2 for v in speeds), speeds
    assert client.get(f"/api/races/{race['id']}").json()["drivers"][0]["braking"]


def test_the_race_has_a_live_3d_view(live: LiveServer, client: httpx.Client, race: dict[str, Any]) -> None:
    assert race["viewer_url"] == f"/races/{race['id']}/viewer/"
    page = client.get(race["viewer_url"])
    assert page.status_code == 200 and "<html" in page.text.lower()
    url = f"{live.ws_url}/races/{race['id']}/viewer"
    with connect(url, subprotocols=[f"viser-v{viser.__version__}"], open_timeout=10, max_size=None) as ws:  # type: ignore[list-item]
        assert isinstance(ws.recv(timeout=10), bytes)  # the relayed scene


# ---------------------------------------------------------------------------------------------- a fair start
def status_of(client: httpx.Client, race: dict[str, Any]) -> str:
    status: str = client.get(f"/api/races/{race['id']}").json()["status"]
    return status


def test_the_race_waits_for_the_view_then_counts_down_with_nothing_moving(
    live: LiveServer, client: httpx.Client, race: dict[str, Any]
) -> None:
    # read only up to the start: the frames left unread hold the close handshake, so the close is not waited for
    telemetry = connect(f"{live.ws_url}/api/races/{race['id']}/telemetry", open_timeout=10, close_timeout=1)
    with telemetry, connect(drive_url(live, race, view="1"), open_timeout=10) as ws:
        driver = Driver(ws)
        driver.drive(0.0, 1.0, 0.5)  # throttle held while the view loads
        assert status_of(client, race) == "waiting"  # connected, but the view is not ready
        assert driver.states[-1]["waiting_for"] == ["Ada"] and driver.states[-1]["status"] == "waiting"
        ws.send(json.dumps({"type": "ready"}))
        give_up = time.monotonic() + 10  # the server takes the view's "ready" within a tick, later when loaded
        while driver.states[-1]["waiting_for"]:
            assert time.monotonic() < give_up, "the view's ready was never taken"
            driver.drive(0.0, 1.0, 0.1)
        driver.until(lambda: driver.states[-1]["status"] == "running", COUNTDOWN_S + 5)
        driver.drive(0.0, 1.0, 1.0)
        frames: list[dict[str, Any]] = []
        while len(frames) < 200 and (not frames or frames[-1]["status"] != "running" or frames[-1]["step"] < 20):
            frames.append(json.loads(telemetry.recv(timeout=5)))
    counting = [s for s in driver.states if s["status"] == "countdown"]
    assert len(counting) >= 3, "the countdown was not published"
    left = [s["countdown"] for s in counting]
    assert left == sorted(left, reverse=True) and left[0] <= COUNTDOWN_S and left[-1] > 0
    grid = driver.states[0]["kart"]
    before_go = [s for s in driver.states if s["status"] in ("waiting", "countdown")]
    assert all(s["step"] == 0 and (s["kart"]["x"], s["kart"]["y"]) == (grid["x"], grid["y"]) for s in before_go)
    assert all(s["countdown"] is None for s in driver.states if s["status"] != "countdown")
    assert driver.kart["speed"] > 2.0  # then the held throttle moves the kart
    assert [e["text"] for e in driver.events if e["kind"] == "start"] == ["Go!"]
    # telemetry shows the countdown too, and no kart (the AI included) moved before the start
    counted = [f for f in frames if f["status"] == "countdown"]
    assert counted and all(f["countdown"] > 0 for f in counted)
    first = {k["index"]: (k["x"], k["y"]) for k in frames[0]["karts"]}
    assert all({k["index"]: (k["x"], k["y"]) for k in f["karts"]} == first for f in frames if f["step"] == 0)
    assert frames[-1]["countdown"] is None and frames[-1]["karts"][1]["speed"] > 0.0


def test_a_view_that_never_loads_delays_the_start_only_so_long(
    live: LiveServer, client: httpx.Client, race: dict[str, Any]
) -> None:
    with connect(drive_url(live, race, view="1"), open_timeout=10) as ws:
        driver = Driver(ws)
        connected = time.monotonic()
        driver.until(lambda: bool(driver.states) and driver.states[-1]["status"] == "countdown", 10)
        waited = time.monotonic() - connected
    assert VIEW_READY_WAIT_S - 0.3 < waited < VIEW_READY_WAIT_S + 2.0


# ---------------------------------------------------------------------------------------------- a field
FIELD_RACE = {
    "track": "oval",
    "laps": 1,
    "karts": [
        {"controller": "human", "name": "Ada", "team": "Red"},
        {"controller": "mcts-lqng", "name": "Tactical", "team": "Blue"},
        {"controller": "fixed-rl", "name": "Policy", "team": "Red"},
        {"controller": "e2e", "name": "End-to-end", "team": "Blue"},
    ],
}


def test_a_person_drives_in_a_four_kart_field_of_teams(live: LiveServer, client: httpx.Client) -> None:
    """A human among three AI karts of two teams, at real time: every kart drives off the grid, the tactical
    planner's plans arrive, no driver fails, and the stopped race keeps every kart and its team."""
    race = start_race(client, **FIELD_RACE)
    try:
        assert set(race["drive_tokens"]) == {"0"}
        with connect(drive_url(live, race), open_timeout=10) as ws:
            wait_status(client, race["id"], ("running",), 30)
            driver = Driver(ws)
            driver.drive(0.0, 0.8, 4.0)  # down the start straight
            assert driver.kart["speed"] > 3.0 and not driver.errors
            detail = client.get(f"/api/races/{race['id']}").json()
    finally:
        client.post(f"/api/races/{race['id']}/stop")
    drivers = {d["name"]: d for d in detail["drivers"]}
    assert drivers["Tactical"]["plans_applied"] >= 2  # 1 Hz plans, in a field of four
    # no driver failed or was disabled (a missed 50 Hz deadline is the machine's load, not the field's)
    failed = [d for d in drivers.values() if d["exceptions"] or d["hangs"] or d["planner_faults"] or d["disabled"]]
    assert not failed, failed
    on_the_grid = [s["name"] for s in detail["standings"] if s["checkpoints_passed"] < 1]
    assert len(detail["standings"]) == 4 and not on_the_grid, f"still on the grid: {on_the_grid}"
    stored = client.get(f"/api/races/{race['id']}").json()
    assert stored["status"] == "stopped"
    assert [(k["name"], k["team"]) for k in stored["karts"]] == [(k["name"], k["team"]) for k in FIELD_RACE["karts"]]
