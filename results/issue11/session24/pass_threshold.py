"""Session 22's pass threshold (``../session22/pass_threshold.py``: mcts-lqng from lane 2 of `complex` against
fixed-lqng at a fraction ``speed_scale`` of its speed targets, seeds 0, 2, 4, ...) with mcts-lqng's tracker
settings changed by TRACKER, a JSON object of ``LQNGParams`` fields (``tracker_env.py``; default: as shipped),
and the setting's name in each line taken from LABEL.

    TRACKER='{"grip_steer": 0.98}' LABEL=grip PYTHONPATH=$PWD .venv/bin/python \\
        results/issue11/session24/pass_threshold.py --starts 16 --workers 2
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import typer

sys.path.insert(0, str(Path(__file__).parent))
import tracker_env

tracker_env.apply()  # before the workers fork

_path = Path(__file__).parents[1] / "session22" / "pass_threshold.py"
_spec = importlib.util.spec_from_file_location("session22", _path)
assert _spec is not None and _spec.loader is not None
session22 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(session22)
session20 = session22.session20  # the driver loop and race (session 22 runs session 20's)
_session20_race = session22.race
LABEL = os.environ.get("LABEL", "shipped")


def race(track: str, setting: str, scale: float, seed: int) -> dict[str, object]:
    """Session 20's race with mcts-lqng as registered (presets changed as above)."""
    return _session20_race(track, "shipped", scale, seed) | {"setting": setting}  # type: ignore[no-any-return]


session20.race = race
session20.SETTINGS = (LABEL,)
session20.SCALES = (1.0, 0.98, 0.97, 0.95, 0.93)

if __name__ == "__main__":
    typer.run(session20.main)
