"""The deployment files: the Dockerfile copies every package the project installs and declares the data volume
and a healthcheck; ``docker-compose config`` accepts docker-compose.yml, whose server keeps its database on a
named volume with a healthcheck, and whose optional ``ray`` profile adds a Ray head and worker with theirs.

No Docker engine runs here: the images are not built and nothing is started (see README, Deployment)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tomllib
from pathlib import Path
from typing import Any

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]


def compose_command() -> list[str]:
    """``docker-compose``, or ``docker compose`` (the plugin); skips the test when neither is installed."""
    if shutil.which("docker-compose"):
        return ["docker-compose"]
    if shutil.which("docker"):
        probe = subprocess.run(["docker", "compose", "version"], capture_output=True, check=False)
        if probe.returncode == 0:
            return ["docker", "compose"]
    pytest.skip("docker-compose is not installed (make test installs it: scripts/install_compose.sh)")


def compose_config(*profiles: str) -> dict[str, Any]:
    """docker-compose.yml as ``docker-compose config`` resolves it with ``profiles`` active."""
    args = [*compose_command(), *(a for p in profiles for a in ("--profile", p)), "config"]
    env = {k: v for k, v in os.environ.items() if k != "KARTING_PUBLISH"}  # the file's defaults, not this shell's
    done = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, check=False, env=env)
    assert done.returncode == 0, done.stderr
    config: dict[str, Any] = yaml.safe_load(done.stdout)
    return config


def test_the_dockerfile_copies_every_installed_package() -> None:
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    packages = {p.rstrip("*") for p in pyproject["tool"]["setuptools"]["packages"]["find"]["include"]}
    dockerfile = (ROOT / "Dockerfile").read_text()
    copied = set(re.findall(r"^COPY (\w+) \./\1$", dockerfile, flags=re.MULTILINE))
    assert packages <= copied, f"not copied into the image: {sorted(packages - copied)}"
    assert 'VOLUME ["/data"]' in dockerfile and "HEALTHCHECK" in dockerfile
    assert "KARTING_DATABASE_URL=sqlite:////data/" in dockerfile


def test_the_server_keeps_its_database_on_a_named_volume_with_a_healthcheck() -> None:
    config = compose_config()
    server = config["services"]["karting"]
    assert "karting-data" in config["volumes"]
    mounts = [v if isinstance(v, str) else f"{v['source']}:{v['target']}" for v in server["volumes"]]
    assert any(m.startswith("karting-data:/data") for m in mounts), mounts
    assert server["environment"]["KARTING_DATABASE_URL"] == "sqlite:////data/karting.db"
    assert "/api/tracks" in " ".join(server["healthcheck"]["test"])
    assert server.get("init") is True  # something reaps the worker processes' exits
    published = [p if isinstance(p, str) else f"{p.get('host_ip', '')}:{p['published']}" for p in server["ports"]]
    assert all(p.startswith("127.0.0.1:") for p in published), published  # loopback unless asked otherwise


def test_the_ray_profile_adds_a_head_and_a_worker_with_healthchecks() -> None:
    config = compose_config("ray")
    head, worker = config["services"]["ray-head"], config["services"]["ray-worker"]
    for service in (head, worker):
        assert service["profiles"] == ["ray"] and service["healthcheck"]["test"]
        assert service["build"]["args"]["EXTRAS"] == "rl,tournament"
    assert "--head" in head["command"] and "--address=ray-head:6379" in worker["command"]
    assert worker["depends_on"]["ray-head"]["condition"] == "service_healthy"
    assert any(str(v).startswith("karting-data:/data") for v in head["volumes"])  # tournaments reach the database
    assert "profiles" not in config["services"]["karting"]  # the server runs without the profile
