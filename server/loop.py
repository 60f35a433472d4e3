"""An asyncio event loop whose timers fire to the microsecond, for the 50 Hz race ticks, and (optionally) a
real-time scheduling class for the thread that runs it.

The standard selector loop waits with ``epoll_wait``, whose timeout is whole milliseconds rounded up, so a
timer set for a tick deadline fires 0-1 ms late (about 0.5 ms on average). Here the wait itself is a
``select()`` on the epoll descriptor (microsecond timeout, wakes on any registered socket), followed by a
non-blocking ``epoll_wait`` that collects the events.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import select
import selectors

_SELECT_FD_LIMIT = 1024  # select() cannot watch descriptors at or above FD_SETSIZE


class PreciseEpollSelector(selectors.EpollSelector):
    """``EpollSelector`` with microsecond (instead of millisecond) timeouts."""

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        """Wait up to ``timeout`` seconds (``None``: forever) for registered events."""
        epoll_fd = self._selector.fileno()  # type: ignore[attr-defined]
        if timeout is not None and timeout > 0 and epoll_fd < _SELECT_FD_LIMIT:
            select.select([epoll_fd], [], [], timeout)
            timeout = 0
        return super().select(timeout)


def new_precise_loop() -> asyncio.AbstractEventLoop:
    """A selector event loop with :class:`PreciseEpollSelector` (a plain one where epoll is missing); also
    uvicorn's ``loop="server.loop:new_precise_loop"``."""
    if hasattr(selectors, "EpollSelector"):
        return asyncio.SelectorEventLoop(PreciseEpollSelector())
    return asyncio.new_event_loop()


def make_realtime(priority: int) -> bool:
    """Put the calling thread in the ``SCHED_FIFO`` real-time class at ``priority``; threads and processes it
    creates afterwards inherit it (controller threads step one below with :func:`step_below_realtime`, planner
    processes return to the ordinary class with :func:`make_ordinary`).

    On a busy machine an ordinary thread waits behind other processes for the CPU for tens of milliseconds;
    a real-time one runs when it wakes. The whole process must be real-time, not the event loop's thread alone:
    a thread that holds the GIL and is descheduled would make the event loop wait as long (priority
    inversion). Linux keeps 5 % of the CPU for ordinary tasks whatever real-time ones do.
    Needs ``CAP_SYS_NICE`` (or root); returns False, changing nothing, where it is not allowed.
    """
    if not hasattr(os, "SCHED_FIFO") or priority <= 0:
        return False
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (PermissionError, OSError):
        return False
    return True


def step_below_realtime() -> None:
    """In a real-time thread, drop one priority level, so the event loop's thread preempts this one."""
    with contextlib.suppress(PermissionError, OSError, AttributeError):
        if os.sched_getscheduler(0) == os.SCHED_FIFO:
            priority = os.sched_getparam(0).sched_priority
            if priority > 1:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority - 1))


def make_ordinary() -> None:
    """Return the calling thread to the ordinary time-sharing class (planner processes: long searches must
    never take the CPU from the ticks)."""
    with contextlib.suppress(PermissionError, OSError, AttributeError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
