"""Debian's chromium for the real-browser tests (Playwright cannot download browsers here), and what those tests
share: the scene probes, the screenshots, the skip mark."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from playwright.sync_api import Page, ViewportSize

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


# viser's client exposes its three.js scene to tests (``window.__viserMutable.nodeRefFromName[name]``, viser 1.1.x)
NODE_POSITION = (
    "name => { const n = window.__viserMutable?.nodeRefFromName?.[name]; return n ? n.position.toArray() : null; }"
)
CAMERA_NEAR_KART0 = """() => {
  const m = window.__viserMutable.nodeRefFromName['/karts/kart0'].matrixWorld.elements;  // three.js world frame
  const c = window.__viserMutable.camera.position;
  return Math.hypot(c.x - m[12], c.y - m[13], c.z - m[14]) < 25;
}"""

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
SCREENSHOTS = ROOT / "docs" / "screenshots"  # the README's pictures (``make screenshots``)
# ``make screenshots`` sets this: the browser tests then draw at the README's size and refresh its pictures
README_SHOTS = os.environ.get("KARTING_README_SCREENSHOTS") == "1"
# chromium draws WebGL in software here, every frame, so a 3D page costs CPU in proportion to its pixels: the
# tests draw a quarter of the README's pixels (the layout is the same: viser's narrow layout starts below 768 px)
VIEW_3D: ViewportSize = {"width": 1280, "height": 800} if README_SHOTS else {"width": 800, "height": 480}
PAGE_2D: ViewportSize = {"width": 1280, "height": 900}
LOCAL_PREFIXES = ("http://127.0.0.1", "ws://127.0.0.1", "data:", "blob:")


def readme_screenshot(page: Page, name: str, *, full_page: bool = False) -> None:
    """A screenshot into ``test-artifacts/`` and, when refreshing the README's pictures, ``docs/screenshots/``."""
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / name), full_page=full_page)
    if README_SHOTS:
        SCREENSHOTS.mkdir(parents=True, exist_ok=True)
        (SCREENSHOTS / name).write_bytes((ARTIFACTS / name).read_bytes())


@contextmanager
def browser_page(
    viewport: ViewportSize, *, timeout_s: float = 60.0, outside: list[str] | None = None
) -> Iterator[Page]:
    """A page of a fresh headless chromium at ``viewport``, closed afterwards; every request that leaves the
    machine is appended to ``outside`` (when given)."""
    from playwright.sync_api import sync_playwright

    binary = chromium_binary()
    assert binary is not None, "no chromium binary"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=binary, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport=viewport)
            if outside is not None:
                page.on("request", lambda r: None if r.url.startswith(LOCAL_PREFIXES) else outside.append(r.url))
            page.set_default_timeout(timeout_s * 1000)
            yield page
        finally:
            browser.close()


requires_chromium = pytest.mark.skipif(
    chromium_binary() is None, reason="no chromium binary (run scripts/install_browser.sh to install Debian's)"
)
