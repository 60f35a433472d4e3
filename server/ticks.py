"""Drift-free tick scheduling and its statistics.

Tick ``n`` of a race is due at ``t0 + n * period`` (absolute deadlines, so lateness never accumulates). A
tick that starts more than one period late is an *overrun*: the schedule skips ahead to the next deadline
still in the future instead of bursting through the missed ones.
"""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass

import numpy as np

WINDOW = 3000  # ticks kept for percentiles (60 s at 50 Hz)


async def sleep_until(deadline: float) -> None:
    """Sleep until the event loop's clock reads ``deadline`` [s] (``loop.time()``)."""
    loop = asyncio.get_running_loop()
    if deadline <= loop.time():
        return
    future = loop.create_future()
    handle = loop.call_at(deadline, _wake, future)
    try:
        await future
    finally:
        handle.cancel()


def _wake(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


def spread_start(earliest: float, period: float, others: list[float]) -> float:
    """The first time from ``earliest`` whose phase (time mod ``period``) is the middle of the widest gap
    between the phases of ``others`` (the starts of the other races' schedules).

    Races whose ticks (and the controller work that follows each tick) do not coincide do not wait for each
    other on the event loop or for the GIL.
    """
    if not others:
        return earliest
    phases = sorted(t % period for t in others)
    gaps = [(b - a, a) for a, b in zip(phases, [*phases[1:], phases[0] + period])]
    width, start = max(gaps)
    target = (start + width / 2) % period
    return earliest + (target - earliest % period) % period


@dataclass(frozen=True)
class TickSummary:
    """Tick timing of one race: counts since the start, percentiles over the last :data:`WINDOW` ticks."""

    period_ms: float
    ticks: int
    overruns: int  # ticks that started more than one period late
    skipped: int  # deadlines skipped after overruns
    jitter_p50_ms: float  # |tick start - deadline|
    jitter_p99_ms: float
    jitter_max_ms: float
    work_p50_ms: float  # tick duration (step, inputs, frame, viewer update)
    work_p99_ms: float


class TickSchedule:
    """The deadlines of one race and the timing of the ticks run against them."""

    def __init__(self, t0: float, period: float) -> None:
        self.t0 = t0
        self.period = period
        self.n = 0
        self.ticks = 0
        self.overruns = 0
        self.skipped = 0
        self._jitter = np.zeros(WINDOW)
        self._work = np.zeros(WINDOW)
        self._start = t0

    @property
    def deadline(self) -> float:
        """When the next tick is due [s]."""
        return self.t0 + self.n * self.period

    def started(self, now: float) -> None:
        """Record that the tick due at :attr:`deadline` started at ``now``; skip ahead if it overran."""
        late = now - self.deadline
        self._start = now
        self._jitter[self.ticks % WINDOW] = abs(late)
        if late > self.period:
            self.overruns += 1
            behind = math.floor((now - self.t0) / self.period)
            self.skipped += behind - self.n
            self.n = behind

    def finished(self, now: float) -> None:
        """Record the end of the current tick and move to the next deadline."""
        self._work[self.ticks % WINDOW] = now - self._start
        self.ticks += 1
        self.n += 1

    def recent_jitter_ms(self) -> list[float]:
        """Jitter of the last ticks (up to :data:`WINDOW`), oldest first [ms]."""
        if self.ticks <= WINDOW:
            return (self._jitter[: self.ticks] * 1e3).tolist()
        i = self.ticks % WINDOW
        return (np.concatenate([self._jitter[i:], self._jitter[:i]]) * 1e3).tolist()

    def summary(self) -> TickSummary:
        """Counts and percentiles."""
        n = min(self.ticks, WINDOW)
        jitter = self._jitter[:n] * 1e3
        work = self._work[:n] * 1e3
        if n == 0:
            jitter = work = np.zeros(1)
        return TickSummary(
            period_ms=self.period * 1e3,
            ticks=self.ticks,
            overruns=self.overruns,
            skipped=self.skipped,
            jitter_p50_ms=float(np.percentile(jitter, 50)),
            jitter_p99_ms=float(np.percentile(jitter, 99)),
            jitter_max_ms=float(jitter.max()),
            work_p50_ms=float(np.percentile(work, 50)),
            work_p99_ms=float(np.percentile(work, 99)),
        )
