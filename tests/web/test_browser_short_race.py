"""A short race's server in a real browser: Debian's chromium (driven by Playwright) watches a finished race's
viewer URL settle on its replay, reads the API docs offline, and opens the start page at a phone's width.

Through the real server (3D views on, a one-lap race of two lane followers at 10 times real time, a temporary
database). Skipped only when no chromium binary is installed.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import httpx
import pytest
from support.browser import PAGE_2D, VIEW_3D, browser_page, readme_screenshot, requires_chromium
from support.live_server import LiveServer, server_settings, wait_for

from web.frame import TEAM_COLORS

if TYPE_CHECKING:
    from playwright.sync_api import Page, ViewportSize

PHONE: ViewportSize = {"width": 390, "height": 844}

pytestmark = [requires_chromium, pytest.mark.slow]

SETTLE_S = 6.0  # [s] a finished race's viewer URL is watched this long
MAX_REQUESTS_WHILE_SETTLED = 25  # in SETTLE_S: a page and its assets, a few polls; a reload loop makes hundreds


class Traffic:
    """Page loads, requests (with their hosts) and websockets of a Playwright page, counted from :meth:`reset`."""

    def __init__(self, page: Page) -> None:
        self.loads = 0
        self.requests: list[str] = []
        self.websockets = 0
        page.on("load", lambda _page: self._add_load())
        page.on("request", lambda r: self.requests.append(r.url))
        page.on("websocket", lambda _ws: self._add_websocket())

    def _add_load(self) -> None:
        self.loads += 1

    def _add_websocket(self) -> None:
        self.websockets += 1

    def reset(self) -> None:
        """Count from now."""
        self.loads, self.requests, self.websockets = 0, [], 0

    def summary(self) -> str:
        """What was counted, for assertion messages."""
        return f"{self.loads} loads, {len(self.requests)} requests, {self.websockets} websockets: {self.requests[:8]}"


@pytest.fixture(scope="module")
def short_lived_race(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """(base URL, race id) of a one-lap race of two lane followers (teams Blue and Red) on a server with 3D views
    that drops a finished race's scene 2 s after its end (``keep_finished_s``; 60 s by default) and races 10 times
    real time."""
    db = tmp_path_factory.mktemp("browser-finished") / "karting.db"
    settings = server_settings(db, viewer_enabled=True, keep_finished_s=2.0, speedup=10.0)
    with LiveServer(settings) as server:
        karts = [{"controller": "lane-follower", "team": "Blue"}, {"controller": "lane-follower", "team": "Red"}]
        body = {"track": "oval", "laps": 1, "karts": karts}
        response = httpx.post(f"{server.url}/api/races", json=body, timeout=60)
        assert response.status_code == 201, response.text
        yield server.url, str(response.json()["id"])


def _live_view_closed(base: str, race_id: str) -> bool:
    race = httpx.get(f"{base}/api/races/{race_id}", timeout=30).json()
    return race["status"] == "finished" and race["viewer_url"] != f"/races/{race_id}/viewer/"


def _check_the_replay_player(page: Page, race_id: str) -> None:
    assert httpx.URL(page.url).path == f"/races/{race_id}/replay/", page.url
    page.get_by_text("Play").first.wait_for()


def test_a_finished_races_viewer_settles(short_lived_race: tuple[str, str]) -> None:
    """A viewer tab open when the race ends moves once to the race's replay player and stays there; opening the
    viewer URL long after the end lands on the replay at once: at most 2 page loads and a bounded number of
    requests and websockets in 10 s either way (a wait page that reloads itself, or a view that reconnects, makes
    hundreds). A race over with nothing recorded answers the
    "race over" page instead (``web/static/race-over.html``)."""
    base, race_id = short_lived_race
    with browser_page(VIEW_3D) as page:
        traffic = Traffic(page)
        page.goto(f"{base}/races/{race_id}/viewer/")  # the viser page, or the wait page while it starts
        wait_for(lambda: _live_view_closed(base, race_id), 90, 0.2)
        page.wait_for_url(f"**/races/{race_id}/replay/**", timeout=60_000)
        _check_the_replay_player(page, race_id)
        traffic.reset()
        page.wait_for_timeout(SETTLE_S * 1000)
        assert traffic.loads == 0, traffic.summary()
        assert len(traffic.requests) <= MAX_REQUESTS_WHILE_SETTLED, traffic.summary()
        assert traffic.websockets <= 1, traffic.summary()
        _check_the_replay_player(page, race_id)

        # long after the end: a fresh visit settles on its first load
        traffic.reset()
        page.goto(f"{base}/races/{race_id}/viewer/")
        page.wait_for_timeout(SETTLE_S * 1000)
        assert traffic.loads <= 2 and traffic.websockets <= 1, traffic.summary()
        assert len(traffic.requests) <= MAX_REQUESTS_WHILE_SETTLED, traffic.summary()
        _check_the_replay_player(page, race_id)

        unknown = page.goto(f"{base}/races/no-such-race/viewer/")
        assert unknown is not None and unknown.status == 404
        assert "No race" in page.locator("h2").inner_text()


def test_the_api_docs_render_offline(short_lived_race: tuple[str, str]) -> None:
    """/docs (Swagger UI) and /redoc (ReDoc) render the API's operations from assets the app serves: every
    request the browser makes is recorded by route interception, and none may leave 127.0.0.1."""
    from playwright.sync_api import Route

    base, _race_id = short_lived_race
    hosts: list[str] = []

    def record(route: Route) -> None:
        host = httpx.URL(route.request.url).host or route.request.url.split(":", 1)[0]
        hosts.append(host)
        if host == "127.0.0.1" or route.request.url.startswith(("data:", "blob:")):
            route.continue_()
        else:
            route.abort()

    with browser_page(PAGE_2D) as page:
        page.route("**/*", record)
        page.goto(f"{base}/docs")
        page.locator(".opblock").first.wait_for()
        paths = page.locator(".opblock-summary-path").all_inner_texts()
        assert "/api/races" in paths and "/api/races/{race_id}/result" in paths, paths
        page.goto(f"{base}/redoc")
        page.get_by_text("Start a race", exact=False).first.wait_for()
        assert page.locator("[data-section-id^='operation/']").count() >= 5
    assert hosts and set(hosts) <= {"127.0.0.1"}, f"requests left 127.0.0.1: {sorted(set(hosts))}"


def test_the_start_page_fits_a_phone(short_lived_race: tuple[str, str]) -> None:
    """At 390 px wide (a phone) the start page never scrolls sideways, lists the race and its form still works:
    the form's limits are the API's (GET /api/limits)."""
    base, race_id = short_lived_race
    limits = httpx.get(f"{base}/api/limits", timeout=30).json()
    with browser_page(PHONE) as page:
        page.goto(f"{base}/")
        page.locator(f'tr[data-race-id="{race_id}"]').wait_for()
        page.locator("#karts input").first.wait_for()
        widths = page.evaluate("() => [document.documentElement.scrollWidth, window.innerWidth]")
        assert widths[0] <= widths[1], f"the page scrolls sideways: {widths}"
        assert page.locator("#laps").get_attribute("max") == str(limits["max_laps"])
        counts = page.locator("#n-karts option").all_inner_texts()
        assert counts == [str(n) for n in range(limits["min_karts"], limits["max_karts"] + 1)]
        name = page.get_by_label("name of kart 1")
        assert name.get_attribute("maxlength") == str(limits["max_name_length"])
        assert name.input_value() == "mcts-lqng 1"  # the API's default name
        row = page.locator(f'tr[data-race-id="{race_id}"]')
        assert "1 lap" in row.inner_text()
        badges = [row.locator(f'.team[data-team="{team}"]') for team in ("Blue", "Red")]  # in the teams' colours
        colours = [badge.evaluate("b => getComputedStyle(b).borderTopColor") for badge in badges]
        assert colours == [f"rgb({r}, {g}, {b})" for r, g, b in TEAM_COLORS[:2]]
        readme_screenshot(page, "start-phone.png", full_page=True)
