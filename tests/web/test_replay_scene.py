"""The replay player (web.replay_scene.ReplayScene) on a real viser server, with a stand-in recording: a
viewer's playback clock (play and pause, seeking (clamped), the speed), and closing."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from sim_core.track_io import get_track
from web.frame import KartFrame, RaceFrame
from web.replay_scene import Playback, ReplayScene

STEPS = 500  # 10 s at 0.02 s


class StraightLine:
    """Two karts moving 0.1 m along x per step (kart k at y = 3k)."""

    steps = STEPS
    dt = 0.02

    def __init__(self) -> None:
        self.asked: list[int] = []

    def frame(self, step: int, status: str = "replay") -> RaceFrame:
        self.asked.append(step)
        karts = tuple(
            KartFrame(k, f"k{k}", "c", 0.1 * step, 3.0 * k, 0.0, 5.0, 0.0, 0.0, 1, k + 1, 0, 1, 0, 0, 0, False, None, 0)
            for k in range(2)
        )
        return RaceFrame("r", "oval", step * self.dt, step, 1, status, karts, 0)


@pytest.fixture
def player() -> Iterator[tuple[ReplayScene, StraightLine]]:
    frames = StraightLine()
    scene = ReplayScene(get_track("oval"), [("k0", "c"), ("k1", "c")], "test replay", frames, "/races/r")
    try:
        yield scene, frames
    finally:
        scene.close()


def test_it_starts_paused_at_the_grid_and_seeks_within_the_race(player: tuple[ReplayScene, StraightLine]) -> None:
    scene, frames = player
    playback = Playback(scene.duration)  # each viewer's own (viewers: tests/web/test_replay_viewers.py)
    assert not playback.playing and playback.time == 0.0 and scene.duration == pytest.approx(10.0)
    assert frames.asked == []  # nothing is shown before a viewer comes
    playback.seek(4.0)
    assert playback.time == 4.0
    playback.seek(-3.0)
    assert playback.time == 0.0
    playback.seek(99.0)
    assert playback.time == pytest.approx(10.0)


def test_play_pause_and_the_speed_choice(player: tuple[ReplayScene, StraightLine]) -> None:
    scene, _ = player
    playback = Playback(scene.duration)  # (a viewer's panel sets it: tests/web/test_replay_viewers.py)
    playback.play()
    assert playback.playing
    playback.pause()
    assert not playback.playing
    playback.set_speed(8.0)
    assert playback.speed == 8.0
    playback.set_speed(0.25)
    assert playback.speed == 0.25
    # playing from the end starts over
    playback.seek(99.0)
    playback.play()
    assert playback.time == 0.0 and playback.playing


def test_closing_stops_the_clock_and_the_server(player: tuple[ReplayScene, StraightLine]) -> None:
    scene, _ = player
    scene.close()
    assert scene.closed and not scene._thread.is_alive()
