"""The race scene without a browser (``web.scene.RaceScene``): a websocket client decodes viser's wire protocol
(``tests/support/viser_wire.py``) to check the track, karts, checkpoints, plans and the HUD."""

from __future__ import annotations

import asyncio
import json
import logging
import re
import socket
import sys
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import msgspec
import numpy as np
import pytest
import zstandard
from support.viser_wire import (
    SUBPROTOCOL,
    Message,
    connect,
    decode_frame,
    make_frame,
    named,
    receive_until,
    replay_done,
)

from sim_core.track_io import get_track
from web.frame import KART_COLORS, KartFrame, RaceFrame
from web.meshes import CHECKPOINT_COLOR, PREDICTION_COLOR, WAYPOINT_COLOR
from web.scene import WAYPOINT_POOL, RaceScene
from web.viewer import VISER_SUBPROTOCOL


@pytest.fixture(params=["oval", "complex"])
def scene(request: pytest.FixtureRequest) -> Iterator[RaceScene]:
    track = get_track(request.param)
    race_scene = RaceScene(track, [("Driver 0", "mcts-lqng"), ("Driver 1", "fixed-lqng")], f"test {request.param}")
    yield race_scene
    race_scene.close()


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


def test_labels_name_the_controller_once_and_the_hud_says_which_faults() -> None:
    from web.frame import kart_label
    from web.hud import hud_text, laps_text, legend_text

    assert kart_label("mcts-lqng 1", "mcts-lqng") == "mcts-lqng 1"
    assert kart_label("Alice", "human") == "Alice (human)"
    assert (laps_text(1), laps_text(3)) == ("1 lap", "3 laps")
    table = hud_text("oval", [("A", "lane-follower")], None)
    assert "| at fault | illegal LC | controller faults |" in table
    assert "collisions at fault" in legend_text() and "controller faults" in legend_text()


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


def test_team_colours_follow_the_grid_order_and_repeat_beyond_four_teams() -> None:
    from web.frame import TEAM_COLORS, team_colors

    assert team_colors([None, "B", "A", "B", None]) == {"B": TEAM_COLORS[0], "A": TEAM_COLORS[1]}
    five = team_colors(["t1", "t2", "t3", "t4", "t5"])
    assert five["t5"] == TEAM_COLORS[0] and len(set(five.values())) == 4
    assert not set(TEAM_COLORS) & set(KART_COLORS)  # a team's colour is never a kart's


def test_the_pages_colour_teams_as_the_scene_does() -> None:
    from web.frame import TEAM_COLORS

    common = (Path(__file__).resolve().parents[2] / "web" / "static" / "common.js").read_text()
    found = re.search(r"const TEAM_COLORS = (\[.*?\]);", common, re.S)
    assert found is not None, "common.js has no TEAM_COLORS"
    assert [tuple(c) for c in json.loads(found.group(1))] == list(TEAM_COLORS)


def test_a_teams_karts_carry_its_colour_on_the_roof_and_in_the_hud() -> None:
    from web.frame import TEAM_COLORS

    track = get_track("oval")
    karts = [("A", "mcts-rl"), ("B", "fixed-rl"), ("C", "mcts-rl"), ("D", "e2e")]
    scene = RaceScene(track, karts, "teams")
    teams = ("Blue", "Red", "Blue", None)

    async def run() -> tuple[list[Message], list[Message]]:
        async with connect(scene.port) as ws:
            backlog = await receive_until(ws, replay_done)
            frame = make_frame(track, 4)
            team_karts = tuple(KartFrame(**{**k.__dict__, "team": t}) for k, t in zip(frame.karts, teams, strict=True))
            scene.update(RaceFrame(**{**frame.__dict__, "karts": team_karts}))
            shown = await receive_until(
                ws, lambda ms: "/karts/kart2/team" in named(ms, "SetSceneNodeVisibilityMessage")
            )
            return backlog, shown

    try:
        backlog, shown = asyncio.run(run())
        hidden = {name: m["visible"] for name, m in named(backlog, "SetSceneNodeVisibilityMessage").items()}
        assert all(hidden[f"/karts/kart{i}/team"] is False for i in range(4))  # before the first frame
        visible = {name: m["visible"] for name, m in named(shown, "SetSceneNodeVisibilityMessage").items()}
        assert visible["/karts/kart0/team"] and visible["/karts/kart1/team"] and visible["/karts/kart2/team"]
        assert "/karts/kart3/team" not in visible  # racing for itself: no plate
        plates = {name: tuple(m["updates"]["color"]) for name, m in named(shown, "SceneNodeUpdateMessage").items()}
        assert plates["/karts/kart0/team"] == plates["/karts/kart2/team"] == TEAM_COLORS[0]
        assert plates["/karts/kart1/team"] == TEAM_COLORS[1] and "/karts/kart3/team" not in plates
        hud = scene._hud.content
        blue, red = (f"rgb({r}, {g}, {b})" for r, g, b in TEAM_COLORS[:2])
        rows = {name: row for row in hud.splitlines() for name in ("Driver 0", "Driver 1", "Driver 3") if name in row}
        assert blue in rows["Driver 0"] and ">Blue<" in rows["Driver 0"] and red in rows["Driver 1"]
        assert "rgb(" not in rows["Driver 3"].split("Driver 3")[1].split("|")[0]  # no team badge
    finally:
        scene.close()
