"""A stored race as the frames its replay player shows: one :class:`~web.frame.RaceFrame` per recorded step,
built on demand from the re-simulated :class:`~controllers.timeline.RaceTimeline` and the replay's plans."""

from __future__ import annotations

import bisect
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from controllers.timeline import RaceTimeline
from server.race_config import KartEntry
from web.frame import KartFrame, RaceFrame

Points = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class _PlanAt:
    """A plan as the kart's waypoints and predictions from ``step`` on."""

    step: int
    waypoints: Points
    predicted: Points


def _points(waypoints: Any) -> Points:
    return tuple((float(w["position"][0]), float(w["position"][1])) for w in waypoints or ())


def _plans_by_kart(plans: Sequence[Mapping[str, Any]], n_karts: int) -> list[list[_PlanAt]]:
    """Each kart's applied plans in step order (the replay format: ``{step, kart, plan}``)."""
    out: list[list[_PlanAt]] = [[] for _ in range(n_karts)]
    for entry in sorted(plans, key=lambda p: int(p["step"])):
        kart = int(entry["kart"])
        if not 0 <= kart < n_karts:
            continue
        plan = entry["plan"]
        by_kart = {int(k): v for k, v in (plan.get("waypoints") or {}).items()}
        ego = int(plan.get("ego", kart))
        predicted = tuple(p for other, ws in by_kart.items() if other != ego for p in _points(ws))
        out[kart].append(_PlanAt(int(entry["step"]), _points(by_kart.get(ego)), predicted))
    return out


class ReplayFrames:
    """The frames of a stored race (``frame(step)`` for ``step`` in ``0..steps``; 0 is the grid)."""

    def __init__(
        self,
        race_id: str,
        track_name: str,
        laps: int,
        karts: Sequence[KartEntry],
        timeline: RaceTimeline,
        plans: Sequence[Mapping[str, Any]],
        controller_faults: Sequence[int],
    ) -> None:
        self.race_id = race_id
        self.track_name = track_name
        self.laps = laps
        self.karts = list(karts)
        self.timeline = timeline
        self.controller_faults = list(controller_faults)
        self._plans = _plans_by_kart(plans, timeline.n_karts)
        self._plan_steps = [[p.step for p in kart] for kart in self._plans]
        self._all_plan_steps = sorted(s for steps in self._plan_steps for s in steps)

    @property
    def steps(self) -> int:
        """The last step (the race lasted ``steps * dt`` seconds)."""
        return self.timeline.steps

    @property
    def dt(self) -> float:
        """[s] per step."""
        return self.timeline.dt

    def frame(self, step: int, status: str = "replay") -> RaceFrame:
        """The race after ``step`` steps (clamped to the recording), shown with ``status``."""
        t = self.timeline
        row = min(max(int(step), 0), t.steps)
        n_cp = t.n_checkpoints
        karts = []
        for k, entry in enumerate(self.karts[: t.n_karts]):
            plan = self._plan(k, row)
            finished = bool(t.finished[row, k])
            passed = int(t.checkpoints_passed[row, k])
            karts.append(
                KartFrame(
                    index=k,
                    name=entry.name,
                    controller=entry.controller,
                    x=float(t.x[row, k]),
                    y=float(t.y[row, k]),
                    heading=float(t.heading[row, k]),
                    speed=float(t.speed[row, k]),
                    steer=0.0,
                    throttle=0.0,
                    lap=min(max(passed, 0) // n_cp + 1, self.laps),
                    position=int(t.position[row, k]),
                    checkpoints_passed=passed,
                    lane=int(t.lane[row, k]),
                    collisions_at_fault=int(t.collisions_at_fault[row, k]),
                    illegal_lane_changes=int(t.illegal_lane_changes[row, k]),
                    wall_hits=int(t.wall_hits[row, k]),
                    finished=finished,
                    finish_time=t.finish_time[k] if finished else None,
                    controller_faults=self.controller_faults[k] if k < len(self.controller_faults) else 0,
                    waypoints=plan.waypoints if plan is not None and not finished else (),
                    predicted=plan.predicted if plan is not None and not finished else (),
                    team=entry.team,
                )
            )
        return RaceFrame(
            race_id=self.race_id,
            track=self.track_name,
            time=row * t.dt,
            step=row,
            laps=self.laps,
            status=status,
            karts=tuple(karts),
            # a finished kart's plan is hidden: a change of the plans drawn, as a new plan is
            plans_version=bisect.bisect_right(self._all_plan_steps, row)
            + (len(self._all_plan_steps) + 1) * sum(k.finished for k in karts),
        )

    def _plan(self, kart: int, row: int) -> _PlanAt | None:
        at = bisect.bisect_right(self._plan_steps[kart], row) - 1
        return self._plans[kart][at] if at >= 0 else None
