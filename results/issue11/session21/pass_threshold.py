"""How much slower a kart must be before mcts-lqng gets past it from behind: session 20's measurement
(``../session20/pass_threshold.py``, whose driver loop this reuses) with ``close_following`` (Gipps' safe speed,
standoffs 2.3 m on straights and 3.0 m in curves) and with the default station keeping (``default``: the linear
rule, 3 m + 0.15 s x speed, session 20's). mcts-lqng starts in lane 2 of the track against fixed-lqng at a fraction
``speed_scale`` of its speed targets; seeds 0, 2, 4, ...

Run from the repo root (one JSON line per race, then one summary line per setting and scale)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session21/pass_threshold.py --starts 16
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import typer


def _load(name: str, path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


session20 = _load("session20", Path(__file__).parents[1] / "session20" / "pass_threshold.py")
sweep = _load("sweep", Path(__file__).parent / "sweep" / "sweep.py")

# ``close_following``'s station keeping (``CLOSE_FOLLOWING_TRACKING``), as tracker overrides
CLOSE_FOLLOWING: dict[str, float] = {
    "follow_safe_braking": 6.0,
    "follow_time": 0.05,
    "follow_distance": 2.3,
    "follow_distance_curve": 3.0,
    "follow_brake_gain": 10.0,
}


def race(track: str, setting: str, scale: float, seed: int) -> dict[str, object]:
    """One race from lane 2, seed ``seed``; ``close_following`` or the ``default`` station keeping."""
    overrides = CLOSE_FOLLOWING if setting == "close_following" else {}
    return {"setting": setting, **sweep.race((track, overrides, scale, seed, (2, 3)))}


session20.SETTINGS = ("close_following", "default")
session20.SCALES = (1.0, 0.98, 0.97, 0.95, 0.93, 0.92, 0.9)
session20.race = race

if __name__ == "__main__":
    typer.run(session20.main)
