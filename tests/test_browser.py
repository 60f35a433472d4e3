"""One real-browser test: Debian's chromium (driven by Playwright) opens the start page and a live race viewer.

Through the real server (``server.app.create_app``) when it exists: a temporary database, ``POST /api/races``
(MCTS-LQNG vs Fixed-LQNG on the oval), then the start page must list the race and the viewer must connect, show
both karts moving and the green waypoint boxes of the planners. Without the server app it runs the same checks
against a stand-in app (the web router + a RaceScene fed by a World driven by the lane follower).

viser's client exposes its three.js scene to tests (``window.__viserMutable.nodeRefFromName[name]``, viser
1.1.x). The screenshot goes to ``test-artifacts/viewer.png``. Skipped only when no chromium binary is installed
(``scripts/install_browser.sh`` installs one; Playwright's own download needs the internet).
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib.util
import math
import os
import threading
import time
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import uvicorn
from fastapi import FastAPI

from sim_core import state as st
from sim_core.track_io import get_track
from sim_core.world import World
from web.frame import KartFrame, RaceFrame
from web.routes import make_web_router
from web.scene import RaceScene

ROOT = Path(__file__).resolve().parents[1]
ARTIFACTS = ROOT / "test-artifacts"
CHROMIUM_CANDIDATES = (
    os.environ.get("KARTING_CHROMIUM", ""),
    "/usr/bin/chromium",
    "/usr/lib/chromium/chromium",
    "/usr/bin/chromium-headless-shell",
    "/usr/lib/chromium/chromium-headless-shell",
)
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def chromium_binary() -> str | None:
    """The first installed chromium binary, if any."""
    return next((path for path in CHROMIUM_CANDIDATES if path and os.access(path, os.X_OK)), None)


def real_server_available() -> bool:
    """Whether the race server's app factory and settings exist."""
    try:
        if importlib.util.find_spec("server.app") is None or importlib.util.find_spec("server.settings") is None:
            return False
        from server import app, settings

        return hasattr(app, "create_app") and hasattr(settings, "Settings")
    except ImportError:
        return False


pytestmark = pytest.mark.skipif(
    chromium_binary() is None, reason="no chromium binary (run scripts/install_browser.sh to install Debian's)"
)


# ---------------------------------------------------------------------------------------------- servers
class ServerThread:
    """uvicorn serving ``app`` (with its lifespan) on a free local port from a background thread."""

    def __init__(self, app: FastAPI) -> None:
        config = uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning", ws_per_message_deflate=False)
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=lambda: asyncio.run(self.server.serve()), daemon=True)

    def __enter__(self) -> str:
        self.thread.start()
        deadline = time.monotonic() + 60
        while not self.server.started:
            assert time.monotonic() < deadline and self.thread.is_alive(), "uvicorn did not start"
            time.sleep(0.02)
        port = int(self.server.servers[0].sockets[0].getsockname()[1])
        return f"http://127.0.0.1:{port}"

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(30)


def stand_in_app() -> FastAPI:
    """The web router and a RaceScene fed at 50 Hz by a World whose karts follow lanes (no race server)."""
    track = get_track("oval")
    names = [("Lane 2", "lane-follower"), ("Lane 3", "lane-follower")]
    state: dict[str, Any] = {}

    def frame_of(world: World, version: int) -> RaceFrame:
        n = track.n_checkpoints
        order = world.standings(0)
        karts = []
        for k, (name, controller) in enumerate(names):
            f, i = world.fstate[0, k], world.istate[0, k]
            passed = int(i[st.I_CP_PASSED])
            ahead = [track.lane_point(passed + 1 + j, 2 + (j + k) % 2) for j in range(6)]
            others = [track.lane_point(passed + 1 + j, 3 - (j + k) % 2) for j in range(4)]
            karts.append(
                KartFrame(
                    index=k,
                    name=name,
                    controller=controller,
                    x=float(f[st.F_X]),
                    y=float(f[st.F_Y]),
                    heading=float(f[st.F_HEADING]),
                    speed=float(f[st.F_SPEED]),
                    steer=float(f[st.F_STEER]),
                    throttle=float(f[st.F_THROTTLE]),
                    lap=min(passed // n + 1, world.laps),
                    position=order.index(k) + 1,
                    checkpoints_passed=passed,
                    lane=int(i[st.I_LANE]),
                    collisions_at_fault=int(i[st.I_FAULTS]),
                    illegal_lane_changes=int(i[st.I_ILLEGAL]),
                    wall_hits=int(i[st.I_WALL_HITS]),
                    finished=bool(i[st.I_FINISHED]),
                    finish_time=None,
                    controller_faults=0,
                    waypoints=tuple((float(p[0]), float(p[1])) for p in ahead),
                    predicted=tuple((float(p[0]), float(p[1])) for p in others),
                )
            )
        status = "finished" if bool(world.done[0]) else "running"
        return RaceFrame(
            "demo", track.name, float(world.time[0]), int(world.steps[0]), world.laps, status, tuple(karts), version
        )

    async def drive(world: World, scene: RaceScene) -> None:
        from controllers.lane_follower import LaneFollower

        follower = LaneFollower(track, world.params.kart)
        lateral = np.array([track.lane_offsets(0)[1], track.lane_offsets(0)[2]])
        next_tick = time.monotonic()
        while not bool(world.done[0]):
            f = world.fstate[0]
            actions = follower.act(
                f[:, st.F_X : st.F_Y + 1], f[:, st.F_HEADING], f[:, st.F_SPEED], f[:, st.F_S], f[:, st.F_WEAR], lateral
            )
            world.step(actions[None, :, :])
            scene.update(frame_of(world, int(world.steps[0]) // 25))
            next_tick += 0.02
            await asyncio.sleep(max(0.0, next_tick - time.monotonic()))

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        world = World(track, n_karts=2, laps=3)
        scene = RaceScene(track, names, "demo race")
        state["scene"] = scene
        task = asyncio.create_task(drive(world, scene))
        try:
            yield
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            await asyncio.to_thread(scene.close)

    app = FastAPI(lifespan=lifespan)
    app.include_router(make_web_router(lambda race_id: state["scene"].port if race_id == "demo" else None))
    race = {
        "id": "demo",
        "status": "running",
        "track": "oval",
        "laps": 3,
        "karts": [{"name": n, "controller": c} for n, c in names],
        "standings": [0, 1],
    }
    app.get("/api/races")(lambda: [race])
    app.get("/api/tracks")(lambda: [{"name": "oval", "length_m": track.length, "laps": 3, "n_checkpoints": 24}])
    app.get("/api/controllers")(lambda: [{"name": "lane-follower", "description": "", "parameters": {}}])
    return app


@pytest.fixture(scope="module")
def live_race(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str, str]]:
    """(base URL, race id, "server" or "stand-in") of a running race."""
    if real_server_available():
        from server.app import create_app
        from server.settings import Settings

        db = tmp_path_factory.mktemp("browser") / "karting.db"
        app = create_app(Settings(database_url=f"sqlite:///{db}", port=0))
        with ServerThread(app) as base:
            body = {
                "track": "oval",
                "laps": 2,
                "seed": 7,
                "start_lanes": None,
                "kart_preset": "paper",
                "karts": [{"controller": "mcts-lqng", "name": "MCTS"}, {"controller": "fixed-lqng", "name": "Fixed"}],
            }
            response = httpx.post(f"{base}/api/races", json=body, timeout=60)
            assert response.status_code == 201, response.text
            yield base, str(response.json()["id"]), "server"
    else:
        with ServerThread(stand_in_app()) as base:
            yield base, "demo", "stand-in"


# ---------------------------------------------------------------------------------------------- the test
NODE_POSITION = (
    "name => { const n = window.__viserMutable?.nodeRefFromName?.[name]; return n ? n.position.toArray() : null; }"
)
ANY_WAYPOINT_VISIBLE = """() => {
  const nodes = window.__viserMutable?.nodeRefFromName || {};
  return Object.keys(nodes).some(name => /^\\/plans\\/kart\\d+\\/wp\\d+$/.test(name) && nodes[name].visible);
}"""


def test_viewer_in_a_real_browser(live_race: tuple[str, str, str]) -> None:
    from playwright.sync_api import sync_playwright

    base, race_id, mode = live_race
    ARTIFACTS.mkdir(exist_ok=True)
    outside: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_binary(), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 720})
            page.on(
                "request",
                lambda r: (
                    outside.append(r.url)
                    if not r.url.startswith(("http://127.0.0.1", "ws://127.0.0.1", "data:", "blob:"))
                    else None
                ),
            )
            page.set_default_timeout(60_000)

            # the start page lists the race with a link to its viewer
            page.goto(f"{base}/")
            row = page.locator(f'tr[data-race-id="{race_id}"]')
            row.wait_for()
            assert "oval" in row.inner_text()
            assert row.locator(f'a[href="/races/{race_id}/viewer/"]').count() == 1

            # the viewer connects and shows the scene
            page.goto(f"{base}/races/{race_id}/viewer/")
            page.wait_for_function("() => !document.body.innerText.includes('Connecting...')")
            for name in ("/karts/kart0", "/karts/kart1", "/plans/kart0/wp0", "/track/lanes", "/track/checkpoints/cp0"):
                page.wait_for_function("name => window.__viserMutable?.nodeRefFromName?.[name] != null", arg=name)
            # labels are drawn in one batch (no three.js object of their own): look them up in the scene tree
            assert page.evaluate("() => window.__viserSceneTree.getState()['/karts/kart1/label'] != null")

            # karts move: wait for the start (a race may count down first), then two reads 0.5 s apart differ
            start = [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)]
            deadline = time.monotonic() + 60
            while [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)] == start:
                assert time.monotonic() < deadline, f"karts never moved ({mode})"
                page.wait_for_timeout(250)
            before = [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)]
            page.wait_for_timeout(500)
            after = [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)]
            moved = [math.dist(a, b) for a, b in zip(before, after, strict=True)]
            assert max(moved) > 0.5, f"karts did not move in 0.5 s: {moved}"

            # the planners' waypoints show up as green boxes
            page.wait_for_function(ANY_WAYPOINT_VISIBLE, timeout=90_000)
            calls = page.evaluate("() => window.__viserTestpoints?.rendererInfo?.render?.calls ?? -1")
            assert calls != 0, "the renderer draws nothing"
            # the canvas is nearly transparent until the environment map is ready (slow with software WebGL)
            page.wait_for_function("() => ['', '1'].includes(window.__viserMutable?.canvas?.style.opacity)")
            page.screenshot(path=str(ARTIFACTS / "viewer.png"))
        finally:
            browser.close()
    assert not outside, f"requests left the machine: {outside[:5]}"
