"""LQNG tracker settings for measuring a setting before it is shipped, from the environment: MCTS_TRACKER (or
TRACKER), a JSON object of ``LQNGParams`` fields set on every mcts-lqng tracker; FIXED_TRACKER, the same for
fixed-lqng's. :func:`apply` wraps the two registered builders, so the fields win over the registry's public
parameters (``grip_steer`` among them, whose default the builder would otherwise write over a changed preset).
Call it before any worker process forks."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import controllers.registry as registry


def _overridden(
    build: Callable[[Any], Any], fields: dict[str, Any], public: dict[str, Any] | None = None
) -> Callable[[Any], Any]:
    def build_with(params: Any) -> Any:
        driver = build(replace(params, **(public or {})))
        driver.tracker.params = replace(driver.tracker.params, **fields)
        return driver

    return build_with


def install(name: str, fields: dict[str, Any], public: dict[str, Any] | None = None) -> None:
    """Wrap registered controller ``name``'s builder: its public parameters changed by ``public``, then its
    tracker's ``fields`` set (they win over the public parameters)."""
    spec = registry.controller_spec(name)
    assert spec.build is not None and spec.params_type is not None
    build = _overridden(spec.build, fields, public)
    registry._BY_NAME[name] = replace(spec, build=build, factory=lambda b=build, t=spec.params_type: b(t()))  # type: ignore[misc]


def apply() -> dict[str, dict[str, Any]]:
    """Wrap mcts-lqng's and fixed-lqng's builders with the environment's fields; returns them by agent."""
    settings = {
        "mcts-lqng": json.loads(os.environ.get("MCTS_TRACKER") or os.environ.get("TRACKER") or "{}"),
        "fixed-lqng": json.loads(os.environ.get("FIXED_TRACKER", "{}")),
    }
    for name, fields in settings.items():
        if fields:
            install(name, fields)
    return settings
