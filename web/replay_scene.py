"""The replay player of a stored race: the race's 3D scene (:class:`~web.scene.RaceScene`) driven by a playback
clock instead of a live race.

Its panel has Play / Pause, a time slider over the race (scrub: drag it or type a time), a speed choice
(0.25x-8x) and, per viewer, the scene's "Follow" camera. The clock is the scene's, so everyone watching one
race's replay watches the same moment (like a shared screen). A daemon thread advances the clock about
:data:`PLAYBACK_HZ` times a second and shows the frame of that moment; the frames come from a
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
from web.scene import RaceScene

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


class ReplayScene:
    """A stored race's replay player on its own viser server (127.0.0.1, an ephemeral port).

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
        self.duration = frames.steps * frames.dt  # [s]
        self._lock = threading.Lock()
        self._time = 0.0  # [s] the playback clock
        self._playing = False
        self._speed = 1.0
        self._shown: tuple[int, str] | None = None
        self._stop = threading.Event()
        self.scene = RaceScene(track, karts, label)
        try:
            self._build(page_url)
        except BaseException:
            self.scene.close()
            raise
        self._show(force=True)
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

    @property
    def time(self) -> float:
        """[s] the moment of the race shown."""
        return self._time

    @property
    def playing(self) -> bool:
        """Whether the clock runs."""
        return self._playing

    def play(self) -> None:
        """Run the clock (from the start again when at the end)."""
        with self._lock:
            if self._time >= self.duration:
                self._time = 0.0
            self._playing = True
        self._play_button.label = PAUSE

    def pause(self) -> None:
        """Stop the clock."""
        with self._lock:
            self._playing = False
        self._play_button.label = PLAY

    def seek(self, seconds: float) -> None:
        """Show the race at ``seconds`` (clamped to the race)."""
        with self._lock:
            self._time = min(max(float(seconds), 0.0), self.duration)

    def set_speed(self, factor: float) -> None:
        """Play at ``factor`` times real time."""
        with self._lock:
            self._speed = float(factor)

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

    # ------------------------------------------------------------------ the panel
    def _build(self, page_url: str) -> None:
        gui = self.scene.server.gui
        self._play_button = gui.add_button(PLAY, order=1.0)
        self._slider = gui.add_slider(
            "Time [s]", 0.0, max(round(self.duration, 1), TIME_STEP), TIME_STEP, 0.0, order=2.0
        )
        self._speed_choice = gui.add_dropdown("Speed", SPEEDS, initial_value="1x", order=3.0)
        gui.add_markdown(f"Replay · {self.duration:.1f} s · [race page]({markdown_text(page_url)})", order=4.0)

        @self._play_button.on_click
        def _(_: viser.GuiEvent) -> None:
            self.pause() if self._playing else self.play()

        @self._slider.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # a viewer moved it (the clock's own moves have no client)
                self.seek(float(self._slider.value))

        @self._speed_choice.on_update
        def _(_: viser.GuiEvent) -> None:
            self.set_speed(float(self._speed_choice.value.rstrip("x")))

    # ------------------------------------------------------------------ playback
    def _run(self) -> None:
        period = 1.0 / PLAYBACK_HZ
        last = time.monotonic()
        while not self._stop.wait(period):
            now = time.monotonic()
            with self._lock:
                if self._playing:
                    self._time = min(self._time + (now - last) * self._speed, self.duration)
                    if self._time >= self.duration:
                        self._playing = False
            last = now
            try:
                self._show()
            except Exception:
                log.exception("replay %s: showing a frame failed", self.scene.label)

    def _show(self, force: bool = False) -> None:
        with self._lock:
            seconds, playing = self._time, self._playing
        step = round(seconds / self.frames.dt)
        status = "replay" if playing else "replay (paused)"
        if playing != (self._play_button.label == PAUSE):
            self._play_button.label = PAUSE if playing else PLAY
        # the scene skips unchanged poses itself; updating every period keeps follow cameras and the HUD fresh
        self.scene.update(self.frames.frame(step, status))
        if force or (step, status) != self._shown:
            self._shown = (step, status)
            self._slider.value = round(seconds, 1)  # type: ignore[misc]  # (its setter is inherited; the stubs miss it)
