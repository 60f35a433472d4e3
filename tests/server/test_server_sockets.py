"""The edge of every websocket, on a real server: any malformed connection parameter is refused with 4400 and a
reason (never an exception), a message over a socket's limit closes it with 1009, the read-only telemetry socket
drains what it is sent and answers a client's close, and binary frames are read like text."""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator
from typing import Any
from urllib.parse import quote, urlencode

import httpx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support.live_server import LiveServer, server_settings, start_race, wait_status
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from server.routes.drive import MAX_MESSAGE_BYTES as DRIVE_LIMIT
from server.routes.telemetry import MAX_MESSAGE_BYTES as TELEMETRY_LIMIT

SERVER_LIMIT = 64 * 1024  # [bytes] this server's ws_max_message_bytes
VALID_KARTS = {str(k) for k in range(8)}


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("sockets") / "karting.db"
    settings = server_settings(db, speedup=1.0, human_wait_s=600.0, ws_max_message_bytes=SERVER_LIMIT)
    with LiveServer(settings) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


@pytest.fixture(scope="module")
def race(client: httpx.Client) -> Iterator[dict[str, Any]]:
    """A human race (kart 0) against the lane follower, waiting for its driver for the whole module."""
    created = start_race(client, track="oval", laps=1, karts=[{"controller": "human"}, {"controller": "lane-follower"}])
    wait_status(client, created["id"], ("waiting",), 60)
    yield created
    client.post(f"/api/races/{created['id']}/stop")


@pytest.fixture
def no_server_errors(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    """Fails the test if the server logged an error (an unhandled exception in a handler logs one)."""
    with caplog.at_level(logging.WARNING):
        yield
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert not errors, [r.getMessage() for r in errors]


def close_of(url: str, *messages: str | bytes) -> tuple[int, str]:
    """Connect to ``url``, send ``messages``, read until the server closes; its close code and reason."""
    with connect(url, open_timeout=10, max_size=None) as ws, pytest.raises(ConnectionClosed) as closed:
        for message in messages:
            ws.send(message)
        while True:
            ws.recv(timeout=10)
    assert closed.value.rcvd is not None, "the server dropped the connection without a close frame"
    return closed.value.rcvd.code, closed.value.rcvd.reason


def drive_url(live: LiveServer, race_id: str, query: str) -> str:
    return f"{live.ws_url}/api/races/{quote(race_id, safe='')}/drive?{query}"


@pytest.mark.parametrize(
    ("query", "says"),
    [
        ("kart=%C2%B2&token=x", "kart"),  # a superscript two: str.isdigit() says yes, int() says no
        ("kart=" + "9" * 5000 + "&token=x", "kart"),
        ("kart=-1&token=x", "kart"),
        ("kart=8&token=x", "kart"),
        ("kart=1.5&token=x", "kart"),
        ("kart=&token=x", "kart"),
        ("token=x", "kart: Field required"),
        ("kart=0", "token: Field required"),
        ("kart=0&token=", "token"),
        ("kart=0&token=" + "t" * 1000, "token"),
        ("kart=%FF%FE&token=%FF", "kart"),  # not UTF-8
    ],
)
def test_each_malformed_drive_parameter_is_refused_with_4400(
    live: LiveServer, race: dict[str, Any], query: str, says: str, no_server_errors: None
) -> None:
    code, reason = close_of(drive_url(live, race["id"], query))
    assert code == 4400 and says in reason
    assert len(reason.encode()) <= 123 and "9999999999" not in reason  # never the input echoed back


@settings(max_examples=60)
@given(kart=st.text(st.characters(exclude_categories=("Cs",)), max_size=30).filter(lambda k: k not in VALID_KARTS))
def test_no_kart_value_gets_anything_but_a_refusal(live: LiveServer, race: dict[str, Any], kart: str) -> None:
    code, reason = close_of(drive_url(live, race["id"], urlencode({"kart": kart, "token": "not-the-token"})))
    # a value pydantic reads as a kart index (" 1", "01") reaches the token check
    assert code in (4400, 4403) and reason


@settings(max_examples=30)
@given(race_id=st.text(st.characters(exclude_categories=("Cs",)), min_size=1, max_size=200))
def test_no_race_id_gets_anything_but_a_refusal(live: LiveServer, race_id: str) -> None:
    for socket in ("drive?kart=0&token=x", "telemetry"):
        code, reason = close_of(f"{live.ws_url}/api/races/{quote(race_id, safe='')}/{socket}")
        assert code in (4400, 4404) and reason


def test_a_malformed_race_id_is_refused_on_telemetry(live: LiveServer, no_server_errors: None) -> None:
    code, reason = close_of(f"{live.ws_url}/api/races/{'x' * 500}/telemetry")
    assert code == 4400 and "race_id" in reason


def test_a_drive_message_over_its_limit_closes_with_1009(
    live: LiveServer, client: httpx.Client, no_server_errors: None
) -> None:
    race = start_race(client, track="oval", laps=1, karts=[{"controller": "human"}])
    url = drive_url(live, race["id"], f"kart=0&token={race['drive_tokens']['0']}")
    code, reason = close_of(url, json.dumps({"steer": 0, "throttle": 0, "pad": "x" * DRIVE_LIMIT}))
    assert code == 1009 and f"at most {DRIVE_LIMIT}" in reason
    client.post(f"/api/races/{race['id']}/stop")


def test_binary_drive_frames_are_read_like_text(live: LiveServer, client: httpx.Client) -> None:
    race = start_race(client, track="oval", laps=1, karts=[{"controller": "human"}])
    url = drive_url(live, race["id"], f"kart=0&token={race['drive_tokens']['0']}")
    with connect(url, open_timeout=10) as ws:
        ws.send(b"\xff\xfe not json")
        ws.send(json.dumps({"steer": 0.0, "throttle": 0.5, "seq": 7}).encode())
        seen = [json.loads(ws.recv(timeout=10)) for _ in range(60)]
    assert any(m["type"] == "error" and "Invalid JSON" in m["error"] for m in seen)
    client.post(f"/api/races/{race['id']}/stop")


def test_telemetry_drains_small_messages_and_answers_the_close(live: LiveServer, race: dict[str, Any]) -> None:
    with connect(f"{live.ws_url}/api/races/{race['id']}/telemetry", open_timeout=10) as ws:
        for _ in range(20):
            ws.send("hello")
            ws.send(b"\x00" * 100)
        assert json.loads(ws.recv(timeout=10))["type"] == "frame"
        ws.close()
        received = ws.protocol.close_rcvd
        assert received is not None and received.code == 1000  # the server answered the close


@pytest.mark.parametrize("size", [TELEMETRY_LIMIT + 1, SERVER_LIMIT + 1])
def test_telemetry_closes_with_1009_on_a_big_message(
    live: LiveServer, race: dict[str, Any], size: int, no_server_errors: None
) -> None:
    code, _reason = close_of(f"{live.ws_url}/api/races/{race['id']}/telemetry", b"\x00" * size)
    assert code == 1009


def test_a_message_over_the_server_limit_closes_the_drive_socket(live: LiveServer, client: httpx.Client) -> None:
    race = start_race(client, track="oval", laps=1, karts=[{"controller": "human"}])
    url = drive_url(live, race["id"], f"kart=0&token={race['drive_tokens']['0']}")
    assert close_of(url, "x" * (SERVER_LIMIT + 1))[0] == 1009
    client.post(f"/api/races/{race['id']}/stop")
