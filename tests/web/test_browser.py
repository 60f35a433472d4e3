"""Real-browser tests: Debian's chromium (driven by Playwright) opens the start page and a live race viewer, a
finished race's viewer URL (it settles: no page reloading itself), the API docs offline and the tournament pages.

Through the real server (``server.app.create_app`` under uvicorn, a temporary database): ``POST /api/races``
(MCTS-LQNG vs Fixed-LQNG on the oval), then the start page must list the race, and the viewer must connect, show
both karts moving and the green waypoint boxes of the planners, and its "Follow" dropdown must make the camera
chase a kart. No request may leave the machine.

viser's client exposes its three.js scene to tests (``window.__viserMutable.nodeRefFromName[name]``, viser
1.1.x). Screenshots go to ``test-artifacts/viewer.png`` (overview) and ``test-artifacts/viewer-follow.png``; the
ones the README shows also go to ``docs/screenshots/``.
Skipped only when no chromium binary is installed (``scripts/install_browser.sh`` installs Debian's;
``playwright install`` needs the internet).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import httpx
import pytest
from support.browser import CHROMIUM_ARGS, chromium_binary
from support.live_server import LiveServer, ServerThread, server_settings, wait_for

if TYPE_CHECKING:
    from playwright.sync_api import Page

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
SCREENSHOTS = ROOT / "docs" / "screenshots"  # the README's pictures, refreshed by every run of these tests


def readme_screenshot(page: Page, name: str, *, full_page: bool = False) -> None:
    """A screenshot into ``test-artifacts/`` and, for the README, ``docs/screenshots/``."""
    ARTIFACTS.mkdir(exist_ok=True)
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / name), full_page=full_page)
    (SCREENSHOTS / name).write_bytes((ARTIFACTS / name).read_bytes())


pytestmark = pytest.mark.skipif(
    chromium_binary() is None, reason="no chromium binary (run scripts/install_browser.sh to install Debian's)"
)


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
            "laps": 3,
            "seed": 7,
            "start_lanes": None,
            "kart_preset": "paper",
            "karts": [{"controller": "mcts-lqng", "name": "MCTS"}, {"controller": "fixed-lqng", "name": "Fixed"}],
        }
        response = httpx.post(f"{base}/api/races", json=body, timeout=60)
        assert response.status_code == 201, response.text
        yield base, str(response.json()["id"])


# ---------------------------------------------------------------------------------------------- the test
NODE_POSITION = (
    "name => { const n = window.__viserMutable?.nodeRefFromName?.[name]; return n ? n.position.toArray() : null; }"
)
ANY_WAYPOINT_VISIBLE = """() => {
  const nodes = window.__viserMutable?.nodeRefFromName || {};
  return Object.keys(nodes).some(name => /^\\/plans\\/kart\\d+\\/wp\\d+$/.test(name) && nodes[name].visible);
}"""

CAMERA_NEAR_KART0 = """() => {
  const m = window.__viserMutable.nodeRefFromName['/karts/kart0'].matrixWorld.elements;  // three.js world frame
  const c = window.__viserMutable.camera.position;
  return Math.hypot(c.x - m[12], c.y - m[13], c.z - m[14]) < 25;
}"""


def test_viewer_in_a_real_browser(live_race: tuple[str, str]) -> None:
    from playwright.sync_api import sync_playwright

    base, race_id = live_race
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
            readme_screenshot(page, "start.png")

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
                assert time.monotonic() < deadline, "karts never moved"
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
            # the README's pictures without viser's "software WebGL" notice (this machine has no GPU)
            page.add_style_tag(content="[class*='Notification-root'] { display: none !important; }")
            readme_screenshot(page, "viewer.png")

            # a viewer's own "Follow" dropdown: its camera then chases the kart
            page.get_by_role("combobox", name="Follow").click()
            page.get_by_role("option", name="1: MCTS").click()
            page.wait_for_function(CAMERA_NEAR_KART0)
            cameras = [page.evaluate("() => window.__viserMutable.camera.position.toArray()")]
            page.wait_for_timeout(500)
            cameras.append(page.evaluate("() => window.__viserMutable.camera.position.toArray()"))
            assert math.dist(*cameras) > 0.5, f"the follow camera stands still: {cameras}"
            readme_screenshot(page, "viewer-follow.png")
        finally:
            browser.close()
    assert not outside, f"requests left the machine: {outside[:5]}"


# ---------------------------------------------------------------------------------------------- tournaments
TOURNAMENT_ID = "browser-t"


@pytest.fixture(scope="module")
def tournament_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """Base URL of the real server (no 3D view, one tournament worker, a temporary DB) for the tournament pages."""
    db = tmp_path_factory.mktemp("browser-tournament") / "karting.db"
    with LiveServer(server_settings(db, tournament_workers=1)) as server:
        yield server.url


def _launch_from_the_form(page: Page, base: str) -> None:
    """Open the tournaments page from the start page's navigation; one agent gets the API's 422; then launch."""
    page.goto(f"{base}/")
    page.get_by_role("navigation").get_by_role("link", name="Tournaments").click()
    page.wait_for_url(f"{base}/tournaments")
    page.get_by_label("fixed-lqng", exact=True).check()
    assert page.get_by_label("oval", exact=True).is_checked()  # the default track

    page.get_by_role("button", name="Start tournament").click()
    error = page.locator("#launch-msg.error")
    error.wait_for()
    assert "422: agents: List should have at least 2 items" in error.inner_text()

    page.get_by_label("lane-follower", exact=True).check()
    page.get_by_label("races per pair").fill("2")
    page.get_by_label("laps").fill("1")
    page.get_by_label("time limit [s]").fill("30")
    page.get_by_label("id", exact=True).fill(TOURNAMENT_ID)
    assert page.locator("#size-hint").inner_text() == "2 races in all"
    page.get_by_label("start spread [s]").fill("3")
    page.get_by_role("button", name="Start tournament").click()
    page.wait_for_function("() => document.querySelector('#launch-msg').textContent.includes('start_spread')")
    assert "422: start_spread: Input should be less than or equal to 2" in error.inner_text()
    page.get_by_label("start spread [s]").fill("0.25")
    page.get_by_role("button", name="Start tournament").click()
    page.wait_for_url(f"{base}/tournaments/{TOURNAMENT_ID}")
    spread = page.locator("#spec dt", has_text="start spread").locator("xpath=following-sibling::dd[1]")
    assert spread.inner_text() == "0.25 s"
    stored = httpx.get(f"{base}/api/tournaments/{TOURNAMENT_ID}", timeout=30).json()
    assert stored["spec"]["start_spread"] == 0.25


def _follow_the_progress(page: Page) -> set[str]:
    """Watch the progress until the tournament is finished; returns the progress texts seen."""
    progress = page.locator("#progress-text")
    seen = {progress.inner_text()}
    deadline = time.monotonic() + 120
    while page.locator("#status").inner_text() != "finished":
        assert time.monotonic() < deadline, f"the tournament did not finish: {seen}"
        seen.add(progress.inner_text())
        page.wait_for_timeout(200)
    seen.add(progress.inner_text())
    assert progress.inner_text() == "2 / 2 races"
    assert page.locator("#progress").get_attribute("aria-valuenow") == "2"
    assert page.locator("#stop").is_hidden()
    return seen


def _check_the_results(page: Page, base: str) -> None:
    """The win matrix (laid out like the paper's, as the API's statistics), the safety table and the plots."""
    wins = page.locator('table.wins[data-track="oval"]')
    wins.wait_for()
    stats = httpx.get(f"{base}/api/tournaments/{TOURNAMENT_ID}/stats", timeout=30).json()
    oval = stats["tracks"]["oval"]["wins"]
    assert wins.locator("thead th").all_inner_texts() == ["agent", "vs fixed-lqng", "vs lane-follower"]
    for agent, other, column in (("fixed-lqng", "lane-follower", 1), ("lane-follower", "fixed-lqng", 0)):
        cells = wins.locator(f'tr[data-agent="{agent}"] td').all_inner_texts()
        assert cells[1 - column] == "-" and cells[column].rstrip("*") == str(oval[agent][other])
    assert page.locator('table.safety[data-track="oval"] tr[data-agent="lane-follower"]').count() == 1
    # wins by start lane: the pair's row as the API's counts (races 0 and 1 start fixed-lqng in lanes 2 and 3)
    split = stats["tracks"]["oval"]["start_lanes"]["pairs"]["fixed-lqng"]["lane-follower"]["by_lane"]
    lanes = page.locator('table.start-lanes[data-track="oval"] tr[data-agent="fixed-lqng vs lane-follower"] td')
    expected = [f"{split[lane]['wins']}–{split[lane]['losses']}" for lane in ("2", "3")]
    assert lanes.all_inner_texts()[:2] == expected
    assert page.locator('table[data-track="combined"]').count() == 0  # one track: no separate combined table

    heatmap = page.locator('figure[data-plot="wins_oval"] img')
    heatmap.scroll_into_view_if_needed()
    page.wait_for_function("img => img.complete && img.naturalWidth > 100", arg=heatmap.element_handle())
    assert page.locator(".plots figure").count() == 3  # wins, safety, finish times
    readme_screenshot(page, "tournament.png", full_page=True)


def _follow_a_race_link(page: Page, base: str) -> None:
    """The first race's result link opens its result; its replay link is the stored replay."""
    race_id = f"{TOURNAMENT_ID}-00000"
    row = page.locator(f'tr[data-race-id="{race_id}"]')
    assert row.locator("a.replay").get_attribute("href") == f"/api/races/{race_id}/replay"
    with page.expect_popup() as popup_info:
        row.locator("a.result").click()
    result_page = popup_info.value
    result_page.wait_for_load_state()
    assert result_page.url == f"{base}/api/races/{race_id}/result"
    assert "lane-follower" in result_page.inner_text("body")
    result_page.close()
    replay = httpx.get(f"{base}/api/races/{race_id}/replay", timeout=30)
    assert replay.status_code == 200 and replay.json()["track"] == "oval"


def _check_the_list_and_the_leaderboard(page: Page, base: str) -> None:
    """The tournaments page lists the tournament as finished and the leaderboard counts its races."""
    page.goto(f"{base}/tournaments")
    listed = page.locator(f'tr[data-tournament-id="{TOURNAMENT_ID}"]')
    listed.wait_for()
    assert "finished" in listed.inner_text() and "2 / 2 races" in listed.inner_text()
    board = page.locator("#leaderboard-rows tr[data-agent]")
    board.first.wait_for()
    agents = board.evaluate_all("rows => rows.map(r => r.dataset.agent)")
    assert sorted(agents) == ["fixed-lqng", "lane-follower"]
    races = page.locator('#leaderboard-rows tr[data-agent="fixed-lqng"] td').nth(3)  # #, agent, tournaments, races
    assert races.inner_text() == "2"
    page.screenshot(path=str(ARTIFACTS / "tournaments.png"), full_page=True)


def _an_unknown_tournament_is_said_so(page: Page, base: str) -> None:
    """An unknown id (with markup in it) is named as text, not markup."""
    page.goto(f"{base}/tournaments/%3Cb%3Enope")
    msg = page.locator("#msg.error")
    msg.wait_for()
    assert "No tournament <b>nope" in msg.inner_text() and page.locator("#msg b").count() == 0


def test_tournament_pages_in_a_real_browser(tournament_server: str) -> None:
    """From the start page's navigation to the tournaments page; the form shows the API's 422, then launches a
    tiny round robin (Fixed-LQNG vs the lane follower, one lap on the oval, 2 races); its page follows the
    progress to the end, shows the win matrix and the plots, and links each race to its result and replay; the
    leaderboard counts the races. No request may leave the machine."""
    from playwright.sync_api import sync_playwright

    base = tournament_server
    ARTIFACTS.mkdir(exist_ok=True)
    outside: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_binary(), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on(
                "request",
                lambda r: outside.append(r.url) if not r.url.startswith(("http://127.0.0.1", "data:")) else None,
            )
            page.set_default_timeout(60_000)
            _launch_from_the_form(page, base)
            seen = _follow_the_progress(page)
            assert "2 / 2 races" in seen and any(text.startswith(("0 / 2", "1 / 2")) for text in seen), seen
            _check_the_results(page, base)
            _follow_a_race_link(page, base)
            _check_the_list_and_the_leaderboard(page, base)
            _an_unknown_tournament_is_said_so(page, base)
        finally:
            browser.close()
    assert not outside, f"requests left the machine: {outside[:5]}"


# ---------------------------------------------------------------------------------------------- after the race
SETTLE_S = 10.0  # [s] a finished race's viewer URL is watched this long
MAX_REQUESTS_WHILE_SETTLED = 25  # in SETTLE_S: a page and its assets, a few polls; a reload loop makes hundreds


class Traffic:
    """Page loads, requests (with their hosts) and websockets of a Playwright page, counted from :meth:`reset`."""

    def __init__(self, page: Page) -> None:
        self.loads = 0
        self.requests: list[str] = []
        self.websockets = 0
        page.on("load", lambda: self._add_load())
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
    """(base URL, race id) of a one-lap race of two lane followers on a server with 3D views that drops a
    finished race's scene 2 s after its end (``keep_finished_s``; 60 s by default) and races 10 times real time."""
    db = tmp_path_factory.mktemp("browser-finished") / "karting.db"
    settings = server_settings(db, viewer_enabled=True, keep_finished_s=2.0, speedup=10.0)
    with LiveServer(settings) as server:
        body = {"track": "oval", "laps": 1, "karts": [{"controller": "lane-follower"}, {"controller": "lane-follower"}]}
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
    requests and websockets in 10 s either way (the wait page used to reload itself about 19 times a second,
    and an open view to reconnect about 50 times a second). A race over with nothing recorded answers the
    "race over" page instead (``web/static/race-over.html``)."""
    from playwright.sync_api import sync_playwright

    base, race_id = short_lived_race
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_binary(), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1024, "height": 640})
            page.set_default_timeout(60_000)
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
        finally:
            browser.close()


def test_the_api_docs_render_offline(short_lived_race: tuple[str, str]) -> None:
    """/docs (Swagger UI) and /redoc (ReDoc) render the API's operations from assets the app serves: every
    request the browser makes is recorded by route interception, and none may leave 127.0.0.1."""
    from playwright.sync_api import Route, sync_playwright

    base, _race_id = short_lived_race
    hosts: list[str] = []

    def record(route: Route) -> None:
        host = httpx.URL(route.request.url).host or route.request.url.split(":", 1)[0]
        hosts.append(host)
        if host == "127.0.0.1" or route.request.url.startswith(("data:", "blob:")):
            route.continue_()
        else:
            route.abort()

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_binary(), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.set_default_timeout(60_000)
            page.route("**/*", record)
            page.goto(f"{base}/docs")
            page.locator(".opblock").first.wait_for()
            paths = page.locator(".opblock-summary-path").all_inner_texts()
            assert "/api/races" in paths and "/api/races/{race_id}/result" in paths, paths
            page.goto(f"{base}/redoc")
            page.get_by_text("Start a race", exact=False).first.wait_for()
            assert page.locator("[data-section-id^='operation/']").count() >= 5
        finally:
            browser.close()
    assert hosts and set(hosts) <= {"127.0.0.1"}, f"requests left 127.0.0.1: {sorted(set(hosts))}"


def test_the_start_page_fits_a_phone(short_lived_race: tuple[str, str]) -> None:
    """At 390 px wide (a phone) the start page never scrolls sideways, lists the race and its form still works:
    the form's limits are the API's (GET /api/limits)."""
    from playwright.sync_api import sync_playwright

    base, race_id = short_lived_race
    limits = httpx.get(f"{base}/api/limits", timeout=30).json()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_binary(), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 390, "height": 844})
            page.set_default_timeout(60_000)
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
            assert "1 lap" in page.locator(f'tr[data-race-id="{race_id}"]').inner_text()
            readme_screenshot(page, "start-phone.png", full_page=True)
        finally:
            browser.close()


# ---------------------------------------------------------------------------------------------- replays
@pytest.fixture(scope="module")
def finished_race(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """(base URL, race id) of a finished two-lap race (the lane follower against Fixed-LQNG on the oval, run
    at 20x) on the real server with 3D views on."""
    from support.live_server import start_race, wait_status

    db = tmp_path_factory.mktemp("browser-replay") / "karting.db"
    settings = server_settings(db, viewer_enabled=True, speedup=20.0, keep_finished_s=1.0)
    with LiveServer(settings) as server, server.client() as client:
        karts = [{"controller": "lane-follower", "name": "LF"}, {"controller": "fixed-lqng", "name": "Fixed"}]
        race = start_race(client, track="oval", laps=2, seed=1, karts=karts)
        wait_status(client, race["id"], ("finished",), 120)
        yield server.url, str(race["id"])


def _kart_positions(page: Page) -> list[list[float]]:
    return [page.evaluate(NODE_POSITION, f"/karts/kart{k}") for k in range(2)]


def _replay_plays_pauses_and_scrubs(page: Page, base: str, race_id: str) -> None:
    """The finished race's viewer address opens its replay player: it starts paused, plays (karts move), pauses
    (karts stop), and the time slider moves the karts to the recorded poses of the time set."""
    poses = httpx.get(f"{base}/api/races/{race_id}/replay", timeout=30).json()["poses"]
    page.goto(f"{base}/races/{race_id}/viewer/")
    page.wait_for_url(f"{base}/races/{race_id}/replay/**")
    for name in ("/karts/kart0", "/karts/kart1", "/track/lanes"):
        page.wait_for_function("name => window.__viserMutable?.nodeRefFromName?.[name] != null", arg=name)
    page.wait_for_function("() => ['', '1'].includes(window.__viserMutable?.canvas?.style.opacity)")

    grid = _kart_positions(page)
    page.wait_for_timeout(600)
    assert _kart_positions(page) == grid, "a paused replay moved"

    page.get_by_role("button", name="Play").click()
    deadline = time.monotonic() + 30
    while _kart_positions(page) == grid:
        assert time.monotonic() < deadline, "the replay never started"
        page.wait_for_timeout(100)
    before = _kart_positions(page)
    page.wait_for_timeout(500)
    after = _kart_positions(page)
    moved = [math.dist(a, b) for a, b in zip(before, after, strict=True)]
    assert max(moved) > 0.5, f"karts did not move in 0.5 s of replay: {moved}"
    readme_screenshot(page, "replay.png")

    page.get_by_role("button", name="Pause").click()
    page.get_by_role("button", name="Play").wait_for()
    page.wait_for_timeout(300)  # the last frame in flight
    paused = _kart_positions(page)
    page.wait_for_timeout(700)
    assert _kart_positions(page) == paused, "karts moved while paused"

    # scrub: type a time into the slider's box; the karts jump to the recorded poses of that moment
    for seconds in (30.0, 10.0):  # forward, then back
        box = page.get_by_role("slider").locator(
            "xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]//input[not(@type='hidden')]"
        )
        box.fill(str(seconds))
        box.press("Enter")
        row = poses[round(seconds / 0.02) - 1]  # the pose after that many steps

        def at_recorded(row: list[list[float]] = row) -> bool:
            shown = _kart_positions(page)
            return all(math.dist(shown[k][:2], row[k][:2]) < 0.01 for k in range(2))

        deadline = time.monotonic() + 10
        while not at_recorded():
            assert time.monotonic() < deadline, f"scrubbing to {seconds} s did not move the karts there"
            page.wait_for_timeout(100)

    # follow a kart: the camera chases it (playing on from 10 s)
    page.get_by_role("combobox", name="Follow").click()
    page.get_by_role("option", name="1: LF").click()
    page.get_by_role("button", name="Play").click()
    page.wait_for_function(CAMERA_NEAR_KART0)
    page.screenshot(path=str(ARTIFACTS / "replay-follow.png"))


def _race_page_shows_charts_and_incidents(page: Page, base: str, race_id: str) -> None:
    """The race page: standings, lap table, the four charts with a line or marks per kart, the incident timeline
    with one mark per incident of the race's report, and links to the replay and the raw JSON."""
    report = httpx.get(f"{base}/api/races/{race_id}/report", timeout=30).json()
    page.goto(f"{base}/races/{race_id}")
    page.locator("body[data-ready='true']").wait_for()
    assert page.locator("#standings tbody tr").count() == 2
    assert page.locator("#laps tbody tr").count() == sum(len(k["laps"]) for k in report["karts"])
    for chart in ("positions", "gaps", "speed", "wear"):
        series = page.locator(f'svg[data-chart="{chart}"] g[data-series]')
        assert series.count() == 2, chart
        for i in range(2):
            assert series.nth(i).locator("polyline, circle").count() > 0, f"{chart}: series {i} is empty"
    assert page.locator('svg[data-chart="speed"] polyline').count() >= 2
    marks = page.locator('svg[data-chart="incidents"] g.incident')
    assert report["incidents"], "the race has no incidents to show"
    assert marks.count() == len(report["incidents"])
    for kind in {i["kind"] for i in report["incidents"]}:
        shown = page.locator(f'svg[data-chart="incidents"] g.incident[data-kind="{kind}"]').count()
        assert shown == sum(i["kind"] == kind for i in report["incidents"]), kind
    assert page.locator("#incidents tbody tr").count() == len(report["incidents"])
    assert page.locator("#viewer-link").get_attribute("href") == f"/races/{race_id}/replay/"
    assert page.locator("#result-link").get_attribute("href") == f"/api/races/{race_id}/result"
    assert page.locator("#replay-json-link").get_attribute("href") == f"/api/races/{race_id}/replay"
    readme_screenshot(page, "race-page.png", full_page=True)


def _live_viewer_moves_to_the_replay(page: Page, base: str) -> None:
    """A live viewer of a race that ends (a race waiting for its human driver, then stopped) moves to the replay
    player by itself: the address the API gives as the race's viewer once it is over."""
    body = {"track": "oval", "laps": 1, "karts": [{"controller": "human"}, {"controller": "lane-follower"}]}
    race = httpx.post(f"{base}/api/races", json=body, timeout=60).json()
    race_id = race["id"]
    page.goto(f"{base}{race['viewer_url']}")
    page.wait_for_function("() => window.__viserMutable?.nodeRefFromName?.['/karts/kart0'] != null")
    assert page.url.startswith(f"{base}/races/{race_id}/viewer/")
    stopped = httpx.post(f"{base}/api/races/{race_id}/stop", timeout=60).json()
    assert stopped["status"] == "stopped" and stopped["viewer_url"] == f"/races/{race_id}/replay/"
    page.wait_for_url(f"{base}/races/{race_id}/replay/**")
    page.get_by_role("button", name="Play").wait_for()


def test_replay_player_and_race_page_in_a_real_browser(finished_race: tuple[str, str]) -> None:
    """A finished race: its viewer address opens the replay player, which plays, pauses and scrubs; its page
    draws the charts and the incident timeline; a live viewer of a race that ends moves to its replay. No
    request may leave the machine."""
    from playwright.sync_api import sync_playwright

    base, race_id = finished_race
    ARTIFACTS.mkdir(exist_ok=True)
    outside: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_binary(), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on(
                "request",
                lambda r: (
                    outside.append(r.url)
                    if not r.url.startswith(("http://127.0.0.1", "ws://127.0.0.1", "data:", "blob:"))
                    else None
                ),
            )
            page.set_default_timeout(60_000)
            _replay_plays_pauses_and_scrubs(page, base, race_id)
            _race_page_shows_charts_and_incidents(page, base, race_id)
            _live_viewer_moves_to_the_replay(page, base)
        finally:
            browser.close()
    assert not outside, f"requests left the machine: {outside[:5]}"
