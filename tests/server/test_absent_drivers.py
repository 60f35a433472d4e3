"""The decisions on drivers who are not there (server.absent_drivers), at chosen moments: the wait for human
drivers (start once all are ready; cancel, naming the setting, when one never connects; start without late
views), and the end of a race no unfinished kart can move in."""

from __future__ import annotations

from server.absent_drivers import DriverWait, StuckWatch, not_ready
from server.drivers import KartDriver
from server.race_config import KartEntry
from server.settings import Settings

SETTINGS = Settings(human_wait_s=60.0, view_ready_wait_s=30.0, abandoned_race_s=5.0)


def drivers() -> list[KartDriver]:
    """Two human karts and one AI kart (no controller needed for these decisions)."""
    karts = [KartEntry(0, "Ada", "human"), KartEntry(1, "Bob", "human"), KartEntry(2, "Bot", "lane-follower")]
    return [KartDriver(k, None, "token" if k.controller == "human" else None) for k in karts]


def connect(driver: KartDriver, view_ready: bool) -> None:
    driver.ever_connected = True
    driver.view_ready = view_ready


def test_the_race_starts_once_every_driver_is_ready() -> None:
    karts = drivers()
    wait = DriverWait(karts, SETTINGS, start=100.0)
    assert [d.name for d in not_ready(karts)] == ["Ada", "Bob"] and wait.over(100.0) is None
    connect(karts[0], view_ready=True)
    assert wait.over(150.0) is None
    connect(karts[1], view_ready=True)
    over = wait.over(151.0)
    assert over is not None and over.cancel is None and over.late == ()


def test_a_driver_who_never_connects_cancels_the_race_after_the_setting() -> None:
    karts = drivers()
    wait = DriverWait(karts, SETTINGS, start=100.0)
    connect(karts[0], view_ready=True)
    assert wait.over(159.9) is None
    over = wait.over(160.0)
    assert over is not None and over.cancel == "no driver joined kart(s) 1 within 60 s (KARTING_HUMAN_WAIT_S)"


def test_a_view_that_does_not_load_in_time_is_not_waited_for() -> None:
    karts = drivers()
    wait = DriverWait(karts, SETTINGS, start=100.0)
    connect(karts[0], view_ready=True)
    connect(karts[1], view_ready=False)
    assert wait.over(150.0) is None  # every driver connected at 150 s: their views have until 180 s
    assert wait.over(179.0) is None
    over = wait.over(180.0)  # (past the join limit, but everyone joined: not cancelled)
    assert over is not None and over.cancel is None and over.late == ("Bob",)


def test_a_race_nobody_can_move_in_ends_after_the_setting() -> None:
    karts = drivers()
    watch = StuckWatch(SETTINGS)
    for d in karts:
        d.braking = True
    karts[2].disabled = True
    assert watch.check(karts, 10.0) is None and watch.check(karts, 14.9) is None
    why = watch.check(karts, 15.0)
    assert why == "no unfinished kart could move for 5 s: kart(s) 0, 1, 2 absent, silent or disabled (not finished)"
    karts[0].braking = False  # someone drives again: the watch starts over
    assert watch.check(karts, 16.0) is None
    karts[0].braking = True
    assert watch.check(karts, 17.0) is None and watch.check(karts, 21.9) is None and watch.check(karts, 22.0)
    # an AI kart whose controller works is never stuck, braking or not
    karts[2].disabled = False
    assert all(watch.check(karts, t) is None for t in (30.0, 40.0))
