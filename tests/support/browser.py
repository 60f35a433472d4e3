"""Debian's chromium for the real-browser tests (Playwright cannot download browsers here)."""

from __future__ import annotations

import os

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
