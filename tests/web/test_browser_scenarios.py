"""The scenarios page in a real browser: Debian's chromium (driven by Playwright) starts a small scenario run from
the page's form, after the API's 422 for a form without egos, and shows the run's cells and pass threshold as the
API gives them. Skipped only when no chromium binary is installed."""

from __future__ import annotations

import time
from collections.abc import Iterator

import httpx
import pytest
from support.browser import ARTIFACTS, PAGE_2D, browser_page, readme_screenshot, requires_chromium
from support.live_server import LiveServer, server_settings

pytestmark = [requires_chromium, pytest.mark.slow]


@pytest.fixture(scope="module")
def scenario_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    db = tmp_path_factory.mktemp("browser-scenarios") / "karting.db"
    with LiveServer(server_settings(db, tournament_workers=1)) as server:
        yield server.url


def test_a_scenario_run_from_the_page(scenario_server: str) -> None:
    base = scenario_server
    ARTIFACTS.mkdir(exist_ok=True)
    outside: list[str] = []
    with browser_page(PAGE_2D, outside=outside) as page:
        page.goto(f"{base}/")
        page.get_by_role("navigation").get_by_role("link", name="Scenarios").click()
        page.wait_for_url(f"{base}/scenarios")
        assert page.locator("#scenarios").get_by_label("overtake-straight", exact=True).is_checked()
        page.get_by_role("button", name="Start run").click()
        error = page.locator("#launch-msg.error")
        error.wait_for()
        assert "422: egos: List should have at least 1 item" in error.inner_text()

        page.locator("#egos").get_by_label("fixed-lqng", exact=True).check()
        page.locator("#opponents").get_by_label("lane-follower", exact=True).check()
        page.get_by_label("tracks").fill("oval")
        page.get_by_label("paces").fill("0.8")
        page.get_by_label("attempts per cell").fill("1")
        page.get_by_role("button", name="Start run").click()
        started = page.locator("#launch-msg.ok")
        started.wait_for()
        run_id = started.inner_text().removeprefix("Run ").removesuffix(" started.")
        page.wait_for_function("id => document.getElementById('run-id').textContent === id", arg=run_id)
        deadline = time.monotonic() + 120
        while page.locator("#cell-rows td").count() < 10:
            assert time.monotonic() < deadline, "the run's figures never came"
            page.wait_for_timeout(300)
        run = httpx.get(f"{base}/api/scenarios/runs/{run_id}", timeout=30).json()
        (cell,) = run["summary"]["cells"]
        shown = page.locator("#cell-rows td").all_inner_texts()
        assert shown[:6] == ["overtake-straight", "oval", "fixed-lqng", "lane-follower", "0.8", "1"]
        assert shown[6].startswith(f"{cell['pass_success']:.2f} [")
        r50 = run["summary"]["pass_threshold_r50"]["fixed-lqng"]["lane-follower"]
        expected = "below every pace" if r50 is None else str(r50)
        assert page.locator("#threshold-rows td").all_inner_texts() == ["fixed-lqng", "lane-follower", expected]
        assert page.locator(f'#run-rows tr[data-run-id="{run_id}"]').inner_text().count("finished") == 1
        readme_screenshot(page, "scenarios.png", full_page=True)
    assert not outside, f"requests left the machine: {outside[:5]}"
