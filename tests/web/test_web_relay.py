"""The viewer relay without a browser (``web.routes.make_web_router``): pages, the websocket relay to a race's
viser scene both ways, its closes (unknown race, version mismatch, scene gone) and a viewer's "follow" choice,
with viser's wire protocol decoded by ``tests/support/viser_wire.py``."""

from __future__ import annotations

import asyncio
import logging
import socket
import time
from collections.abc import Iterator

import httpx
import msgspec
import pytest
from fastapi import FastAPI
from support.live_server import ServerThread
from support.viser_wire import (
    SUBPROTOCOL,
    Message,
    connect,
    make_frame,
    named,
    receive_until,
    replay_done,
)
from websockets.exceptions import ConnectionClosed

from sim_core.track_io import get_track
from web.routes import RaceState, make_web_router
from web.scene import RaceScene


@pytest.fixture()
def relay_app() -> Iterator[tuple[ServerThread, RaceScene]]:
    scene = RaceScene(get_track("oval"), [("A", "mcts-lqng"), ("B", "human")], "relay test")
    scenes = {"r1": scene}

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        dead_port = int(probe.getsockname()[1])

    def scene_port(race_id: str) -> int | None:
        if race_id == "stale":
            return dead_port
        s = scenes.get(race_id)
        return None if s is None or s.closed else s.port

    def race_state(race_id: str) -> RaceState | None:
        states = {"r1": RaceState("running", False), "stale": RaceState("running", False)}
        states |= {"starting": RaceState("starting", False), "done": RaceState("finished", True)}
        return states.get(race_id)

    app = FastAPI()
    app.include_router(make_web_router(scene_port, race_state))
    with ServerThread(app, lifespan="off") as server:
        yield server, scene
    scene.close()


def test_pages(relay_app: tuple[ServerThread, RaceScene]) -> None:
    server, _ = relay_app
    with httpx.Client(base_url=f"http://127.0.0.1:{server.port}", timeout=10) as client:
        start = client.get("/")
        assert start.status_code == 200 and start.headers["content-type"].startswith("text/html")
        assert "HeadToHead Karting" in start.text and "/assets/start.js" in start.text
        assert 'href="/tournaments"' in start.text  # the navigation
        tournaments = client.get("/tournaments")
        assert tournaments.status_code == 200 and "/assets/tournaments.js" in tournaments.text
        tournament = client.get("/tournaments/some-id")
        assert tournament.status_code == 200 and "/assets/tournament.js" in tournament.text
        assets = (
            "start.js",
            "drive.js",
            "drive-worker.js",
            "common.js",
            "viewer-wait.js",
            "viewer-live.js",
            "race-over.js",
            "framed.js",
            "tournaments.js",
            "tournament.js",
            "style.css",
        )
        for asset in assets:
            kind = "css" if asset.endswith(".css") else "javascript"
            response = client.get(f"/assets/{asset}")
            assert response.status_code == 200 and kind in response.headers["content-type"]
        assert client.get("/assets/nope.js").status_code == 404
        assert client.get("/assets/..%2Froutes.py").status_code == 404
        viewer = client.get("/races/r1/viewer/")
        assert viewer.status_code == 200 and viewer.headers["content-type"].startswith("text/html")
        assert viewer.headers.get("content-encoding") == "gzip"  # httpx asks for gzip and decodes it
        assert len(viewer.content) > 100_000 and b"<html" in viewer.content[:2000].lower()
        # viewer-live.js comes first, before viser's scripts (it wraps the Worker that holds viser's websocket)
        assert viewer.content.index(b"/assets/viewer-live.js") < viewer.content.index(b"<script", 200)
        plain = client.get("/races/r1/viewer/", headers={"Accept-Encoding": "identity"})
        assert plain.content == viewer.content
        redirect = client.get("/races/r1/viewer", follow_redirects=False)
        assert redirect.status_code in (301, 302, 307, 308)
        assert redirect.headers["location"].endswith("/races/r1/viewer/")
        missing = client.get("/races/nope/viewer/")
        assert missing.status_code == 404 and "No race <code>nope</code>" in missing.text
        assert '<script src="/assets/viewer' not in missing.text  # nothing polls or reloads there
        starting = client.get("/races/starting/viewer/")
        assert starting.status_code == 200 and "viewer-wait.js" in starting.text and "starting" in starting.text
        over = client.get("/races/done/viewer/")
        assert over.status_code == 200 and "is over" in over.text and "viewer-wait.js" not in over.text
        assert 'href="/races/done/replay"' in over.text and 'href="/api/races/done/result"' in over.text
        hostile = client.get("/races/<b>x/viewer/")
        assert hostile.status_code == 404 and "<b>x" not in hostile.text
        drive = client.get("/races/r1/drive", params={"kart": 1, "token": "t"})
        assert drive.status_code == 200 and "/assets/drive.js" in drive.text
        unknown_drive = client.get("/races/nope/drive", params={"kart": 1, "token": "t"})
        assert unknown_drive.status_code == 404 and "No race <code>nope</code>" in unknown_drive.text


def test_relay_unknown_race_closes_4404(relay_app: tuple[ServerThread, RaceScene]) -> None:
    server, _ = relay_app

    async def run() -> ConnectionClosed:
        async with connect(server.port, "/races/nope/viewer") as ws:
            with pytest.raises(ConnectionClosed) as closed:
                await asyncio.wait_for(ws.recv(), 5)
            return closed.value

    closed = asyncio.run(run())
    assert closed.rcvd is not None and closed.rcvd.code == 4404
    assert "nope" in closed.rcvd.reason


def test_relay_forwards_viser_both_ways_and_cleans_up(
    relay_app: tuple[ServerThread, RaceScene], caplog: pytest.LogCaptureFixture
) -> None:
    server, scene = relay_app
    track = scene.track

    async def run() -> tuple[list[Message], list[Message]]:
        async with connect(server.port, "/races/r1/viewer") as ws:
            assert ws.subprotocol == SUBPROTOCOL
            backlog = await receive_until(ws, replay_done)
            scene.update(make_frame(track, 2, moved=2.0))
            update = await receive_until(ws, lambda ms: "/karts/kart0" in named(ms, "SetPositionMessage"))
            assert any(name.startswith("viewer-relay") for name in server.task_names())
            return backlog, update

    with caplog.at_level(logging.INFO):
        backlog, update = asyncio.run(run())
        assert "/karts/kart0" in named(backlog, "BoxMessage")
        expected_x = float(track.lane_point(0, 1)[0]) + 2.0
        assert named(update, "SetPositionMessage")["/karts/kart0"]["position"][0] == pytest.approx(expected_x)
        deadline = time.monotonic() + 5
        while any(name.startswith("viewer-relay") for name in server.task_names()):
            assert time.monotonic() < deadline, "relay tasks leaked after the browser left"
            time.sleep(0.05)
    problems = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert not problems, [r.getMessage() for r in problems]


def test_relay_passes_version_mismatch_and_scene_close(relay_app: tuple[ServerThread, RaceScene]) -> None:
    server, scene = relay_app

    async def mismatch() -> ConnectionClosed:
        async with connect(server.port, "/races/r1/viewer", subprotocol="viser-v0.0.1") as ws:
            with pytest.raises(ConnectionClosed) as closed:
                while True:
                    await asyncio.wait_for(ws.recv(), 5)
            return closed.value

    closed = asyncio.run(mismatch())
    assert closed.rcvd is not None and closed.rcvd.code == 1002

    async def scene_closes() -> ConnectionClosed:
        async with connect(server.port, "/races/r1/viewer") as ws:
            await receive_until(ws, replay_done)
            await asyncio.to_thread(scene.close)
            with pytest.raises(ConnectionClosed) as closed:
                while True:
                    await asyncio.wait_for(ws.recv(), 10)
            return closed.value

    closed = asyncio.run(scene_closes())
    assert closed.rcvd is not None and closed.rcvd.code in (1000, 1001)

    async def viser_gone() -> ConnectionClosed:  # a port where nothing listens any more
        async with connect(server.port, "/races/stale/viewer") as ws:
            with pytest.raises(ConnectionClosed) as closed:
                await asyncio.wait_for(ws.recv(), 10)
            return closed.value

    closed = asyncio.run(viser_gone())
    assert closed.rcvd is not None and closed.rcvd.code == 1011
    deadline = time.monotonic() + 5
    while any(name.startswith("viewer-relay") for name in server.task_names()):
        assert time.monotonic() < deadline, "relay tasks leaked after viser stopped"
        time.sleep(0.05)


CAMERA_MESSAGE = msgspec.msgpack.encode(
    {
        "type": "ViewerCameraMessage",
        "wxyz": [1.0, 0.0, 0.0, 0.0],
        "position": [0.0, -30.0, 30.0],
        "fov": 1.0,
        "near": 0.01,
        "far": 1000.0,
        "image_height": 480,
        "image_width": 640,
        "look_at": [0.0, 0.0, 0.0],
        "up_direction": [0.0, 0.0, 1.0],
    }
)


def test_a_viewer_that_asks_to_follow_a_kart_starts_chasing_it(relay_app: tuple[ServerThread, RaceScene]) -> None:
    """``?follow=K`` on the viewer's websocket (the drive page's view) picks the "Follow" dropdown's start."""
    server, _ = relay_app

    async def follow_choice(query: str) -> str:
        async with connect(server.port, f"/races/r1/viewer{query}") as ws:
            await ws.send(CAMERA_MESSAGE)  # viser adds a client's own GUI once it reported its camera
            messages = await receive_until(ws, lambda ms: any(m["type"] == "GuiDropdownMessage" for m in ms))
        dropdown = next(m for m in messages if m["type"] == "GuiDropdownMessage")
        assert dropdown["props"]["label"] == "Follow"
        return str(dropdown["value"])

    assert asyncio.run(follow_choice("?follow=1")) == "2: B"
    assert asyncio.run(follow_choice("?follow=0")) == "1: A"
    for ignored in ("", "?follow=7", "?follow=-1", "?follow=x", "?other=1"):
        assert asyncio.run(follow_choice(ignored)) == "Free camera", ignored
