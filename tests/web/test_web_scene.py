"""The race scene and the viewer relay, without a browser: viser's wire protocol decoded from a websocket client.

Each viser websocket frame is ``u64 len(msgpack) | u64 len(zstd) | zstd(msgpack {"messages": [...]}) | binary
buffers``; the tests decode the messages and look at their types, node names and props.
"""

from __future__ import annotations

import asyncio
import logging
import socket
import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import httpx
import msgspec
import numpy as np
import pytest
import viser
import websockets
import zstandard
from fastapi import FastAPI
from support.live_server import ServerThread
from websockets.exceptions import ConnectionClosed
from websockets.typing import Subprotocol

from sim_core.track import Track
from sim_core.track_io import get_track
from web.frame import KartFrame, RaceFrame
from web.meshes import CHECKPOINT_COLOR, PREDICTION_COLOR, WAYPOINT_COLOR
from web.routes import RaceState, make_web_router
from web.scene import WAYPOINT_POOL, RaceScene
from web.viewer import VISER_SUBPROTOCOL

SUBPROTOCOL = Subprotocol(f"viser-v{viser.__version__}")
Message = dict[str, Any]


# ---------------------------------------------------------------------------------------------- helpers
def decode_frame(data: bytes) -> list[Message]:
    """The messages of one viser websocket frame."""
    inner_size = int.from_bytes(data[:8], "little")
    compressed_size = int.from_bytes(data[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(data[16 : 16 + compressed_size], max_output_size=inner_size)
    return list(msgspec.msgpack.decode(inner)["messages"])


async def receive_until(
    ws: websockets.ClientConnection, done: Callable[[list[Message]], bool], timeout: float = 10.0
) -> list[Message]:
    """Collect messages until ``done(all so far)`` holds (or fail after ``timeout`` seconds)."""
    messages: list[Message] = []
    deadline = time.monotonic() + timeout
    while not done(messages):
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"timed out; got {sorted({m['type'] for m in messages})}"
        data = await asyncio.wait_for(ws.recv(), remaining)
        assert isinstance(data, bytes)
        messages.extend(decode_frame(data))
    return messages


def replay_done(messages: list[Message]) -> bool:
    """Whether viser finished sending its scene backlog."""
    return any(m["type"] == "ReplayDoneMessage" for m in messages)


def named(messages: list[Message], kind: str) -> dict[str, Message]:
    """Last message of type ``kind`` per node name."""
    return {m["name"]: m for m in messages if m["type"] == kind}


def make_frame(
    track: Track,
    n_karts: int,
    *,
    step: int = 0,
    plans_version: int = 0,
    moved: float = 0.0,
    waypoints: tuple[tuple[float, float], ...] = (),
    predicted: tuple[tuple[float, float], ...] = (),
    status: str = "running",
) -> RaceFrame:
    """A frame with karts on the grid (kart 0 ``moved`` metres along x) and kart 0's plan."""
    karts = []
    for i in range(n_karts):
        point = track.lane_point(0, 1 + i % track.n_lanes)
        karts.append(
            KartFrame(
                index=i,
                name=f"Driver {i}",
                controller="fixed-lqng",
                x=float(point[0]) + (moved if i == 0 else 0.0),
                y=float(point[1]),
                heading=0.3 * i,
                speed=5.0 + i,
                steer=0.0,
                throttle=1.0,
                lap=1,
                position=i + 1,
                checkpoints_passed=0,
                lane=1 + i % track.n_lanes,
                collisions_at_fault=i,
                illegal_lane_changes=0,
                wall_hits=0,
                finished=False,
                finish_time=None,
                controller_faults=0,
                waypoints=waypoints if i == 0 else (),
                predicted=predicted if i == 0 else (),
            )
        )
    return RaceFrame("r1", track.name, step * 0.02, step, track.laps, status, tuple(karts), plans_version)


@pytest.fixture(params=["oval", "complex"])
def scene(request: pytest.FixtureRequest) -> Iterator[RaceScene]:
    track = get_track(request.param)
    race_scene = RaceScene(track, [("Driver 0", "mcts-lqng"), ("Driver 1", "fixed-lqng")], f"test {request.param}")
    yield race_scene
    race_scene.close()


def connect(port: int, path: str = "", subprotocol: str = SUBPROTOCOL) -> Any:
    return websockets.connect(
        f"ws://127.0.0.1:{port}{path}", subprotocols=[Subprotocol(subprotocol)], max_size=None, compression=None
    )


# ---------------------------------------------------------------------------------------------- scene
def test_viser_wire_decoders_available() -> None:
    assert VISER_SUBPROTOCOL == SUBPROTOCOL
    payload = msgspec.msgpack.encode({"messages": [{"type": "X"}]})
    frame = len(payload).to_bytes(8, "little")
    compressed = zstandard.ZstdCompressor().compress(payload)
    assert decode_frame(frame + len(compressed).to_bytes(8, "little") + compressed) == [{"type": "X"}]


def test_scene_has_track_karts_checkpoints_and_plan_nodes(scene: RaceScene) -> None:
    track = scene.track

    async def run() -> list[Message]:
        async with connect(scene.port) as ws:
            assert ws.subprotocol == SUBPROTOCOL
            return await receive_until(ws, replay_done)

    messages = asyncio.run(run())
    boxes = named(messages, "BoxMessage")
    for i in range(2):
        assert boxes[f"/karts/kart{i}"]["props"]["dimensions"] == pytest.approx((2.0, 0.9, 0.5))
        for j in range(WAYPOINT_POOL):
            assert tuple(boxes[f"/plans/kart{i}/wp{j}"]["props"]["color"]) == WAYPOINT_COLOR
        assert tuple(boxes[f"/plans/kart{i}/pred0"]["props"]["color"]) == PREDICTION_COLOR
    assert tuple(boxes["/karts/kart0"]["props"]["color"]) != tuple(boxes["/karts/kart1"]["props"]["color"])
    checkpoints = [name for name in boxes if name.startswith("/track/checkpoints/")]
    assert len(checkpoints) == track.n_checkpoints
    assert all(tuple(boxes[name]["props"]["color"]) == CHECKPOINT_COLOR for name in checkpoints)
    # checkpoint boxes sit on the checkpoint lines, across the road
    positions = named(messages, "SetPositionMessage")
    for c in (0, track.n_checkpoints // 2):
        centre, _ = track.checkpoint_frame(c)
        xyz = positions[f"/track/checkpoints/cp{c}"]["position"]
        assert np.hypot(xyz[0] - centre[0], xyz[1] - centre[1]) < 1.0
        assert boxes[f"/track/checkpoints/cp{c}"]["props"]["dimensions"][1] > 8.0
    assert "/track/lanes" in named(messages, "LineSegmentsMessage")
    meshes = named(messages, "MeshMessage")
    assert {"/track/surface", "/track/walls/left", "/track/walls/right"} <= set(meshes)
    labels = named(messages, "LabelMessage")
    assert "Driver 0" in labels["/karts/kart0/label"]["props"]["text"]
    assert "Driver 1" in labels["/karts/kart1/label"]["props"]["text"]
    # plan boxes start hidden; karts are visible
    visible = {name: m["visible"] for name, m in named(messages, "SetSceneNodeVisibilityMessage").items()}
    assert visible["/plans/kart0/wp0"] is False and visible["/plans/kart1/pred0"] is False
    assert visible["/karts/kart0"] is True
    theme = next(m for m in messages if m["type"] == "ThemeConfigurationMessage")
    assert theme["show_share_button"] is False
    hud = [m for m in messages if m["type"] == "GuiMarkdownMessage"]
    assert any("Driver 0" in m["props"]["_markdown"] for m in hud)


def test_updates_move_karts_and_show_plans(scene: RaceScene) -> None:
    track = scene.track
    wp = tuple((float(p[0]), float(p[1])) for p in (track.lane_point(c, 2) for c in range(1, 4)))
    pred = tuple((float(p[0]), float(p[1])) for p in (track.lane_point(c, 3) for c in range(1, 3)))

    async def run() -> tuple[list[Message], list[Message], list[Message]]:
        async with connect(scene.port) as ws:
            await receive_until(ws, replay_done)
            start = make_frame(track, 2)
            scene.update(start)
            first = await receive_until(ws, lambda ms: "/karts/kart0" in named(ms, "SetPositionMessage"))
            scene.update(make_frame(track, 2, step=1, moved=1.5, plans_version=1, waypoints=wp, predicted=pred))

            def plan_shown(ms: list[Message]) -> bool:
                vis = named(ms, "SetSceneNodeVisibilityMessage")
                return "/plans/kart0/wp2" in vis and "/karts/kart0" in named(ms, "SetPositionMessage")

            second = await receive_until(ws, plan_shown)
            # same plans_version: the plan is not re-sent even if the frame's waypoints differ
            scene.update(make_frame(track, 2, step=2, moved=3.0, plans_version=1, waypoints=wp[:1]))
            third = await receive_until(ws, lambda ms: "/karts/kart0" in named(ms, "SetPositionMessage"))
            return first, second, third

    first, second, third = asyncio.run(run())
    x0 = named(first, "SetPositionMessage")["/karts/kart0"]["position"][0]
    x1 = named(second, "SetPositionMessage")["/karts/kart0"]["position"][0]
    assert x1 - x0 == pytest.approx(1.5, abs=1e-6)
    assert "/karts/kart1" not in named(second, "SetPositionMessage")  # unchanged poses are not re-sent
    visible = {name: m["visible"] for name, m in named(second, "SetSceneNodeVisibilityMessage").items()}
    assert all(visible[f"/plans/kart0/wp{j}"] for j in range(3))
    assert visible["/plans/kart0/pred0"] and visible["/plans/kart0/pred1"]
    assert not visible.get("/plans/kart0/wp3", False)
    positions = named(second, "SetPositionMessage")
    assert positions["/plans/kart0/wp1"]["position"][:2] == pytest.approx(wp[1])
    assert positions["/plans/kart0/pred1"]["position"][:2] == pytest.approx(pred[1])
    assert not any(m.get("name", "").startswith("/plans/") for m in third)
    assert named(third, "SetPositionMessage")["/karts/kart0"]["position"][0] == pytest.approx(x0 + 3.0)


def test_update_never_raises_and_close_is_idempotent(caplog: pytest.LogCaptureFixture) -> None:
    track = get_track("oval")
    scene = RaceScene(track, [("A", "human"), ("B", "fixed-lqng")], "broken frames")
    port = scene.port
    assert scene._kart_writers[0].fast  # the fast pose path matches this viser version
    with caplog.at_level(logging.ERROR, logger="web.scene"):
        scene.update(None)  # type: ignore[arg-type]
        scene.update(make_frame(track, 4))  # more karts than the scene has: extra ones ignored
        bad = make_frame(track, 2)
        scene.update(RaceFrame(**{**bad.__dict__, "karts": (*bad.karts[:1], "not a kart")}))  # type: ignore[arg-type]
    assert any("update failed" in r.getMessage() for r in caplog.records)
    scene.close()
    scene.close()
    scene.update(make_frame(track, 2))  # after close: a no-op
    assert scene.closed
    with socket.socket() as s:  # the port is free again
        s.bind(("127.0.0.1", port))


def test_scenes_started_at_once_leave_stdout_alone() -> None:
    track = get_track("oval")
    stdout = sys.stdout
    with ThreadPoolExecutor(4) as pool:
        scenes = list(pool.map(lambda i: RaceScene(track, [("A", "human")], f"at once {i}"), range(4)))
    for scene in scenes:
        scene.close()
    assert sys.stdout is stdout


def test_hud_shows_standings_and_escapes_names() -> None:
    track = get_track("oval")
    hostile = "<img src=x onerror=alert(1)> | *b*"
    scene = RaceScene(track, [(hostile, "human"), ("B", "fixed-lqng")], "escaping")
    try:
        assert "<img" not in scene._hud.content
        frame = make_frame(track, 2)
        karts = (KartFrame(**{**frame.karts[0].__dict__, "name": hostile}), frame.karts[1])
        scene.update(RaceFrame(**{**frame.__dict__, "karts": karts}))
        content = scene._hud.content
        assert "<img" not in content and "&lt;img" in content and "\\|" in content and "\\*b\\*" in content
        assert "Driver 1" in content and "18" in content  # kart 0 at 5 m/s = 18 km/h
    finally:
        scene.close()


# ---------------------------------------------------------------------------------------------- relay
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


def test_labels_name_the_controller_once_and_the_hud_says_which_faults() -> None:
    from web.frame import kart_label
    from web.hud import hud_text, laps_text, legend_text

    assert kart_label("mcts-lqng 1", "mcts-lqng") == "mcts-lqng 1"
    assert kart_label("Alice", "human") == "Alice (human)"
    assert (laps_text(1), laps_text(3)) == ("1 lap", "3 laps")
    table = hud_text("oval", [("A", "lane-follower")], None)
    assert "| at fault | illegal LC | controller faults |" in table
    assert "collisions at fault" in legend_text() and "controller faults" in legend_text()


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


def test_hud_counts_down_and_drops_finished_karts_speed() -> None:
    track = get_track("oval")
    scene = RaceScene(track, [("A", "human"), ("B", "fixed-lqng")], "countdown")
    try:
        frame = make_frame(track, 2, status="countdown")
        scene.update(RaceFrame(**{**frame.__dict__, "countdown": 2.4}))
        assert "starts in 3" in scene._hud.content
        running = make_frame(track, 2)
        finished = KartFrame(**{**running.karts[1].__dict__, "finished": True, "finish_time": 40.5})
        scene.update(RaceFrame(**{**running.__dict__, "karts": (running.karts[0], finished)}))
        rows = {
            name: row for row in scene._hud.content.splitlines() for name in ("Driver 0", "Driver 1") if name in row
        }
        assert "| 18 |" in rows["Driver 0"]  # 5 m/s
        assert "| – |" in rows["Driver 1"] and "✓ 40.50 s" in rows["Driver 1"] and "| 22 |" not in rows["Driver 1"]
    finally:
        scene.close()
