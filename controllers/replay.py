"""Replays and plan targets, shared by headless races (:mod:`controllers.race`) and the live server: every kart's
pose and inputs per step, the plans as they were applied, and the referee's Δr / Δv targets from a plan."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from controllers.plan import Plan
from sim_core import state as st
from sim_core.params import DT
from sim_core.world import World

POSE_COLUMNS = [st.F_X, st.F_Y, st.F_HEADING, st.F_SPEED]


@dataclass
class Replay:
    """Every kart's pose and inputs per step, plus the plans as they were applied."""

    track: str
    dt: float
    poses: list[list[list[float]]] = field(
        default_factory=list
    )  # [step][kart] = [x, y, heading, speed, steer, throttle]
    plans: list[dict[str, object]] = field(default_factory=list)

    def as_dict(self) -> dict[str, object]:
        """The replay as plain data, sharing this replay's lists (``dataclasses.asdict`` would deep-copy every pose
        value: half a second for a race's 4,000 steps)."""
        return {"track": self.track, "dt": self.dt, "poses": self.poses, "plans": self.plans}

    def save(self, path: str | Path) -> None:
        """Write the replay as JSON."""
        Path(path).write_text(json.dumps(self.as_dict()))


class ReplayRecorder:
    """Records a race of ``world`` step by step into room allocated up front (a growing list of lists would
    give the garbage collector work during a live race)."""

    def __init__(self, track_name: str, n_karts: int) -> None:
        self.track_name = track_name
        self._poses = np.zeros((0, n_karts, 6))  # per step and kart: x, y, heading, speed, steer, throttle
        self._recorded = 0  # steps in _poses
        self._plans: list[dict[str, object]] = []

    def allocate(self, steps: int) -> None:
        """Room for ``steps`` steps (a race lasts at most its time limit)."""
        self._poses = np.zeros((steps, self._poses.shape[1], 6))
        self._recorded = 0

    def record(self, world: World, actions: np.ndarray, race: int = 0) -> None:
        """The step race ``race`` of ``world`` just took with ``actions`` (K, 2) (ignored once the room is full)."""
        if self._recorded < len(self._poses):
            pose = self._poses[self._recorded]
            pose[:, :4] = world.fstate[race][:, POSE_COLUMNS]
            pose[:, 4:] = actions
            self._recorded += 1

    def plan(self, step: int, kart: int, plan: Plan) -> None:
        """A plan applied to ``kart`` at race step ``step``."""
        self._plans.append({"step": step, "kart": kart, "plan": asdict(plan)})

    def replay(self) -> Replay:
        """The replay so far."""
        return Replay(self.track_name, DT, self._poses[: self._recorded].tolist(), list(self._plans))


def apply_plan_targets(world: World, race: int, kart: int, plan: Plan) -> None:
    """Tell the referee the ego waypoints of ``plan`` as ``kart``'s targets (its Δr / Δv, section 5.2.2)."""
    for waypoint in plan.ego_waypoints:
        world.set_target(race, kart, waypoint.checkpoint, waypoint.lane, waypoint.speed)
