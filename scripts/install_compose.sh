#!/usr/bin/env bash
# Install docker-compose for tests/test_deployment.py (which runs `docker-compose config`), once.
#
# Only the command line is needed: `config` reads and checks the file without a Docker engine. Debian's package
# comes from the ordinary apt mirror. Idempotent: does nothing when docker-compose (or the `docker compose`
# plugin) is already there. Uses sudo only when not root; without apt-get or root the test is skipped.
set -euo pipefail

if command -v docker-compose >/dev/null 2>&1 || docker compose version >/dev/null 2>&1; then
    echo "install_compose: docker-compose already installed"
    exit 0
fi

if ! command -v apt-get >/dev/null 2>&1; then
    echo "install_compose: no apt-get here; install docker-compose yourself (the deployment test is skipped)" >&2
    exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        SUDO="sudo"
    else
        echo "install_compose: not root and no sudo; cannot install docker-compose (the test will be skipped)" >&2
        exit 0
    fi
fi

export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends docker-compose
echo "install_compose: installed docker-compose"
