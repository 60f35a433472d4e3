"""The server's edge through a real server (:mod:`server.edge`, :mod:`server.strict_json`): bodies that are not
strict JSON, oversized input and bodies, the live-race limit under concurrent creates, drive tokens in the log,
the API key, allowed hosts and origins for HTTP and websockets, CORS, OPTIONS, and what the OpenAPI schema says.

Classes of bad input are generated (hypothesis, derandomized) over every field of the race and tournament
requests, not listed by example."""

from __future__ import annotations

import asyncio
import json
import logging
import socket
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.live_server import LiveServer, server_settings, start_race, wait_status
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from server.edge import bounded, host_name, name_allowed
from server.log_redaction import REDACTED, TokenRedactor, redact
from server.settings import Settings
from server.strict_json import strict_loads

AI_RACE: dict[str, Any] = {"track": "oval", "laps": 1, "karts": [{"controller": "lane-follower"}]}
HUMAN_RACE: dict[str, Any] = {"track": "oval", "laps": 1, "karts": [{"controller": "human"}]}
BAD = "__BAD_VALUE__"  # replaced by a raw JSON token in the body text
MAX_ANSWER_BYTES = 8 * 1024  # no error answer may be larger, whatever the request was
SEEDED = settings(max_examples=60, derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))

# every place a value can go in a race request, and in a tournament request
RACE_FIELDS: list[tuple[str, ...]] = [
    ("track",),
    ("laps",),
    ("seed",),
    ("kart_preset",),
    ("start_lanes", "0"),
    ("karts", "0", "controller"),
    ("karts", "0", "name"),
    ("karts", "0", "params", "lookahead_time"),
    ("karts", "0", "params", BAD),  # a parameter's name (an object key)
]
TOURNAMENT_FIELDS: list[tuple[str, ...]] = [
    ("agents", "0"),
    ("tracks", "0"),
    ("races_per_pair",),
    ("seed",),
    ("laps",),
    ("time_limit",),
    ("kart_preset",),
    ("id",),
]
NON_FINITE = ["NaN", "Infinity", "-Infinity", "1e999", "-1e400"]
SURROGATES = ['"\\ud800"', '"\\udfff"', '"ab\\ud83d"', '"\\ude00x"', '"\\ud800\\ud800"']


def _with_bad(body: dict[str, Any], where: tuple[str, ...]) -> dict[str, Any]:
    """``body`` with :data:`BAD` at ``where`` (list indices as digit strings; BAD as the last part: a key)."""
    body = json.loads(json.dumps(body))
    node: Any = body
    for part in where[:-1]:
        if isinstance(node, list):
            node = node[int(part)]
        else:
            node = node.setdefault(part, [] if part in ("start_lanes", "agents", "tracks") else {})
    last = where[-1]
    if isinstance(node, list):
        node[:] = [BAD]
    elif last == BAD:
        node[BAD] = 1.0
    else:
        node[last] = BAD
    return body


def _raw(body: dict[str, Any], token: str) -> bytes:
    return json.dumps(body).replace(f'"{BAD}"', token).encode()


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("edge") / "karting.db"
    with LiveServer(server_settings(db, controller_hosts=0)) as server:
        yield server


@pytest.fixture(scope="module")
def client(live: LiveServer) -> Iterator[httpx.Client]:
    with live.client() as c:
        yield c


def _assert_bounded_422(response: httpx.Response) -> list[dict[str, Any]]:
    assert response.status_code == 422, response.text[:500]
    assert len(response.content) <= MAX_ANSWER_BYTES
    detail: list[dict[str, Any]] = strict_loads(response.content)["detail"]  # valid, strict JSON
    assert detail and all(e["msg"] for e in detail)
    return detail


# ------------------------------------------------------------------------------------------- strict JSON
TOURNAMENT: dict[str, Any] = {"agents": ["lane-follower", "e2e"], "tracks": ["oval"], "races_per_pair": 1}
# (path, body, where, raw token): an object key can only be a string, so only surrogates go there
STRICT_JSON_CASES = [
    (path, base, where, token)
    for path, base, fields in (
        ("/api/races", AI_RACE, RACE_FIELDS),
        ("/api/tournaments", TOURNAMENT, TOURNAMENT_FIELDS),
    )
    for where in fields
    for token in (SURROGATES if where[-1] == BAD else NON_FINITE + SURROGATES)
]


@settings(SEEDED, max_examples=100)
@given(st.sampled_from(STRICT_JSON_CASES))
def test_non_finite_numbers_and_lone_surrogates_anywhere_get_422(
    client: httpx.Client, case: tuple[str, dict[str, Any], tuple[str, ...], str]
) -> None:
    path, base, where, token = case
    response = client.post(
        path, content=_raw(_with_bad(base, where), token), headers={"content-type": "application/json"}
    )
    detail = _assert_bounded_422(response)
    assert detail[0]["type"] == "json_invalid"
    assert "finite" in detail[0]["ctx"]["error"] or "surrogate" in detail[0]["ctx"]["error"]


def test_strict_loads_accepts_what_json_allows_and_refuses_the_rest() -> None:
    assert strict_loads(b'{"a": [1, 2.5, -3e10, "\\ud83d\\ude00", null, true]}') == {
        "a": [1, 2.5, -3e10, "\U0001f600", None, True]
    }
    for bad in [b"NaN", b"[Infinity]", b'{"a": 1e999}', b'"\\ud800"', b'{"\\udc00": 1}', b"\xff", b"1" * 5000, b"[1,"]:
        with pytest.raises(json.JSONDecodeError):
            strict_loads(bad)


# ------------------------------------------------------------------------------------------- bounded answers
@SEEDED
@given(
    st.sampled_from(RACE_FIELDS[:-1]),
    st.one_of(  # sizes drawn directly: hypothesis's own collections stay small
        st.builds(lambda c, n: c * n, st.characters(), st.integers(1_000, 30_000)),
        st.builds(lambda v, n: [v] * n, st.integers(-(10**6), 10**6), st.integers(1_000, 9_000)),
        st.builds(lambda n: {f"p{i}": i for i in range(n)}, st.integers(100, 3_000)),
    ),
)
def test_oversized_values_anywhere_get_a_small_422(client: httpx.Client, where: tuple[str, ...], value: Any) -> None:
    body = _with_bad(AI_RACE, where)
    raw = json.dumps(body).replace(f'"{BAD}"', json.dumps(value)).encode()
    if len(raw) > Settings().max_body_bytes:
        return  # the body limit answers that (tested below)
    _assert_bounded_422(client.post("/api/races", content=raw, headers={"content-type": "application/json"}))


def test_a_body_with_hundreds_of_errors_gets_a_short_list(client: httpx.Client) -> None:
    kart = {"controller": "lane-follower", "params": {f"p{i}": [i] for i in range(32)}}
    detail = _assert_bounded_422(client.post("/api/races", json={**AI_RACE, "karts": [kart] * 8}))
    assert len(detail) == 21 and detail[-1]["type"] == "too_many_errors" and "more errors" in detail[-1]["msg"]


def test_bounded_keeps_small_values_and_cuts_the_rest() -> None:
    assert bounded({"a": [1, 2.5, "x", None]}) == {"a": [1, 2.5, "x", None]}
    assert bounded(float("nan")) == "nan" and bounded(float("-inf")) == "-inf"
    assert bounded("\ud800ab") == "\\ud800ab"
    cut = bounded("x" * 10_000)
    assert len(cut) < 200 and "10000 characters" in cut
    assert bounded(list(range(300_000))) == "(a list of 300000 entries, not shown)"
    assert bounded(10**40).startswith("1000")


def test_bodies_over_the_limit_get_413_before_they_are_read(live: LiveServer, client: httpx.Client) -> None:
    limit = live.settings.max_body_bytes
    lanes = {"track": "oval", "start_lanes": [1] * 300_000, "karts": [{"controller": "lane-follower"}]}
    declared = client.post("/api/races", json=lanes)
    assert declared.status_code == 413 and f"limit of {limit} bytes" in declared.json()["detail"]

    def chunks() -> Iterator[bytes]:  # no Content-Length: counted as it arrives
        yield b'{"track": "oval", "karts": [], "start_lanes": ['
        for _ in range(200):
            yield b"1, " * 1000

    streamed = client.post("/api/races", content=chunks(), headers={"content-type": "application/json"})
    assert streamed.status_code == 413 and str(limit) in streamed.json()["detail"]
    assert client.request("GET", "/api/tracks", content=b" " * (limit + 1)).status_code == 413
    assert client.get("/api/tracks").status_code == 200  # and the server serves on


# ------------------------------------------------------------------------------------------- live-race limit
def test_concurrent_creates_never_exceed_the_live_race_limit(tmp_path: Any) -> None:
    limit = 3
    settings = server_settings(tmp_path / "k.db", controller_hosts=0, max_sessions=limit, speedup=1.0)
    with LiveServer(settings) as server:

        async def create_many() -> list[httpx.Response]:
            async with httpx.AsyncClient(base_url=server.url, timeout=60) as client:
                body = {**AI_RACE, "laps": 5}
                return await asyncio.gather(*(client.post("/api/races", json=body) for _ in range(40)))

        responses = asyncio.run(create_many())
        codes = sorted(r.status_code for r in responses)
        assert codes == [201] * limit + [429] * (40 - limit), codes
        assert all("races are running" in r.json()["detail"] for r in responses if r.status_code == 429)
        with server.client() as client:
            live_races = [
                r for r in client.get("/api/races").json() if r["status"] in ("starting", "waiting", "running")
            ]
            assert len(live_races) == limit
            for race in live_races:
                client.post(f"/api/races/{race['id']}/stop")


# ------------------------------------------------------------------------------------------- tokens in the log
def test_redact_hides_secret_query_values() -> None:
    line = '127.0.0.1:5 - "WebSocket /api/races/ab/drive?kart=0&token=s3cr-t_X" [accepted]'
    assert redact(line) == f'127.0.0.1:5 - "WebSocket /api/races/ab/drive?kart=0&token={REDACTED}" [accepted]'
    record = logging.LogRecord("uvicorn.access", logging.INFO, "", 0, "%s %s", ("GET", "/x?token=abc&b=1"), None)
    assert TokenRedactor().filter(record) and record.getMessage() == f"GET /x?token={REDACTED}&b=1"


class _Captured(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


def test_drive_tokens_never_reach_the_server_log(live: LiveServer, client: httpx.Client) -> None:
    captured = _Captured()
    loggers = [logging.getLogger(name) for name in ("uvicorn.access", "uvicorn.error")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.addHandler(captured)
        logger.setLevel(logging.DEBUG)
    try:
        race = start_race(client, **HUMAN_RACE)
        token = race["drive_tokens"]["0"]
        assert client.get(f"/races/{race['id']}/drive?kart=0&token={token}").status_code == 200
        with connect(f"{live.ws_url}/api/races/{race['id']}/drive?kart=0&token={token}", open_timeout=10) as ws:
            ws.recv(timeout=10)
        client.post(f"/api/races/{race['id']}/stop")
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.removeHandler(captured)
            logger.setLevel(level)
    logged = "\n".join(captured.lines)
    assert f"token={REDACTED}" in logged and "WebSocket" in logged  # the lines are there, redacted
    assert token not in logged


# ------------------------------------------------------------------------------------------- hosts and origins
@pytest.mark.parametrize(
    ("header", "name"),
    [
        ("localhost:8000", "localhost"),
        ("[::1]:8000", "::1"),
        ("127.0.0.1", "127.0.0.1"),
        ("Karts.Example", "karts.example"),
    ],
)
def test_host_name_drops_the_port(header: str, name: str) -> None:
    assert host_name(header) == name


def test_served_hosts_default_to_loopback_names_on_loopback_only() -> None:
    assert Settings(host="127.0.0.1").served_hosts() == ["localhost", "127.0.0.1", "::1"]
    assert Settings(host="0.0.0.0").served_hosts() == ["*"]
    assert Settings(host="0.0.0.0", allowed_hosts="karts.example, *.karts.example").served_hosts() == [
        "karts.example",
        "*.karts.example",
    ]
    assert name_allowed("a.karts.example", ["*.karts.example"]) and not name_allowed("evil.example", ["karts.example"])


def test_other_hosts_and_origins_are_refused_over_http(live: LiveServer, client: httpx.Client) -> None:
    refused = client.get("/api/tracks", headers={"host": "evil.example"})
    assert refused.status_code == 400 and "evil.example" in refused.json()["detail"]
    for origin in ("http://evil.example", "null", "http://127.0.0.1.evil.example"):
        refused = client.post("/api/races", json=AI_RACE, headers={"origin": origin})
        assert refused.status_code == 403 and "origin" in refused.json()["detail"]
    assert client.get("/api/tracks", headers={"host": f"localhost:{live.port}"}).status_code == 200
    assert client.get("/api/tracks", headers={"origin": f"http://127.0.0.1:{live.port}"}).status_code == 200


def _ws_close(live: LiveServer, path: str, *, host: str | None = None, origin: str | None = None) -> tuple[int, str]:
    sock = socket.create_connection(("127.0.0.1", live.port), timeout=10)
    uri = f"ws://{host or f'127.0.0.1:{live.port}'}{path}"
    with connect(uri, sock=sock, origin=origin, open_timeout=10) as ws, pytest.raises(ConnectionClosed) as closed:  # type: ignore[arg-type]
        ws.recv(timeout=10)
    assert closed.value.rcvd is not None
    return closed.value.rcvd.code, closed.value.rcvd.reason


@pytest.mark.parametrize(
    "path", ["/api/races/{id}/telemetry", "/api/races/{id}/drive?kart=0&token=x", "/races/{id}/viewer"]
)
def test_other_hosts_and_origins_are_refused_on_websockets(live: LiveServer, client: httpx.Client, path: str) -> None:
    race = start_race(client, **AI_RACE)
    path = path.format(id=race["id"])
    code, reason = _ws_close(live, path, host="evil.example")
    assert code == 4400 and "evil.example" in reason
    code, reason = _ws_close(live, path, origin="http://evil.example")
    assert code == 4403 and "origin" in reason
    client.post(f"/api/races/{race['id']}/stop")


# ------------------------------------------------------------------------------------------- API key, CORS
def test_an_api_key_guards_every_mutating_operation(tmp_path: Any) -> None:
    key = "k3y-for-tests"
    settings = server_settings(tmp_path / "k.db", controller_hosts=0, api_key=key, cors_origins=["http://app.example"])
    with LiveServer(settings) as server, server.client() as client:
        missing = client.post("/api/races", json=AI_RACE)
        assert missing.status_code == 401 and "X-API-Key" in missing.json()["detail"]
        wrong = client.post("/api/races", json=AI_RACE, headers={"X-API-Key": "nope"})
        assert wrong.status_code == 403 and "wrong API key" in wrong.json()["detail"]
        race = client.post("/api/races", json=AI_RACE, headers={"X-API-Key": key})
        assert race.status_code == 201
        race_id = race.json()["id"]
        assert client.get(f"/api/races/{race_id}").status_code == 200  # reading needs no key
        assert client.post(f"/api/races/{race_id}/stop").status_code == 401
        assert client.post(f"/api/races/{race_id}/stop", headers={"X-API-Key": key}).status_code == 200
        tournament = {"agents": ["lane-follower", "e2e"], "tracks": ["oval"], "races_per_pair": 1}
        assert client.post("/api/tournaments", json=tournament).status_code == 401
        assert client.post("/api/tournaments/t0/stop").status_code == 401
        assert client.post("/api/tournaments/t0/stop", headers={"X-API-Key": key}).status_code == 404

        schema = client.get("/openapi.json").json()
        assert (
            schema["paths"]["/api/races"]["post"]["security"] and "security" not in schema["paths"]["/api/races"]["get"]
        )

        # CORS for the listed origin only: a preflight is answered, another origin is refused
        preflight = {"origin": "http://app.example", "access-control-request-method": "POST"}
        answered = client.options("/api/races", headers=preflight)
        assert answered.status_code == 200
        assert answered.headers["access-control-allow-origin"] == "http://app.example"
        assert "x-api-key" in answered.headers["access-control-allow-headers"].lower()
        refused = client.options("/api/races", headers={**preflight, "origin": "http://evil.example"})
        assert refused.status_code == 403


def test_options_without_cors_is_405_not_500(client: httpx.Client) -> None:
    for path in ("/api/races", "/api/races/abc", "/api/tournaments", "/"):
        response = client.options(path)
        assert response.status_code == 405, (path, response.text)
        assert response.json()["detail"] == "Method Not Allowed"


# ------------------------------------------------------------------------------------------- the schema
def test_the_schema_documents_the_edge_answers_and_links_a_race(client: httpx.Client) -> None:
    schema = client.get("/openapi.json").json()
    for path, operations in schema["paths"].items():
        for method, operation in operations.items():
            assert {"400", "403", "413"} <= set(operation["responses"]), (method, path)
    create = schema["paths"]["/api/races"]["post"]
    assert {"201", "401", "422", "429"} <= set(create["responses"])
    assert {"GetRace", "StopRace", "GetResult"} <= set(create["responses"]["201"]["links"])
    assert "security" not in create  # no API key on this server
    race_in = schema["components"]["schemas"]["RaceIn"]
    assert race_in["properties"]["start_lanes"]["anyOf"][0]["minItems"] == 1
    assert "oval" in race_in["properties"]["track"]["enum"]
    kart_schemas = schema["components"]["schemas"]["KartIn"]["oneOf"]
    lane_follower = next(k for k in kart_schemas if k["properties"]["controller"]["enum"] == ["lane-follower"])
    assert lane_follower["properties"]["params"]["properties"]["lookahead_time"]["maximum"] == 2.0


def test_a_race_with_the_start_lanes_the_schema_allows_is_created(client: httpx.Client) -> None:
    race = start_race(client, **{**AI_RACE, "start_lanes": [4]})
    assert race["karts"][0]["controller"] == "lane-follower"
    wait_status(client, race["id"], ("finished", "running"), 30)
    client.post(f"/api/races/{race['id']}/stop")
    assert client.post("/api/races", json={**AI_RACE, "start_lanes": []}).status_code == 422
