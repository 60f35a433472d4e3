"""Stored races brought back: re-simulated from their replays (:class:`RecordedRaces`, cached) and played in
replay scenes opened on demand (:class:`ReplayScenes`: a bounded number at once, closed when idle)."""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from controllers.timeline import RaceTimeline, resimulate
from server.db import RaceDatabase, StoredRace
from server.live import LiveRaces
from server.race_config import kart_paces
from server.race_report import RaceReport, race_report
from server.replay_frames import ReplayFrames
from sim_core.conditions import RaceConditions
from sim_core.params import SimParams, kart_preset
from sim_core.track import Track
from web.viewer import ViewersBusyError

log = logging.getLogger(__name__)

REAP_PERIOD_S = 5.0  # [s] between checks for idle replay scenes


@dataclass(frozen=True)
class RecordedRace:
    """A stored race with its replay re-simulated."""

    race: StoredRace
    track: Track
    replay: dict[str, Any]
    timeline: RaceTimeline

    def frames(self) -> ReplayFrames:
        """The race as the replay player's frames."""
        race = self.race
        records = sorted(race.result.karts, key=lambda k: k.index) if race.result is not None else []
        faults = [k.faults.controller_faults for k in records]  # (the race's totals: not kept per step)
        return ReplayFrames(
            race.id, race.track, race.laps, race.karts, self.timeline, self.replay.get("plans") or [], faults
        )

    def report(self) -> RaceReport:
        """The race's figures for its page."""
        return race_report(self.race.id, self.timeline, self.race.laps)


class RecordedRaces:
    """Stored races re-simulated from their replays, the last ``cache_size`` kept (a finished race never
    changes). Blocking: call from a thread."""

    def __init__(self, db: RaceDatabase, load_track: Callable[[str], Track], cache_size: int = 8) -> None:
        self.db = db
        self.load_track = load_track
        self.cache_size = cache_size
        self._cache: OrderedDict[str, RecordedRace] = OrderedDict()
        self._lock = threading.Lock()

    def load(self, race_id: str) -> RecordedRace | None:
        """The race re-simulated, or ``None`` when there is no such race or it has no replay (yet)."""
        with self._lock:
            if race_id in self._cache:
                self._cache.move_to_end(race_id)
                return self._cache[race_id]
        race = self.db.get(race_id)
        if race is None or race.result is None:
            return None
        replay = self.db.replay(race_id)
        if replay is None:
            return None
        track = self.load_track(race.track)
        poses = np.asarray(replay.get("poses") or [], dtype=np.float64).reshape(-1, len(race.karts), 6)
        params = SimParams(kart=kart_preset(race.kart_preset))
        start_lanes = tuple(race.start_lanes) if race.start_lanes is not None else None
        drawn = _drawn_conditions(race)
        drawn_paces = drawn.paces if drawn is not None else (1.0,) * len(race.karts)
        paces = kart_paces(race.karts, drawn_paces, [k.human for k in race.karts])
        timeline = resimulate(poses, track, race.laps, params, start_lanes, drawn, paces)
        if timeline.pose_error > 1e-6:
            strays = timeline.pose_error
            log.warning("race %s: its re-simulation strays %.3f m from the recorded poses", race_id, strays)
        recorded = RecordedRace(race, track, replay, timeline)
        with self._lock:
            self._cache[race_id] = recorded
            while len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)
        return recorded


class ReplayView(Protocol):
    """A replay scene (``web.replay_scene.ReplayScene``)."""

    @property
    def port(self) -> int:
        """Its viser server's local TCP port."""

    @property
    def viewers(self) -> int:
        """Browser tabs connected now."""

    def close(self) -> None:
        """Stop serving (blocking)."""


@dataclass
class _Open:
    view: ReplayView
    last_seen: float  # [s] monotonic: when it last had a viewer or was asked for
    relayed: int = 0  # browser websockets relayed to it now

    @property
    def watched(self) -> bool:
        """Whether anyone watches (a relayed websocket, or a viewer the scene itself counts)."""
        return self.relayed > 0 or self.view.viewers > 0


class ReplayScenes:
    """Replay scenes by race id, opened on demand by ``open_view(race_id)`` (blocking; ``None``: the race has no
    replay), at most ``max_open`` at once; one without viewers for ``idle_s`` is closed."""

    def __init__(self, open_view: Callable[[str], ReplayView | None], max_open: int, idle_s: float) -> None:
        self.open_view = open_view
        self.max_open = max_open
        self.idle_s = idle_s
        self._open: dict[str, _Open] = {}
        self._opening: dict[str, asyncio.Task[ReplayView | None]] = {}
        self._reaper: asyncio.Task[None] | None = None

    def start(self) -> None:
        """Start closing idle scenes (on the running loop)."""
        self._reaper = asyncio.get_running_loop().create_task(self._reap_forever(), name="replay-scenes-reaper")

    def open_count(self) -> int:
        """Scenes open or opening."""
        return len(self._open) + len(self._opening)

    async def port(self, race_id: str) -> int | None:
        """The local port of ``race_id``'s replay scene, opened if need be; ``None`` when the race has no replay.
        Raises :class:`web.viewer.ViewersBusyError` when ``max_open`` scenes have viewers."""
        entry = self._open.get(race_id)
        if entry is not None:
            entry.last_seen = time.monotonic()
            return entry.view.port
        task = self._opening.get(race_id)
        if task is None:
            if self.open_count() >= self.max_open and not self._idle():
                raise ViewersBusyError(f"{self.max_open} replays are being watched; try again later")
            task = asyncio.get_running_loop().create_task(asyncio.to_thread(self.open_view, race_id))
            self._opening[race_id] = task
            task.add_done_callback(lambda done: self._opened(race_id, done))
        view = await asyncio.shield(task)
        if view is None:
            return None
        self._open.setdefault(race_id, _Open(view, time.monotonic()))
        # only a race that has a replay makes an idle scene give way
        while len(self._open) > self.max_open and (idle := self._idle(but=race_id)):
            await self._close(min(idle)[1])
        return view.port

    def _opened(self, race_id: str, task: asyncio.Task[ReplayView | None]) -> None:
        self._opening.pop(race_id, None)
        if not task.cancelled() and task.exception() is None and (view := task.result()) is not None:
            self._open[race_id] = _Open(view, time.monotonic())

    def _idle(self, but: str | None = None) -> list[tuple[float, str]]:
        """(last seen, race id) of the open scenes without viewers (besides ``but``)."""
        return [(e.last_seen, rid) for rid, e in self._open.items() if not e.watched and rid != but]

    def viewer_joined(self, race_id: str) -> None:
        """A browser's websocket is being relayed to ``race_id``'s scene."""
        entry = self._open.get(race_id)
        if entry is not None:
            entry.relayed += 1
            entry.last_seen = time.monotonic()

    def viewer_left(self, race_id: str) -> None:
        """A relayed websocket of ``race_id``'s scene ended."""
        entry = self._open.get(race_id)
        if entry is not None:
            entry.relayed = max(entry.relayed - 1, 0)
            entry.last_seen = time.monotonic()

    async def _close(self, race_id: str) -> None:
        entry = self._open.pop(race_id, None)
        if entry is not None:
            try:
                await asyncio.to_thread(entry.view.close)
            except Exception:
                log.exception("replay %s: closing its scene failed", race_id)

    async def close_idle(self) -> None:
        """Close every scene without viewers for ``idle_s``."""
        now = time.monotonic()
        for race_id, entry in list(self._open.items()):
            if entry.watched:
                entry.last_seen = now
            elif now - entry.last_seen > self.idle_s:
                log.info("replay %s: closed after %.0f s without viewers", race_id, now - entry.last_seen)
                await self._close(race_id)

    async def _reap_forever(self) -> None:
        while True:
            await asyncio.sleep(min(REAP_PERIOD_S, max(self.idle_s / 2, 0.1)))
            await self.close_idle()

    async def shutdown(self) -> None:
        """Close every scene."""
        if self._reaper is not None:
            self._reaper.cancel()
        for task in list(self._opening.values()):
            await asyncio.gather(task, return_exceptions=True)
        for race_id in list(self._open):
            await self._close(race_id)


class StoredReplays:
    """The replay player's view of the server (``web.routes.ReplayDirectory``): which races have a replay, and
    their replay scenes. ``races`` and ``scenes`` are read when asked (the app's lifespan makes them)."""

    def __init__(self, races: Callable[[], LiveRaces], scenes: Callable[[], ReplayScenes]) -> None:
        self.races = races
        self.scenes = scenes

    async def has_replay(self, race_id: str) -> bool:
        """Whether ``race_id`` is over with its result and replay stored."""
        races = self.races()
        session = races.get(race_id)
        if session is not None:
            return not session.live and session.result is not None
        stored = await asyncio.to_thread(races.services.db.get, race_id)
        return stored is not None and stored.result is not None

    def viewer_joined(self, race_id: str) -> None:
        """A browser started watching ``race_id``'s replay."""
        self.scenes().viewer_joined(race_id)

    def viewer_left(self, race_id: str) -> None:
        """A browser stopped watching ``race_id``'s replay."""
        self.scenes().viewer_left(race_id)

    async def replay_port(self, race_id: str) -> int | None:
        """The race's replay scene port (opened if need be); ``None`` without a replay or without 3D views."""
        session = self.races().get(race_id)
        if session is not None and (session.live or session.result is None):
            return None
        return await self.scenes().port(race_id)


def _drawn_conditions(race: StoredRace) -> RaceConditions | None:
    """The conditions the race ran under, as its manifest recorded them (None: none recorded, or unreadable)."""
    manifest = race.result.manifest if race.result is not None else None
    drawn = manifest.conditions.get("conditions") if manifest is not None else None
    if not isinstance(drawn, dict):
        return None
    try:
        return RaceConditions.from_json(drawn)
    except (TypeError, ValueError):
        log.warning("race %s: its recorded conditions cannot be read; re-simulated under the paper's", race.id)
        return None
