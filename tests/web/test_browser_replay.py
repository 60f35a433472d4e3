"""Replays in a real browser: Debian's chromium (driven by Playwright) plays, pauses and scrubs a finished race's
replay, reads its race page (charts and incidents), and sees a live viewer move to the replay when its race ends.

Through the real server (3D views on, a two-lap race at 20 times real time, a temporary database). Screenshots go to
``test-artifacts/`` and, under ``make screenshots``, ``docs/screenshots/`` (``replay.png``, ``race-page.png``).
Skipped only when no chromium binary is installed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

import httpx
import pytest
from support.browser import (
    ARTIFACTS,
    CAMERA_NEAR_KART0,
    NODE_POSITION,
    PAGE_2D,
    VIEW_3D,
    browser_page,
    readme_screenshot,
    requires_chromium,
)
from support.live_server import LiveServer, server_settings

if TYPE_CHECKING:
    from playwright.sync_api import Page

pytestmark = [requires_chromium, pytest.mark.slow]


@pytest.fixture(scope="module")
def finished_race(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """(base URL, race id) of a finished two-lap race with a collision and a pass (the lane follower from lane 2
    against MCTS-LQNG from lane 3 behind it on the oval, teams Blue and Red, run at 20x in lockstep, so the race is
    its seed's) on the real server with 3D views on."""
    from support.live_server import start_race, wait_status

    db = tmp_path_factory.mktemp("browser-replay") / "karting.db"
    settings = server_settings(db, viewer_enabled=True, speedup=20.0, keep_finished_s=1.0, lockstep=True)
    with LiveServer(settings) as server, server.client() as client:
        karts = [
            {"controller": "lane-follower", "name": "LF", "team": "Blue"},
            {"controller": "mcts-lqng", "name": "MCTS", "team": "Red"},
        ]
        race = start_race(client, track="oval", laps=2, seed=3, start_lanes=[2, 3], karts=karts)
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
    before, deadline = _kart_positions(page), time.monotonic() + 10  # a loaded machine draws in bursts
    while max(math.dist(a, b) for a, b in zip(before, _kart_positions(page), strict=True)) <= 0.5:
        assert time.monotonic() < deadline, "the replay stopped"
        page.wait_for_timeout(250)
    readme_screenshot(page, "replay.png")

    page.get_by_role("button", name="Pause").click()
    page.get_by_role("button", name="Play").wait_for()
    # the frames already in flight land first (later on a loaded machine): wait until two reads agree
    paused, deadline = _kart_positions(page), time.monotonic() + 10
    page.wait_for_timeout(300)
    while (now := _kart_positions(page)) != paused:
        assert time.monotonic() < deadline, "the replay never paused"
        paused = now
        page.wait_for_timeout(300)
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
    for kart, team in ((0, "Blue"), (1, "Red")):  # each kart's team beside its name
        assert page.locator(f'#standings tr[data-kart="{kart}"] .team[data-team="{team}"]').count() == 1
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
    base, race_id = finished_race
    outside: list[str] = []
    with browser_page(VIEW_3D, outside=outside) as page:
        _replay_plays_pauses_and_scrubs(page, base, race_id)
        page.set_viewport_size(PAGE_2D)
        _race_page_shows_charts_and_incidents(page, base, race_id)
        page.set_viewport_size(VIEW_3D)
        _live_viewer_moves_to_the_replay(page, base)
    assert not outside, f"requests left the machine: {outside[:5]}"
