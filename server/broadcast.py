"""Latest-value notification from a race's tick task to its subscribers (websockets, API waits)."""

from __future__ import annotations

import asyncio


class Broadcast:
    """:meth:`wait` returns once :attr:`version` has moved past the caller's."""

    def __init__(self) -> None:
        self.version = 0
        self._event = asyncio.Event()

    def publish(self) -> None:
        """Wake every waiter."""
        self.version += 1
        event, self._event = self._event, asyncio.Event()
        event.set()

    async def wait(self, seen: int) -> int:
        """Wait for a version newer than ``seen``; returns it."""
        while self.version == seen:
            await self._event.wait()
        return self.version
