"""A stored race as its replay player's frames (server.replay_frames) and the replay scenes opened on demand,
bounded and closed when idle (server.replays.ReplayScenes)."""

from __future__ import annotations

import asyncio
import time
from dataclasses import asdict

import numpy as np
import pytest

from controllers.plan import Plan, Waypoint
from controllers.replay import ReplayRecorder
from controllers.timeline import resimulate
from server.race_config import KartEntry
from server.replay_frames import ReplayFrames
from server.replays import ReplayScenes
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World
from web.viewer import ViewersBusyError

STEPS = 60


def _frames() -> ReplayFrames:
    """Two karts accelerating for STEPS steps, kart 0 with one plan applied at step 10."""
    track = get_track("oval")
    world = World(track, 1, 2, SimParams(), laps=1)
    recorder = ReplayRecorder("oval", 2)
    recorder.allocate(STEPS)
    actions = np.array([[[0.0, 1.0], [0.1, 0.5]]])
    plan = Plan(
        ego=0,
        root_checkpoint=1,
        waypoints={
            0: (Waypoint(1, 2, (1.0, 2.0), 10.0, 0.5), Waypoint(2, 2, (3.0, 4.0), 11.0, 1.0)),
            1: (Waypoint(1, 3, (5.0, 6.0), 9.0, 0.6),),
        },
        iterations=1,
        nodes=1,
        seconds=0.0,
    )
    for step in range(STEPS):
        if step == 10:
            recorder.plan(step, 0, plan)
        world.step(actions)
        recorder.record(world, actions[0])
    replay = recorder.replay()
    timeline = resimulate(np.asarray(replay.poses), track, 1, SimParams())
    plans = [
        {
            **p,
            "plan": {
                **asdict(plan),
                "waypoints": {str(k): [asdict(w) for w in ws] for k, ws in plan.waypoints.items()},
            },
        }
        for p in replay.plans
    ]
    karts = [KartEntry(0, "A", "fixed-lqng"), KartEntry(1, "B", "lane-follower")]
    return ReplayFrames("r1", "oval", 1, karts, timeline, plans, [0, 3])


def test_frames_show_the_recorded_poses_and_the_plans_in_force() -> None:
    frames = _frames()
    assert frames.steps == STEPS
    timeline = frames.timeline
    frame = frames.frame(30)
    assert frame.time == pytest.approx(30 * frames.dt) and frame.step == 30 and frame.status == "replay"
    assert [(k.x, k.y) for k in frame.karts] == [(timeline.x[30, k], timeline.y[30, k]) for k in range(2)]
    assert [k.name for k in frame.karts] == ["A", "B"] and frame.karts[1].controller_faults == 3
    # kart 0's plan is drawn from step 10 on (the JSON form of the replay: kart keys are strings)
    assert frames.frame(9).karts[0].waypoints == ()
    assert frames.frame(10).karts[0].waypoints == ((1.0, 2.0), (3.0, 4.0))
    assert frames.frame(10).karts[0].predicted == ((5.0, 6.0),)
    assert frames.frame(9).plans_version != frames.frame(10).plans_version
    assert frames.frame(10).plans_version == frames.frame(40).plans_version
    # steps outside the recording are clamped
    assert frames.frame(-5).step == 0 and frames.frame(10**6).step == STEPS


class FakeView:
    """A replay scene stand-in: a port, a viewer count and whether it was closed."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.viewers = 0
        self.closed = False

    def close(self) -> None:
        self.closed = True


def test_scenes_open_once_on_demand_and_stay_within_the_limit() -> None:
    opened: dict[str, FakeView] = {}

    def open_view(race_id: str) -> FakeView | None:
        if race_id == "unknown":
            return None
        time.sleep(0.05)  # two requests for one race arrive while it opens
        opened[race_id] = FakeView(1000 + len(opened))
        return opened[race_id]

    async def scenario() -> None:
        scenes = ReplayScenes(open_view, max_open=1, idle_s=60.0)
        assert await asyncio.gather(scenes.port("a"), scenes.port("a")) == [1000, 1000]
        assert list(opened) == ["a"] and scenes.open_count() == 1
        assert await scenes.port("unknown") is None
        opened["a"].viewers = 1  # watched: it may not make way for another race
        with pytest.raises(ViewersBusyError):
            await scenes.port("b")
        opened["a"].viewers = 0  # no longer watched: the least recently used scene makes way
        assert await scenes.port("b") == 1001
        assert opened["a"].closed and scenes.open_count() == 1
        await scenes.shutdown()
        assert opened["b"].closed

    asyncio.run(scenario())


def test_idle_scenes_are_closed_and_watched_ones_kept() -> None:
    views = {"a": FakeView(1), "b": FakeView(2)}

    async def scenario() -> None:
        scenes = ReplayScenes(views.get, max_open=4, idle_s=0.05)
        await scenes.port("a")
        await scenes.port("b")
        views["b"].viewers = 1
        await asyncio.sleep(0.1)
        await scenes.close_idle()
        assert views["a"].closed and not views["b"].closed
        assert scenes.open_count() == 1
        await scenes.shutdown()

    asyncio.run(scenario())
