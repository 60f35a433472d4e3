"""A tournament's PNG plots for the pages (:func:`arena.report.plot_report`: win-matrix heatmaps, safety bars,
finish-time distributions), drawn on matplotlib's Agg backend and kept in memory.

Plots are drawn all at once for a tournament's races so far and cached under its id and number of stored races:
a finished tournament is drawn once, a running one again only after a new race was stored. pyplot's state is
global, so drawing is serialised; the cache keeps the newest few tournaments.
"""

from __future__ import annotations

import tempfile
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from arena.records import RaceFigures
from arena.report import plot_report
from arena.stats import tournament_stats

_DRAWING = threading.Lock()  # pyplot is not thread-safe


class TournamentPlots:
    """PNG plots per (tournament, races stored), the newest ``keep`` tournaments' in memory."""

    def __init__(self, keep: int = 8) -> None:
        self.keep = keep
        self._cache: OrderedDict[tuple[str, int], Mapping[str, bytes]] = OrderedDict()
        self._lock = threading.Lock()
        self.drawn = 0  # how many times plots were drawn (tests check the cache with it)

    def plots(self, tournament_id: str, done: int, figures: Callable[[], Sequence[RaceFigures]]) -> Mapping[str, bytes]:
        """``{stem: PNG bytes}`` of the tournament with ``done`` races stored; ``figures()`` reads its races
        (called only when they are not cached). Empty when it has no race."""
        key = (tournament_id, done)
        with self._lock:
            if key in self._cache:
                self._cache.move_to_end(key)
                return self._cache[key]
        with _DRAWING:
            with self._lock:  # drawn by another request while this one waited
                if key in self._cache:
                    return self._cache[key]
            races = list(figures())
            drawn = _draw(races) if races else {}
            self.drawn += 1
        with self._lock:
            for stale in [k for k in self._cache if k[0] == tournament_id]:
                del self._cache[stale]
            self._cache[key] = drawn
            while len(self._cache) > self.keep:
                self._cache.popitem(last=False)
        return drawn


def _draw(races: Sequence[RaceFigures]) -> dict[str, bytes]:
    with tempfile.TemporaryDirectory(prefix="karting-plots-") as folder:
        paths = plot_report(tournament_stats(races), races, Path(folder))
        return {path.stem: path.read_bytes() for path in paths}
