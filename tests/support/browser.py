"""Debian's chromium for the real-browser tests (Playwright cannot download browsers here), and what those tests
share: the scene probes, the screenshots, the skip mark."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from playwright.sync_api import Page

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
SCREENSHOTS = ROOT / "docs" / "screenshots"  # the README's pictures, refreshed by every run of the browser tests


def readme_screenshot(page: Page, name: str, *, full_page: bool = False) -> None:
    """A screenshot into ``test-artifacts/`` and, for the README, ``docs/screenshots/``."""
    ARTIFACTS.mkdir(exist_ok=True)
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / name), full_page=full_page)
    (SCREENSHOTS / name).write_bytes((ARTIFACTS / name).read_bytes())


requires_chromium = pytest.mark.skipif(
    chromium_binary() is None, reason="no chromium binary (run scripts/install_browser.sh to install Debian's)"
)
