"""The live race viewer in a real browser: Debian's chromium (driven by Playwright) opens the start page and a live
race's viewer.

Through the real server (``server.app.create_app`` under uvicorn, a temporary database): ``POST /api/races`` (MCTS-
LQNG vs Fixed-LQNG on the oval), then the start page must list the race, and the viewer must connect, show both
karts moving and the green waypoint boxes of the planners, and its "Follow" dropdown must make the camera chase a
kart. No request may leave the machine. Screenshots go to ``test-artifacts/`` (``viewer.png``, ``viewer-
follow.png``, ``start.png``) and, under ``make screenshots``, ``docs/screenshots/``. Skipped only when no chromium
binary is installed (``scripts/install_browser.sh`` installs Debian's; ``playwright install`` needs the internet).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

import httpx
import pytest
from support.browser import (
    CAMERA_NEAR_KART0,
    NODE_POSITION,
    PAGE_2D,
    VIEW_3D,
    browser_page,
    readme_screenshot,
    requires_chromium,
)
from support.live_server import ServerThread

if TYPE_CHECKING:
    from playwright.sync_api import Page

pytestmark = [requires_chromium, pytest.mark.slow]


@pytest.fixture(scope="module")
def live_race(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """(base URL, race id) of an MCTS-LQNG vs Fixed-LQNG race on the oval, on the real server (temporary DB)."""
    from server.app import create_app
    from server.settings import Settings

    db = tmp_path_factory.mktemp("browser") / "karting.db"
    with ServerThread(create_app(Settings(database_url=f"sqlite:///{db}", port=0))) as server:
        base = server.url
        body = {
            "track": "oval",
            "laps": 10,  # [about 3 min] still running when the last check reads the camera, on a loaded machine
            "seed": 7,
            "start_lanes": None,
            "kart_preset": "paper",
            "karts": [{"controller": "mcts-lqng", "name": "MCTS"}, {"controller": "fixed-lqng", "name": "Fixed"}],
        }
        response = httpx.post(f"{base}/api/races", json=body, timeout=60)
        assert response.status_code == 201, response.text
        yield base, str(response.json()["id"])


ANY_WAYPOINT_VISIBLE = """() => {
  const nodes = window.__viserMutable?.nodeRefFromName || {};
  return Object.keys(nodes).some(name => /^\\/plans\\/kart\\d+\\/wp\\d+$/.test(name) && nodes[name].visible);
}"""


CAMERA_POSITION = "() => window.__viserMutable.camera.position.toArray()"


def _positions(page: Page) -> list[list[float]]:
    return [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)]


def test_viewer_in_a_real_browser(live_race: tuple[str, str]) -> None:
    base, race_id = live_race
    outside: list[str] = []
    with browser_page(PAGE_2D, outside=outside) as page:
        # the start page lists the race with a link to its viewer
        page.goto(f"{base}/")
        row = page.locator(f'tr[data-race-id="{race_id}"]')
        row.wait_for()
        assert "oval" in row.inner_text()
        assert row.locator(f'a[href="/races/{race_id}/viewer/"]').count() == 1
        readme_screenshot(page, "start.png")

        # the viewer connects and shows the scene
        page.set_viewport_size(VIEW_3D)
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
            assert time.monotonic() < deadline, "karts never moved"
            page.wait_for_timeout(250)
        # and go on moving (a loaded machine delivers the view's frames in bursts: up to 10 s for half a metre)
        before, deadline = [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)], time.monotonic() + 10
        while max(math.dist(a, b) for a, b in zip(before, _positions(page), strict=True)) <= 0.5:
            assert time.monotonic() < deadline, "karts stopped moving"
            page.wait_for_timeout(250)

        # the planners' waypoints show up as green boxes
        page.wait_for_function(ANY_WAYPOINT_VISIBLE, timeout=90_000)
        calls = page.evaluate("() => window.__viserTestpoints?.rendererInfo?.render?.calls ?? -1")
        assert calls != 0, "the renderer draws nothing"
        # the canvas is nearly transparent until the environment map is ready (slow with software WebGL)
        page.wait_for_function("() => ['', '1'].includes(window.__viserMutable?.canvas?.style.opacity)")
        # the README's pictures without viser's "software WebGL" notice (this machine has no GPU)
        page.add_style_tag(content="[class*='Notification-root'] { display: none !important; }")
        readme_screenshot(page, "viewer.png")

        # a viewer's own "Follow" dropdown: its camera then chases the kart
        page.get_by_role("combobox", name="Follow").click()
        page.get_by_role("option", name="1: MCTS").click()
        page.wait_for_function(CAMERA_NEAR_KART0)
        camera, deadline = page.evaluate(CAMERA_POSITION), time.monotonic() + 10
        while math.dist(camera, page.evaluate(CAMERA_POSITION)) <= 0.5:
            assert time.monotonic() < deadline, "the follow camera stands still"
            page.wait_for_timeout(250)
        readme_screenshot(page, "viewer-follow.png")
    assert not outside, f"requests left the machine: {outside[:5]}"
