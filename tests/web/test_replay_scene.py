"""The replay player's clock and panel (web.replay_scene.ReplayScene) on a real viser server, with a stand-in
recording: play and pause, seeking (clamped), the speed choice, the frame shown, and closing."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from sim_core.track_io import get_track
from web.frame import KartFrame, RaceFrame
from web.replay_scene import PAUSE, PLAY, ReplayScene

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
    assert not scene.playing and scene.time == 0.0 and scene.duration == pytest.approx(10.0)
    assert frames.asked[0] == 0  # the grid is shown at once
    scene.seek(4.0)
    assert scene.time == 4.0
    scene.seek(-3.0)
    assert scene.time == 0.0
    scene.seek(99.0)
    assert scene.time == pytest.approx(10.0)


def test_play_pause_and_the_speed_choice(player: tuple[ReplayScene, StraightLine]) -> None:
    scene, _ = player
    scene.play()
    assert scene.playing and scene._play_button.label == PAUSE
    scene.pause()
    assert not scene.playing and scene._play_button.label == PLAY
    scene._speed_choice.value = "8x"  # as a viewer's choice arrives
    assert scene._speed == 8.0
    scene._speed_choice.value = "0.25x"
    assert scene._speed == 0.25
    # playing from the end starts over
    scene.seek(99.0)
    scene.play()
    assert scene.time == 0.0 and scene.playing


def test_closing_stops_the_clock_and_the_server(player: tuple[ReplayScene, StraightLine]) -> None:
    scene, _ = player
    scene.close()
    assert scene.closed and not scene._thread.is_alive()
