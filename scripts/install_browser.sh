#!/usr/bin/env bash
# Install Debian's chromium for the real-browser test (tests/web/test_browser.py), once.
#
# Playwright's own `playwright install chromium` downloads from a CDN, which is not reachable everywhere (CI
# boxes, this project's machines); Debian's package comes from the ordinary apt mirror. Idempotent: does
# nothing when /usr/bin/chromium (or Debian's chromium-headless-shell) is already there. Uses sudo only when
# not root. Set CHROMIUM_PACKAGE to install another package name (e.g. chromium-headless-shell).
set -euo pipefail

if [ -x /usr/bin/chromium ] || [ -x /usr/lib/chromium/chromium-headless-shell ] || [ -x /usr/bin/chromium-headless-shell ]; then
    echo "install_browser: chromium already installed"
    exit 0
fi

if ! command -v apt-get >/dev/null 2>&1; then
    echo "install_browser: no apt-get here; install chromium yourself (the browser test is skipped without it)" >&2
    exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        SUDO="sudo"
    else
        echo "install_browser: not root and no sudo; cannot install chromium (the browser test will be skipped)" >&2
        exit 0
    fi
fi

PACKAGE="${CHROMIUM_PACKAGE:-chromium}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "$PACKAGE"
echo "install_browser: installed $PACKAGE"
