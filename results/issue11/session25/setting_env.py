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
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parents[1] / "session24"))
import tracker_env


def apply() -> dict[str, Any]:
    """Wrap mcts-lqng's and fixed-lqng's builders with the environment's settings; returns them."""
    setting = json.loads(os.environ.get("MCTS_SETTING") or '{"public": {}, "tracker": {}}')
    fixed = json.loads(os.environ.get("FIXED_TRACKER") or "{}")
    if setting["public"] or setting["tracker"]:
        tracker_env.install("mcts-lqng", setting["tracker"], setting["public"])
    if fixed:
        tracker_env.install("fixed-lqng", fixed)
    return {"mcts-lqng": setting, "fixed-lqng": fixed}


if __name__ == "__main__":
    apply()
    script = sys.argv[1]
    sys.argv = sys.argv[1:]
    runpy.run_path(script, run_name="__main__")
