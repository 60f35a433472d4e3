"""A person drives in a real browser: Debian's chromium (driven by Playwright) opens the drive page of a human kart.

Through the real server (3D views on, real time, a temporary database): a race of "Ada" (human) against "Bot" (the
lane follower) on the oval. The race waits for the page's 3D view, counts down on the page (and in telemetry)
with no kart moving although the throttle key is held, then the kart answers the keyboard; the view chases the
driven kart; a gamepad (``navigator.getGamepads`` replaced in the page) steers with its left stick; at the end
the page states the driver's own result, the winner by name, no "reconnect" button, and "Race again" starts the
same race anew; the first race's link, opened again, shows its end. Screenshots: ``test-artifacts/
drive-countdown.png``, ``drive-running.png``, ``drive-end.png``. No request may leave the machine. Skipped only
when no chromium binary is installed.
"""

from __future__ import annotations

import json
import math
import re
import threading
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from support.browser import ARTIFACTS, VIEW_3D, browser_page, requires_chromium
from support.live_server import LiveServer, server_settings, start_race, wait_for
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

RACE = {
    "track": "oval",
    "laps": 1,
    "seed": 3,
    "karts": [{"controller": "human", "name": "Ada"}, {"controller": "lane-follower", "name": "Bot"}],
}
BEFORE_THE_START = ("starting", "waiting", "countdown")


pytestmark = [requires_chromium, pytest.mark.slow]

# the page's gamepad: whatever the test puts in window.__pad (null: none connected)
FAKE_GAMEPADS = """
window.__pad = null;
Object.defineProperty(navigator, "getGamepads", {configurable: true, value: () => [window.__pad]});
"""
CAMERA_NEAR_OWN_KART = """() => {
  const m = window.__viserMutable?.nodeRefFromName?.['/karts/kart0']?.matrixWorld?.elements;
  const c = window.__viserMutable?.camera?.position;
  return Boolean(m && c) && Math.hypot(c.x - m[12], c.y - m[13], c.z - m[14]) < 25;
}"""


class Telemetry:
    """Every frame of a race's telemetry websocket, read in a thread."""

    def __init__(self, url: str) -> None:
        self.frames: list[dict[str, Any]] = []
        self._ws = connect(url, open_timeout=10)
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            for raw in self._ws:
                message = json.loads(raw)
                if message["type"] == "frame":
                    self.frames.append(message)
        except ConnectionClosed:
            return

    def close(self) -> None:
        """Stop reading."""
        self._ws.close()
        self._thread.join(5)

    def kart(self, index: int) -> dict[str, Any] | None:
        """Kart ``index`` in the newest frame."""
        return self.frames[-1]["karts"][index] if self.frames else None


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    db = tmp_path_factory.mktemp("drive-browser") / "karting.db"
    # the race waits up to 2 min for the page's 3D view (30 s by default), which a loaded machine may take to load
    settings = server_settings(db, viewer_enabled=True, speedup=1.0, keep_finished_s=60.0, view_ready_wait_s=120.0)
    with LiveServer(settings) as server:
        yield server


def positions(frame: dict[str, Any]) -> list[tuple[float, float]]:
    return [(k["x"], k["y"]) for k in frame["karts"]]


def test_a_person_drives_a_race_in_a_real_browser(live: LiveServer) -> None:
    ARTIFACTS.mkdir(exist_ok=True)
    client = live.client()
    race = start_race(client, **RACE)
    telemetry = Telemetry(f"{live.ws_url}/api/races/{race['id']}/telemetry")
    outside: list[str] = []
    try:
        with browser_page(VIEW_3D, timeout_s=90, outside=outside) as page:
            page.add_init_script(FAKE_GAMEPADS)
            link = f"{live.url}{race['karts'][0]['drive_url']}"
            page.goto(link)

            _the_race_counts_down_with_nothing_moving(page, telemetry)
            _the_kart_answers_the_keyboard_and_the_view_chases_it(page, telemetry)
            _a_gamepad_steers(page, telemetry)
            _the_end_states_my_result(page, client, telemetry, race)
            _race_again_starts_the_same_race(page, client, race, link)
    finally:
        telemetry.close()
        client.close()
    assert not outside, f"requests left the machine: {outside[:5]}"


def _the_race_counts_down_with_nothing_moving(page: Any, telemetry: Telemetry) -> None:
    """The page waits for its view, then shows a countdown; the throttle key is held from then on, but nothing
    moves (telemetry) until the countdown is over."""
    countdown = page.locator("#countdown")
    countdown.wait_for(state="visible")
    shown = {countdown.inner_text()}
    page.keyboard.down("ArrowUp")
    page.screenshot(path=str(ARTIFACTS / "drive-countdown.png"))
    while page.locator("#race-status").inner_text() != "running":
        if countdown.is_visible():
            shown.add(countdown.inner_text())
        page.wait_for_timeout(50)
    # the page shows the count (on a loaded machine it may paint only some of its numbers: the telemetry below
    # says the count ran through)
    assert shown and shown <= {"1", "2", "3"}, shown
    wait_for(lambda: any(f["status"] == "running" for f in telemetry.frames), 10)
    before = [f for f in telemetry.frames if f["status"] in BEFORE_THE_START]
    counting = [f for f in before if f["status"] == "countdown"]
    assert counting and all(0 < f["countdown"] <= 3.0 for f in counting)
    assert len({math.ceil(f["countdown"]) for f in counting}) >= 2  # it counted down, not one number held
    assert all(positions(f) == positions(before[0]) and f["step"] == 0 for f in before), "a kart moved early"


def _the_kart_answers_the_keyboard_and_the_view_chases_it(page: Any, telemetry: Telemetry) -> None:
    wait_for(lambda: (telemetry.kart(0) or {}).get("speed", 0.0) > 3.0, 15)  # ArrowUp held since the countdown
    assert "Go!" in page.locator("#log").inner_text()  # the start event, shown as a toast and logged
    viewer = next(f for f in page.frames if "/viewer/" in f.url)
    viewer.wait_for_function(CAMERA_NEAR_OWN_KART)  # the view starts on the chase camera of the driven kart
    page.screenshot(path=str(ARTIFACTS / "drive-running.png"))
    page.keyboard.up("ArrowUp")


def _a_gamepad_steers(page: Any, telemetry: Telemetry) -> None:
    """The left stick full left (axes[0] = -1) steers left (steer > 0); the right trigger accelerates."""
    buttons = [{"value": 0.0, "pressed": False} for _ in range(16)]
    buttons[7] = {"value": 0.5, "pressed": True}
    pad = {"id": "Test pad (STANDARD GAMEPAD)", "connected": True, "axes": [-1.0, 0.0, 0.0, 0.0], "buttons": buttons}
    page.evaluate("pad => { window.__pad = pad; }", pad)
    wait_for(lambda: (telemetry.kart(0) or {}).get("steer", 0.0) > 0.5, 10)
    assert "gamepad" in page.locator("#input-source").inner_text()
    centred = {**pad, "axes": [0.05, 0.0, 0.0, 0.0]}  # inside the deadzone
    page.evaluate("pad => { window.__pad = pad; }", centred)
    wait_for(lambda: abs((telemetry.kart(0) or {}).get("steer", 1.0)) < 0.05, 10)


def _the_end_states_my_result(page: Any, client: httpx.Client, telemetry: Telemetry, race: dict[str, Any]) -> None:
    """Once the bot finished, the race is stopped: the page states Ada's place, time and safety figures and the
    winner by name; no reconnect button."""
    page.evaluate("() => { window.__pad = null; }")
    wait_for(lambda: (telemetry.kart(1) or {}).get("finished"), 120)
    assert client.post(f"/api/races/{race['id']}/stop").status_code in (200, 202)
    end = page.locator("#end")
    end.wait_for(state="visible")
    you = page.locator("#end-you").inner_text()
    assert re.fullmatch(r"You \(Ada\): P[12] of 2, did not finish", you), you
    assert re.fullmatch(
        r"Collisions at fault: \d+ · illegal lane changes: \d+ · wall hits: \d+",
        page.locator("#end-safety").inner_text(),
    )
    assert re.fullmatch(r"Winner: Bot, in \d+\.\d\d s", page.locator("#end-winner").inner_text())
    assert page.locator("#reconnect").is_hidden()
    page.screenshot(path=str(ARTIFACTS / "drive-end.png"))


def _race_again_starts_the_same_race(page: Any, client: httpx.Client, race: dict[str, Any], first_link: str) -> None:
    old = race["id"]
    page.get_by_role("button", name="Race again").click()
    page.wait_for_url(lambda url: f"/races/{old}/" not in url)
    new = re.search(r"/races/([^/]+)/drive\?kart=0&token=.+", page.url)
    assert new is not None, page.url
    again = client.get(f"/api/races/{new.group(1)}").json()
    before = client.get(f"/api/races/{old}").json()
    for key in ("track", "laps", "seed", "kart_preset", "start_lanes"):
        assert again[key] == before[key], key
    assert [(k["name"], k["controller"]) for k in again["karts"]] == [("Ada", "human"), ("Bot", "lane-follower")]
    page.locator("#countdown").wait_for(state="visible")  # the new race waits for this page's view again
    client.post(f"/api/races/{new.group(1)}/stop")
    # the first race's link, opened again later, shows its end as it was
    page.goto(first_link)
    page.locator("#end").wait_for(state="visible")
    assert page.locator("#end-you").inner_text().startswith("You (Ada): P")
    assert page.locator("#reconnect").is_hidden() and page.locator("#conn").inner_text() == "race over"
