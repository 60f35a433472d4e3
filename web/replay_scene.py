"""The replay player of a stored race: the race's 3D scene (:class:`~web.scene.RaceScene`) driven by playback
clocks instead of a live race.

Each viewer (a browser tab: one viser client) has a playback of its own (:class:`Playback`): its own karts,
plans and HUD (:class:`~web.race_nodes.RaceNodes`, in that viewer's scope) and its own panel: Play / Pause, a
time slider over the race (scrub: drag it or type a time), a speed choice (0.25x-8x) and the scene's "Follow"
camera. So one viewer playing, pausing or scrubbing moves nothing in another's view, and a tab that opens the
replay starts at the grid, paused, whatever others watch. The track is shared. A daemon thread advances every
viewer's clock about :data:`PLAYBACK_HZ` times a second and shows each its frame; the frames come from a
:class:`FrameSource` (the server builds them from the stored replay).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from typing import Protocol

import viser

from sim_core.track import Track
from web.frame import RaceFrame
from web.hud import markdown_text
from web.race_nodes import RaceNodes
from web.scene import CAMERA_PERIOD, RaceScene

log = logging.getLogger(__name__)

PLAYBACK_HZ = 30.0  # [Hz] frames shown per second of wall time
SPEEDS = ("0.25x", "0.5x", "1x", "2x", "4x", "8x")
TIME_STEP = 0.1  # [s] the time slider's resolution
PLAY, PAUSE = "Play", "Pause"


class FrameSource(Protocol):
    """A recorded race: ``frame(step)`` for ``step`` in ``0..steps`` (0 is the grid)."""

    @property
    def steps(self) -> int:
        """The last step."""

    @property
    def dt(self) -> float:
        """[s] per step."""

    def frame(self, step: int, status: str = "replay") -> RaceFrame:
        """The race after ``step`` steps."""


class Playback:
    """One viewer's playback clock over a race of ``duration`` seconds: paused at the grid at first; thread-safe
    (the viewer's panel sets it from viser's threads, the player's thread advances it)."""

    def __init__(self, duration: float) -> None:
        self.duration = duration  # [s]
        self._lock = threading.Lock()
        self._time = 0.0  # [s] the moment of the race shown
        self._playing = False
        self._speed = 1.0

    @property
    def time(self) -> float:
        """[s] the moment of the race shown."""
        return self._time

    @property
    def playing(self) -> bool:
        """Whether the clock runs."""
        return self._playing

    @property
    def speed(self) -> float:
        """Race seconds per wall-clock second."""
        return self._speed

    def state(self) -> tuple[float, bool]:
        """(time [s], playing), read together."""
        with self._lock:
            return self._time, self._playing

    def play(self) -> None:
        """Run the clock (from the start again when at the end)."""
        with self._lock:
            if self._time >= self.duration:
                self._time = 0.0
            self._playing = True

    def pause(self) -> None:
        """Stop the clock."""
        with self._lock:
            self._playing = False

    def seek(self, seconds: float) -> None:
        """Show the race at ``seconds`` (clamped to the race)."""
        with self._lock:
            self._time = min(max(float(seconds), 0.0), self.duration)

    def set_speed(self, factor: float) -> None:
        """Play at ``factor`` times real time."""
        with self._lock:
            self._speed = float(factor)

    def advance(self, wall_seconds: float) -> None:
        """``wall_seconds`` of wall time went by: a running clock moves on at its speed, and stops at the end."""
        with self._lock:
            if self._playing:
                self._time = min(self._time + wall_seconds * self._speed, self.duration)
                if self._time >= self.duration:
                    self._playing = False


class _ReplayViewer:
    """One viewer of a replay: its playback, its panel and its own karts, plans and HUD (in its scope)."""

    def __init__(
        self, client: viser.ClientHandle, track: Track, karts: Sequence[tuple[str, str]], duration: float
    ) -> None:
        self.client = client
        self.playback = Playback(duration)
        self.shown: tuple[int, str] | None = None
        self.nodes = RaceNodes(client.scene, client.gui, track, karts)
        gui = client.gui
        self.play_button = gui.add_button(PLAY, order=1.0)
        self.slider = gui.add_slider("Time [s]", 0.0, max(round(duration, 1), TIME_STEP), TIME_STEP, 0.0, order=2.0)
        self.speed_choice = gui.add_dropdown("Speed", SPEEDS, initial_value="1x", order=3.0)

        @self.play_button.on_click
        def _(_: viser.GuiEvent) -> None:
            self.pause() if self.playback.playing else self.play()

        @self.slider.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # the viewer moved it (the clock's own moves have no client)
                self.playback.seek(float(self.slider.value))

        @self.speed_choice.on_update
        def _(_: viser.GuiEvent) -> None:
            self.playback.set_speed(float(self.speed_choice.value.rstrip("x")))

    def play(self) -> None:
        """Play (the button then says Pause)."""
        self.playback.play()
        self.play_button.label = PAUSE

    def pause(self) -> None:
        """Pause (the button then says Play)."""
        self.playback.pause()
        self.play_button.label = PLAY

    def show(self, frames: FrameSource, cache: dict[tuple[int, str], RaceFrame], force: bool = False) -> RaceFrame:
        """Show the frame of this viewer's moment (``cache``: the frames already built this period, by step and
        status); returns it."""
        seconds, playing = self.playback.state()
        step = round(seconds / frames.dt)
        status = "replay" if playing else "replay (paused)"
        if playing != (self.play_button.label == PAUSE):
            self.play_button.label = PAUSE if playing else PLAY
        frame = cache.get((step, status))
        if frame is None:
            frame = cache[step, status] = frames.frame(step, status)
        # the nodes skip unchanged poses themselves; showing every period keeps the HUD fresh
        with self.client.atomic():
            self.nodes.show(frame, time.monotonic())
        if force or (step, status) != self.shown:
            self.shown = (step, status)
            self.slider.value = round(seconds, 1)  # type: ignore[misc]  # (its setter is inherited; the stubs miss it)
        return frame


class ReplayScene:
    """A stored race's replay player on its own viser server (127.0.0.1, an ephemeral port), a playback per
    viewer.

    Args:
        track: the race's track.
        karts: ``(display name, controller name)`` per grid slot.
        label: shown in the panel title.
        frames: the recorded race.
        page_url: the race's page, linked from the panel.
    """

    def __init__(
        self, track: Track, karts: Sequence[tuple[str, str]], label: str, frames: FrameSource, page_url: str
    ) -> None:
        self.frames = frames
        self.track = track
        self.karts = list(karts)
        self.duration = frames.steps * frames.dt  # [s]
        self._viewers: dict[int, _ReplayViewer] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.scene = RaceScene(track, karts, label, shared=False, viewer_joined=self._joined, viewer_left=self._left)
        try:
            info = f"Replay · {self.duration:.1f} s · [race page]({markdown_text(page_url)})"
            self.scene.server.gui.add_markdown(info, order=4.0)
        except BaseException:
            self.scene.close()
            raise
        self._thread = threading.Thread(target=self._run, name=f"replay {label}", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ public API
    @property
    def port(self) -> int:
        """The viser server's TCP port on 127.0.0.1."""
        return self.scene.port

    @property
    def viewers(self) -> int:
        """Browser tabs connected now."""
        return self.scene.viewer_count

    def playbacks(self) -> dict[int, Playback]:
        """Each connected viewer's playback, by viser client id."""
        with self._lock:
            return {client_id: viewer.playback for client_id, viewer in self._viewers.items()}

    def close(self) -> None:
        """Stop playback and the viser server (blocking; idempotent)."""
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(2.0)
        self.scene.close()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self.scene.closed

    # ------------------------------------------------------------------ viewers
    def _joined(self, client: viser.ClientHandle) -> None:
        viewer = _ReplayViewer(client, self.track, self.karts, self.duration)
        viewer.show(self.frames, {}, force=True)  # the grid, at once
        with self._lock:
            # a tab that closed while its view was built has already left (viser forgets it before saying so)
            if client.client_id in self.scene.server.get_clients():
                self._viewers[client.client_id] = viewer

    def _left(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._viewers.pop(client.client_id, None)

    # ------------------------------------------------------------------ playback
    def _run(self) -> None:
        period = 1.0 / PLAYBACK_HZ
        last = time.monotonic()
        camera_due = 0.0
        while not self._stop.wait(period):
            now = time.monotonic()
            with self._lock:
                viewers = list(self._viewers.items())
            cache: dict[tuple[int, str], RaceFrame] = {}
            cameras = now >= camera_due
            if cameras:
                camera_due = now + CAMERA_PERIOD
            for client_id, viewer in viewers:
                viewer.playback.advance(now - last)
                try:
                    frame = viewer.show(self.frames, cache)
                    if cameras:
                        self.scene.follow(client_id, frame.karts)
                except Exception:
                    with self._lock:
                        gone = client_id not in self._viewers
                    if not gone:  # (a viewer that just left fails harmlessly)
                        log.exception("replay %s: showing viewer %d a frame failed", self.scene.label, client_id)
            last = now
