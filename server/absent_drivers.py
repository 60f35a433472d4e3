"""How long a race bears with drivers who are not there: before the start, the wait for its human drivers
(:class:`DriverWait`: a driver who never connects cancels the race); while it runs, a race in which no unfinished
kart can move (:class:`StuckWatch`: it ends). Both are decisions on the drivers' state at a moment of
``time.monotonic()``; the race session (:mod:`server.session`) acts on them.

The waits are the settings ``human_wait_s``, ``view_ready_wait_s`` and ``abandoned_race_s``
(:class:`server.settings.Settings`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from server.drivers import KartDriver
from server.settings import Settings


def not_ready(drivers: Sequence[KartDriver]) -> list[KartDriver]:
    """The human drivers not connected yet, or whose view is not ready yet."""
    return [d for d in drivers if d.human and not (d.ever_connected and d.view_ready)]


@dataclass(frozen=True)
class WaitOver:
    """The wait for the human drivers is over: the race starts (``cancel`` None; ``late``: the drivers whose view
    was not ready in time) or is cancelled for the reason ``cancel``."""

    cancel: str | None = None
    late: tuple[str, ...] = ()


class DriverWait:
    """A race's wait, from ``start`` [s, monotonic], for its human drivers: at most ``human_wait_s`` for every
    one to connect (a driver who never comes cancels the race: it would run with a parked kart), then at most
    ``view_ready_wait_s`` for their views to load (then the race starts anyway)."""

    def __init__(self, drivers: Sequence[KartDriver], settings: Settings, start: float) -> None:
        self.humans = [d for d in drivers if d.human]
        self.settings = settings
        self.joined_by = start + settings.human_wait_s
        self.ready_by: float | None = None  # set once every driver has connected

    def over(self, now: float) -> WaitOver | None:
        """The end of the wait at ``now`` [s, monotonic], or None while the race still waits."""
        waiting = not_ready(self.humans)
        if not waiting:
            return WaitOver()
        if self.ready_by is None and all(d.ever_connected for d in self.humans):
            self.ready_by = now + self.settings.view_ready_wait_s
        if self.ready_by is None and now >= self.joined_by:
            absent = ", ".join(str(d.index) for d in self.humans if not d.ever_connected)
            wait_s, setting = self.settings.human_wait_s, self.settings.env_name("human_wait_s")
            return WaitOver(cancel=f"no driver joined kart(s) {absent} within {wait_s:g} s ({setting})")
        if self.ready_by is not None and now >= self.ready_by:
            return WaitOver(late=tuple(d.name for d in waiting))
        return None


class StuckWatch:
    """Notices a running race that no unfinished kart could move in for ``abandoned_race_s``: each one an absent
    or silent human, or an AI whose controller is disabled."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self._since: float | None = None  # [s] monotonic: since when no unfinished kart could move

    def check(self, unfinished: Sequence[KartDriver], now: float) -> str | None:
        """Why the race ends at ``now`` [s, monotonic], given its ``unfinished`` karts' drivers; None: it goes on."""
        if not all((d.braking and (d.human or d.disabled)) for d in unfinished):
            self._since = None
            return None
        if self._since is None:
            self._since = now
            return None
        if now - self._since < self.settings.abandoned_race_s:
            return None
        karts = ", ".join(str(d.index) for d in unfinished)
        why = f"no unfinished kart could move for {self.settings.abandoned_race_s:g} s: kart(s) {karts} "
        return why + "absent, silent or disabled (not finished)"
