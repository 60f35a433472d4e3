"""What just happened to a driven kart, worded for its driver's screen: the events of the drive websocket.

:class:`DriveEvents` compares each frame with the one before (the counters in a frame are cumulative, so a frame
skipped in between loses nothing) and words what changed: the start, wall hits, collisions at fault, illegal
lane changes, driving the wrong way, passes, laps and the finish.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_core.track import Track
from web.frame import KartFrame, RaceFrame

DRIVE_EVENT_KINDS = (
    "start",
    "wall_hit",
    "collision_at_fault",
    "illegal_lane_change",
    "wrong_way",
    "passed",
    "overtaken",
    "lap",
    "finished",
)
WRONG_WAY_COS = -0.34  # facing more than ~110 degrees away from the track's direction
WRONG_WAY_SPEED = 1.0  # [m/s] ... while moving forward at least this fast
WRONG_WAY_HOLD_S = 1.0  # [s] of race time, so a spin is not called wrong way
START_STEPS = 50  # a driver who joins later than this many ticks after the start is not told "Go!"


@dataclass(frozen=True)
class DriveEvent:
    """One event: its kind (one of :data:`DRIVE_EVENT_KINDS`), its wording and when [s, race time]."""

    kind: str
    text: str
    time: float


def _times(count: int) -> str:
    return "once" if count == 1 else f"{count} times"


class DriveEvents:
    """The events of kart ``kart`` on ``track``, frame by frame (:meth:`update`)."""

    def __init__(self, track: Track, kart: int) -> None:
        self.track = track
        self.kart = kart
        self._last: RaceFrame | None = None
        self._wrong_since: float | None = None  # [s] race time since when the kart faces the wrong way
        self._wrong_told = False

    def facing_the_wrong_way(self, kart: KartFrame) -> bool:
        """Whether ``kart`` drives forward against the track's direction."""
        s, _ = self.track.project(np.array([kart.x, kart.y]))
        _, tangent = self.track.point_at(s)
        along = math.cos(kart.heading) * tangent[0] + math.sin(kart.heading) * tangent[1]
        return bool(along < WRONG_WAY_COS and kart.speed > WRONG_WAY_SPEED)

    def update(self, frame: RaceFrame) -> list[DriveEvent]:
        """The events since the previous frame (for the first frame seen: only the start, if it is the start)."""
        last, self._last = self._last, frame
        mine = frame.karts[self.kart]
        said: list[tuple[str, str]] = []
        if frame.status == "running" and (last is None or last.status != "running") and frame.step < START_STEPS:
            said.append(("start", "Go!"))
        if last is not None:
            said += self._changes(last, frame)
        if not mine.finished:
            said += self._wrong_way(mine, frame.time)
        return [DriveEvent(kind, text, frame.time) for kind, text in said]

    def _changes(self, last: RaceFrame, frame: RaceFrame) -> list[tuple[str, str]]:
        mine, before = frame.karts[self.kart], last.karts[self.kart]
        said = []
        if mine.finished and not before.finished:
            took = f" in {mine.finish_time:.2f} s" if mine.finish_time is not None else ""
            said.append(("finished", f"Finished P{mine.position} of {len(frame.karts)}{took}"))
        if mine.wall_hits > before.wall_hits:
            said.append(("wall_hit", "Wall hit"))
        if mine.collisions_at_fault > before.collisions_at_fault:
            said.append(("collision_at_fault", f"Collision at your fault ({_times(mine.collisions_at_fault)} so far)"))
        if mine.illegal_lane_changes > before.illegal_lane_changes:
            said.append(("illegal_lane_change", f"Illegal lane change ({_times(mine.illegal_lane_changes)} so far)"))
        if mine.finished:
            return said
        if mine.lap > before.lap:
            said.append(("lap", "Final lap" if mine.lap == frame.laps else f"Lap {mine.lap} of {frame.laps}"))
        if mine.position != before.position:
            for other, was in zip(frame.karts, last.karts, strict=True):
                if other.index == self.kart or other.finished:
                    continue
                if was.position < before.position and other.position > mine.position:
                    said.append(("passed", f"You passed {other.name}"))
                elif was.position > before.position and other.position < mine.position:
                    said.append(("overtaken", f"{other.name} passed you"))
        return said

    def _wrong_way(self, mine: KartFrame, now: float) -> list[tuple[str, str]]:
        if not self.facing_the_wrong_way(mine):
            self._wrong_since = None
            self._wrong_told = False
            return []
        if self._wrong_since is None:
            self._wrong_since = now
        if self._wrong_told or now - self._wrong_since < WRONG_WAY_HOLD_S:
            return []
        self._wrong_told = True
        return [("wrong_way", "Wrong way! Turn around")]
