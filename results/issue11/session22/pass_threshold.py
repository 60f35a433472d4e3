"""How much slower a kart must be before mcts-lqng as shipped this session (close following with the alongside
discipline) gets past it from behind: session 20's measurement (``../session20/pass_threshold.py``, whose driver
loop and race this reuses) at session 21's speed scales. mcts-lqng starts in lane 2 of `complex` against fixed-lqng
at a fraction ``speed_scale`` of its speed targets; seeds 0, 2, 4, ... Session 21's table
(``../session21/pass_threshold_complex.txt``) gives the linear rule and close following without the discipline on
the same starts.

Run from the repo root (one JSON line per race, then one summary line per scale)::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session22/pass_threshold.py --starts 16
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import typer

_path = Path(__file__).parents[1] / "session20" / "pass_threshold.py"
_spec = importlib.util.spec_from_file_location("session20", _path)
assert _spec is not None and _spec.loader is not None
session20 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(session20)
_session20_race = session20.race


def race(track: str, setting: str, scale: float, seed: int) -> dict[str, object]:
    """Session 20's race (``shipped``: mcts-lqng as registered), defined here so that worker processes can
    unpickle it."""
    return _session20_race(track, setting, scale, seed)  # type: ignore[no-any-return]


session20.race = race
session20.SETTINGS = ("shipped",)
session20.SCALES = (1.0, 0.98, 0.97, 0.95, 0.93, 0.92, 0.9)

if __name__ == "__main__":
    typer.run(session20.main)
