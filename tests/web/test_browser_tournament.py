"""The tournament pages in a real browser: Debian's chromium (driven by Playwright) launches a tiny round robin from
the tournaments page's form and follows it to its results.

Through the real server (no 3D view, one tournament worker, a temporary database). Screenshots go to ``test-
artifacts/`` and, under ``make screenshots``, ``docs/screenshots/tournament.png``. Skipped only when no chromium
binary is installed.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

import httpx
import pytest
from support.browser import ARTIFACTS, PAGE_2D, browser_page, readme_screenshot, requires_chromium
from support.live_server import LiveServer, server_settings

if TYPE_CHECKING:
    from playwright.sync_api import Page

pytestmark = [requires_chromium, pytest.mark.slow]

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
    assert page.get_by_label("conditions").input_value() == "varied"  # a tournament's default
    page.get_by_label("conditions").select_option("paper")
    page.get_by_role("button", name="Start tournament").click()
    page.wait_for_url(f"{base}/tournaments/{TOURNAMENT_ID}")
    shown = page.locator("#spec dt", has_text="conditions").locator("xpath=following-sibling::dd[1]")
    assert shown.inner_text() == "paper"
    stored = httpx.get(f"{base}/api/tournaments/{TOURNAMENT_ID}", timeout=30).json()
    assert stored["spec"]["conditions"] == "paper"


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
    # the pair's win rate with its interval and the ratings, as the API's tables
    tables = httpx.get(f"{base}/api/tournaments/{TOURNAMENT_ID}/tables", timeout=30).json()
    pair = page.locator('table.pairs[data-track="oval"] tr[data-agent="fixed-lqng vs lane-follower"] td')
    assert pair.all_inner_texts() == tables["tracks"]["oval"]["pairs"][1][1:]
    assert page.locator("table.ratings tbody tr").count() == 2

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
    base = tournament_server
    ARTIFACTS.mkdir(exist_ok=True)
    outside: list[str] = []
    with browser_page(PAGE_2D, outside=outside) as page:
        _launch_from_the_form(page, base)
        seen = _follow_the_progress(page)
        assert "2 / 2 races" in seen and any(text.startswith(("0 / 2", "1 / 2")) for text in seen), seen
        _check_the_results(page, base)
        _follow_a_race_link(page, base)
        _check_the_list_and_the_leaderboard(page, base)
        _an_unknown_tournament_is_said_so(page, base)
    assert not outside, f"requests left the machine: {outside[:5]}"
