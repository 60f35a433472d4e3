"""Scratch variants of session 16's experiments, applied on import (``h2h_cp.py`` imports it before the
head-to-head script), each switched on by an environment variable:

* ``CAND=agent:folder[,agent:folder]``: race an agent on other weights (a candidate folder);
* ``TOPSPEED=1``: mcts-rl's tracker gets top speed at every plan waypoint (what commit a369bca ships);
* ``DIVE=gap,kappa,n``: mcts-rl targets the inside lane at the next ``n`` checkpoints whose centre-line curvature
  is at least ``kappa`` [1/m] whenever another kart is 0 to ``gap`` m ahead;
* ``FORCE=c0-c1:lane;...``: mcts-rl targets fixed lanes at those checkpoints on the first lap;
* ``LINESPEED=1``: the planner's free waypoints carry the racing line's speed at their checkpoint, not top speed;
* ``FORCEPLAN=c0-c1:lane;...``: any MCTS planner (mcts-lqng too) that started on the left of the grid (lane 2)
  plans those lanes at those checkpoints of the first lap, whatever the search says.

Run from the repo root::

    PYTHONPATH=results/rl/session16/variants:$PWD .venv/bin/python results/rl/session16/variants/h2h_cp.py \\
        --track complex --karts mcts-rl,fixed-rl --races 20 --workers 2
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

import controllers.rl.policy as policy_module
import controllers.rl.tracker as tracker_module
import controllers.tactical.high_level as high_level

Targets = Callable[[Any, Any, Any], None]


def _swap_weights(spec: str) -> None:
    candidates = dict(item.split(":") for item in spec.split(",") if item)
    shipped = policy_module.weights_folder

    def folder(agent: str) -> Path:
        return Path(candidates[agent]) if agent in candidates else shipped(agent)

    tracker_module.weights_folder = folder  # type: ignore[assignment]
    policy_module.weights_folder = folder  # type: ignore[assignment]


def _wrap_targets(after: Callable[[Any, Any], None]) -> None:
    """Run ``after(tracker, observation)`` on mcts-rl's targets once the shipped code has set them."""
    shipped: Targets = tracker_module.RLTracker._targets

    def targets(self: Any, observation: Any, plan: Any) -> None:
        shipped(self, observation, plan)
        if self.agent == "mcts-rl":
            after(self, observation)

    tracker_module.RLTracker._targets = targets  # type: ignore[method-assign]


def _top_speed(tracker: Any, observation: Any) -> None:
    tracker.plan_speed[0, 0] = tracker.kart.top_speed


def _dive(spec: str) -> Callable[[Any, Any], None]:
    gap_max, kappa_min, ahead = (float(x) for x in spec.split(","))

    def dive(tracker: Any, observation: Any) -> None:
        track = tracker._ctx.track
        rows = np.clip(np.searchsorted(track.centre_s, track.checkpoint_s), 0, len(track.centre_s) - 1)
        kappa = np.asarray(track.centre_curvature)[rows]
        me = observation.me
        gaps = [track.gap(me.progress, v.progress) for v in observation.others() if not v.finished]
        if not any(0.0 < g < gap_max for g in gaps):
            return
        for j in range(int(ahead)):
            c = (me.checkpoints_passed + j) % track.n_checkpoints
            if abs(kappa[c]) >= kappa_min:
                tracker.plan_lane[0, 0, c] = track.n_lanes if kappa[c] < 0 else 1

    return dive


def _force(spec: str) -> Callable[[Any, Any], None]:
    spans = []
    for part in spec.split(";"):
        checkpoints, lane = part.split(":")
        first, last = checkpoints.split("-")
        spans.append((int(first), int(last), int(lane)))

    def force(tracker: Any, observation: Any) -> None:
        for first, last, lane in spans:
            for c in range(max(first, observation.me.checkpoints_passed), last + 1):
                tracker.plan_lane[0, 0, c % tracker.tables.n_checkpoints] = lane

    return force


def _line_speeds() -> None:
    shipped = high_level.MCTSPlanner.plan

    def plan(self: Any, observation: Any) -> Any:
        out = shipped(self, observation)
        track, top = self._context.track, self._context.kart.top_speed
        n = track.n_checkpoints
        waypoints = tuple(
            replace(w, speed=min(top, float(self._line.speed_at(float(track.checkpoint_s[w.checkpoint % n])))))
            if w.speed >= top - 1e-9
            else w
            for w in out.ego_waypoints
        )
        return replace(out, waypoints={**out.waypoints, out.ego: waypoints})

    high_level.MCTSPlanner.plan = plan  # type: ignore[method-assign]


def _force_plan(spec: str) -> None:
    spans = {}
    for part in spec.split(";"):
        checkpoints, lane = part.split(":")
        first, last = checkpoints.split("-")
        spans.update({c: int(lane) for c in range(int(first), int(last) + 1)})
    shipped = high_level.MCTSPlanner.plan

    def plan(self: Any, observation: Any) -> Any:
        out = shipped(self, observation)
        if not hasattr(self, "_forced_start"):
            self._forced_start = observation.me.lateral > 0.0
        if not self._forced_start:
            return out
        track = self._context.track
        waypoints = []
        for w in out.ego_waypoints:
            if w.checkpoint in spans:
                point = track.lane_point(w.checkpoint, spans[w.checkpoint])
                w = replace(w, lane=spans[w.checkpoint], position=(float(point[0]), float(point[1])))
            waypoints.append(w)
        return replace(out, waypoints={**out.waypoints, out.ego: tuple(waypoints)})

    high_level.MCTSPlanner.plan = plan  # type: ignore[method-assign]


if os.environ.get("CAND"):
    _swap_weights(os.environ["CAND"])
if os.environ.get("TOPSPEED") == "1":
    _wrap_targets(_top_speed)
if os.environ.get("DIVE"):
    _wrap_targets(_dive(os.environ["DIVE"]))
if os.environ.get("FORCE"):
    _wrap_targets(_force(os.environ["FORCE"]))
if os.environ.get("LINESPEED") == "1":
    _line_speeds()
if os.environ.get("FORCEPLAN"):
    _force_plan(os.environ["FORCEPLAN"])
