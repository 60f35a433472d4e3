"""Scratch variant (session 16): the LQ tracker's speed ceiling is the speed profile of the racing line shifted
sideways to the kart's present offset (:func:`controllers.racing_line.shifted_lines`, the paths the tactical game
is calibrated on), not the line's own profile, for every LQNG kart. Applied on import::

    PATCHES=shifted_speed_ceiling PYTHONPATH=results/issue11/session16/variants:$PWD .venv/bin/python \\
        results/issue11/session16/variants/h2h_patched.py --track complex --karts mcts-lqng,fixed-lqng --races 4
"""

from __future__ import annotations

import math
from typing import Any

import controllers.lq.tracker as lq_tracker
from controllers.base import RaceContext
from controllers.racing_line import shifted_lines

_shipped_reset = lq_tracker.LQNGTracker.reset


def _reset(self: Any, context: RaceContext) -> None:
    _shipped_reset(self, context)
    self._shifted = shifted_lines(context.track, self._line, context.kart)


def _speed_target(self: Any, kart: Any, first: Any, second: Any, top: float, brake: float) -> float:
    p = self.params
    shift = kart.lateral - float(self._line.offset_at(kart.progress))
    target = min(top, self._shifted.speed_at(kart.progress, shift))
    for w in (first, second):
        dist = math.hypot(w.position[0] - kart.x, w.position[1] - kart.y)
        allowed = math.sqrt(min(w.speed + p.speed_margin, top) ** 2 + 2.0 * brake * p.braking_use * dist)
        target = min(target, allowed)
    return target


lq_tracker.LQNGTracker.reset = _reset  # type: ignore[method-assign]
lq_tracker.LQNGTracker._speed_target = _speed_target  # type: ignore[method-assign]
