"""An asyncio event loop whose timers fire to the microsecond, for the 50 Hz race ticks.

The standard selector loop waits with ``epoll_wait``, whose timeout is whole milliseconds rounded up, so a
timer set for a tick deadline fires 0-1 ms late (about 0.5 ms on average). Here the wait itself is a
``select()`` on the epoll descriptor (microsecond timeout, wakes on any registered socket), followed by a
non-blocking ``epoll_wait`` that collects the events.
"""

from __future__ import annotations

import asyncio
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
