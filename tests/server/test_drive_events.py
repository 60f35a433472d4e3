"""The events a driver sees on the drive page (server.drive_events), from frames built by hand on the oval."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from server.drive_events import DRIVE_EVENT_KINDS, WRONG_WAY_HOLD_S, DriveEvents
from sim_core.track import Track
from sim_core.track_io import get_track
from web.frame import KartFrame, RaceFrame


@pytest.fixture(scope="module")
def oval() -> Track:
    return get_track("oval")


def kart_on_grid(track: Track, index: int, **changes: object) -> KartFrame:
    """Kart ``index`` on its grid slot, facing along the track (the oval starts heading +y)."""
    x, y = track.lane_point(0, 1 + index)
    kart = KartFrame(
        index=index,
        name=f"Driver {index}",
        controller="human" if index == 0 else "lane-follower",
        x=float(x),
        y=float(y),
        heading=math.pi / 2,
        speed=5.0,
        steer=0.0,
        throttle=1.0,
        lap=1,
        position=index + 1,
        checkpoints_passed=0,
        lane=1 + index,
        collisions_at_fault=0,
        illegal_lane_changes=0,
        wall_hits=0,
        finished=False,
        finish_time=None,
        controller_faults=0,
    )
    return replace(kart, **changes)  # type: ignore[arg-type]


def frame(step: int, karts: list[KartFrame], status: str = "running") -> RaceFrame:
    return RaceFrame("r1", "oval", step * 0.02, step, 3, status, tuple(karts), 0)


def kinds_and_texts(events: DriveEvents, f: RaceFrame) -> list[tuple[str, str]]:
    happened = events.update(f)
    assert all(e.kind in DRIVE_EVENT_KINDS and e.time == f.time for e in happened)
    return [(e.kind, e.text) for e in happened]


def test_the_start_is_told_once_and_only_at_the_start(oval: Track) -> None:
    karts = [kart_on_grid(oval, 0), kart_on_grid(oval, 1)]
    events = DriveEvents(oval, 0)
    assert kinds_and_texts(events, frame(0, karts, "countdown")) == []
    assert kinds_and_texts(events, frame(1, karts)) == [("start", "Go!")]
    assert kinds_and_texts(events, frame(2, karts)) == []
    late = DriveEvents(oval, 0)  # a driver who joins a race long under way
    assert kinds_and_texts(late, frame(5000, karts)) == []


def test_counters_that_rise_are_told_with_their_totals(oval: Track) -> None:
    events = DriveEvents(oval, 0)
    other = kart_on_grid(oval, 1)
    events.update(frame(100, [kart_on_grid(oval, 0), other]))
    hit = kart_on_grid(oval, 0, wall_hits=1, collisions_at_fault=1, illegal_lane_changes=2)
    said = kinds_and_texts(events, frame(101, [hit, other]))
    assert said == [
        ("wall_hit", "Wall hit"),
        ("collision_at_fault", "Collision at your fault (once so far)"),
        ("illegal_lane_change", "Illegal lane change (2 times so far)"),
    ]
    assert kinds_and_texts(events, frame(102, [hit, other])) == []  # nothing new: nothing said
    other_hit = replace(other, wall_hits=3, collisions_at_fault=2)  # another kart's troubles are not ours
    assert kinds_and_texts(events, frame(103, [hit, other_hit])) == []


def test_passes_laps_and_the_finish(oval: Track) -> None:
    events = DriveEvents(oval, 0)
    me, other = kart_on_grid(oval, 0, position=2), kart_on_grid(oval, 1, position=1)
    events.update(frame(100, [me, other]))
    me, other = replace(me, position=1), replace(other, position=2)
    assert kinds_and_texts(events, frame(101, [me, other])) == [("passed", "You passed Driver 1")]
    me, other = replace(me, position=2), replace(other, position=1)
    assert kinds_and_texts(events, frame(102, [me, other])) == [("overtaken", "Driver 1 passed you")]
    me = replace(me, lap=2)
    assert kinds_and_texts(events, frame(103, [me, other])) == [("lap", "Lap 2 of 3")]
    me = replace(me, lap=3)
    assert kinds_and_texts(events, frame(104, [me, other])) == [("lap", "Final lap")]
    me = replace(me, finished=True, finish_time=61.234)
    assert kinds_and_texts(events, frame(105, [me, other])) == [("finished", "Finished P2 of 2 in 61.23 s")]


def test_wrong_way_is_told_after_a_while_and_again_only_after_turning_back(oval: Track) -> None:
    events = DriveEvents(oval, 0)
    other = kart_on_grid(oval, 1)
    backwards = kart_on_grid(oval, 0, heading=-math.pi / 2)
    assert events.facing_the_wrong_way(backwards)
    assert not events.facing_the_wrong_way(kart_on_grid(oval, 0))
    assert not events.facing_the_wrong_way(replace(backwards, speed=-3.0))  # reversing is not the wrong way
    hold = round(WRONG_WAY_HOLD_S / 0.02)
    said = [kinds_and_texts(events, frame(100 + i, [backwards, other])) for i in range(hold + 5)]
    told = [i for i, s in enumerate(said) if s]
    assert told == [hold] and said[hold] == [("wrong_way", "Wrong way! Turn around")]
    assert kinds_and_texts(events, frame(200, [kart_on_grid(oval, 0), other])) == []
    again = [kinds_and_texts(events, frame(201 + i, [backwards, other])) for i in range(hold + 1)]
    assert again[-1] == [("wrong_way", "Wrong way! Turn around")]
