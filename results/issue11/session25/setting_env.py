"""A whole mcts-lqng setting from the environment, for measuring it before it is shipped: MCTS_SETTING, a JSON
object ``{"public": {...}, "tracker": {...}}`` (the registry's public parameters of mcts-lqng, then fields of its
LQ tracker, as ``random_search.py`` samples them); FIXED_TRACKER, ``LQNGParams`` fields set on fixed-lqng's
tracker (a control). :func:`apply` wraps the registered builders; call it before any worker forks.
``python setting_env.py SCRIPT ARGS...`` runs SCRIPT with the setting applied."""

from __future__ import annotations

import json
import os
import runpy
import sys
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import controllers.registry as registry


def _wrapped(build: Callable[[Any], Any], public: dict[str, Any], tracker: dict[str, Any]) -> Callable[[Any], Any]:
    def build_with(params: Any) -> Any:
        driver = build(replace(params, **public))
        driver.tracker.params = replace(driver.tracker.params, **tracker)
        return driver

    return build_with


def apply() -> dict[str, Any]:
    """Wrap mcts-lqng's and fixed-lqng's builders with the environment's settings; returns them."""
    setting = json.loads(os.environ.get("MCTS_SETTING") or '{"public": {}, "tracker": {}}')
    fixed = json.loads(os.environ.get("FIXED_TRACKER") or "{}")
    for name, public, tracker in (
        ("mcts-lqng", setting["public"], setting["tracker"]),
        ("fixed-lqng", {}, fixed),
    ):
        if not public and not tracker:
            continue
        spec = registry.controller_spec(name)
        assert spec.build is not None and spec.params_type is not None
        build = _wrapped(spec.build, public, tracker)
        registry._BY_NAME[name] = replace(spec, build=build, factory=lambda b=build, t=spec.params_type: b(t()))  # type: ignore[misc]
    return {"mcts-lqng": setting, "fixed-lqng": fixed}


if __name__ == "__main__":
    apply()
    script = sys.argv[1]
    sys.argv = sys.argv[1:]
    runpy.run_path(script, run_name="__main__")
