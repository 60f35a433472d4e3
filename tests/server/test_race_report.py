"""The race page's figures (server.race_report) from hand-made crossings and traces, checked by hand."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.timeline import Crossing
from server.race_report import lap_reports, sector_ends, speed_along_lap


def test_sectors_split_the_lap_as_evenly_as_the_checkpoints_allow() -> None:
    assert sector_ends(24) == (8, 16, 24)
    assert sector_ends(10) == (3, 7, 10)  # 10/3 = 3.33 -> 3, 20/3 = 6.67 -> 7
    assert sector_ends(4) == (1, 3, 4)  # 4/3 = 1.33 -> 1, 8/3 = 2.67 -> 3
    assert sector_ends(2) == (1, 2)  # fewer checkpoints than sectors: one sector per checkpoint


def _crossings(kart: int, times: list[float]) -> list[Crossing]:
    return [
        Crossing(kart, checkpoint, t, 10.0 + checkpoint, 0.25 + 0.01 * checkpoint)
        for checkpoint, t in enumerate(times, start=1)
    ]


def test_laps_sectors_positions_and_gaps_by_hand() -> None:
    # 4 checkpoints a lap (sectors end at checkpoints 1, 3 and 4), 2 laps, 2 karts
    crossings = _crossings(0, [1.0, 2.0, 3.0, 4.0, 5.5, 6.5, 7.0, 8.0]) + _crossings(
        1, [1.2, 2.2, 3.5, 4.5, 5.4, 6.0, 6.8, 7.6]
    )
    kart0, kart1 = lap_reports(crossings, n_checkpoints=4, laps=2, n_karts=2)

    # kart 0, lap 1: from the start signal (0 s) to checkpoint 4 at 4.0 s; sectors 0-1, 1-3, 3-4.0
    lap = kart0[0]
    assert (lap.lap, lap.time, lap.end_time, lap.position, lap.gap) == (1, 4.0, 4.0, 1, 0.0)
    assert lap.sectors == pytest.approx((1.0, 2.0, 1.0))
    assert (lap.speed, lap.wear) == (14.0, pytest.approx(0.29))  # over the line: checkpoint 4's figures
    # kart 1, lap 1: 4.5 s, second over the line, 0.5 s behind
    lap = kart1[0]
    assert (lap.time, lap.position) == (4.5, 2)
    assert lap.gap == pytest.approx(0.5)
    assert lap.sectors == pytest.approx((1.2, 2.3, 1.0))
    # lap 2 runs from each kart's own lap-1 crossing: kart 0 8.0 - 4.0, kart 1 7.6 - 4.5 (and leads by 0.4 s)
    assert kart0[1].time == pytest.approx(4.0) and kart0[1].sectors == pytest.approx((1.5, 1.5, 1.0))
    assert kart1[1].time == pytest.approx(3.1) and kart1[1].sectors == pytest.approx((0.9, 1.4, 0.8))
    assert (kart0[1].position, kart1[1].position) == (2, 1)
    assert kart0[1].gap == pytest.approx(0.4) and kart1[1].gap == 0.0


def test_an_unfinished_lap_is_left_out() -> None:
    crossings = _crossings(0, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])  # 1.5 laps
    (laps,) = lap_reports(crossings, n_checkpoints=4, laps=2, n_karts=1)
    assert [lap.lap for lap in laps] == [1]


def test_racing_a_distance_the_last_lap_ends_at_each_karts_finish() -> None:
    """Kart 0 (front row) finishes 0.3 s after its last crossing of the line; kart 1 (second row) 0.2 s before
    its own: both last laps end at the finish, kart 1's last sector short of the line, and kart 1 is placed first."""
    crossings = _crossings(0, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]) + _crossings(
        1, [1.1, 2.1, 3.1, 4.1, 5.0, 6.0, 7.0]
    )
    kart0, kart1 = lap_reports(crossings, n_checkpoints=4, laps=2, n_karts=2, finish_times=(8.3, 7.9))
    assert [lap.lap for lap in kart0] == [1, 2] and [lap.lap for lap in kart1] == [1, 2]
    assert kart0[1].end_time == 8.3 and kart0[1].time == pytest.approx(4.3) and kart0[1].sectors[-1] == 1.3
    assert kart1[1].end_time == 7.9 and kart1[1].time == pytest.approx(3.8)
    assert sum(lap.time for lap in kart1) == pytest.approx(7.9)
    assert (kart1[1].position, kart0[1].position) == (1, 2) and kart0[1].gap == pytest.approx(0.4)
    assert kart1[1].speed == 17.0  # its last crossing's figures (checkpoint 7)
    at_the_line = lap_reports(crossings, n_checkpoints=4, laps=2, n_karts=2, finish_times=(8.0, None))
    assert at_the_line[0] == lap_reports(crossings, n_checkpoints=4, laps=2, n_karts=2)[0]  # the same laps


def test_speed_along_the_lap_by_hand() -> None:
    # a 100 m lap in 4 stretches of 25 m, 2 laps; the last row is after the finish and left out
    progress = np.array([0.0, 10.0, 30.0, 60.0, 90.0, 110.0, 160.0])
    speed = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    finished = np.array([False] * 6 + [True])
    lap1, lap2 = speed_along_lap(progress, speed, finished, track_length=100.0, laps=2, bins=4)
    assert lap1 == [1.5, 3.0, 4.0, 5.0]  # (1 + 2) / 2 in 0-25 m, then one sample per stretch
    assert lap2 == [6.0, None, None, None]  # only 110 m was driven in lap 2 before the finish
