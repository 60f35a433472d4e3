"""The 3D view of one race: a viser server per race, with the track, and the karts, plans and HUD
(:mod:`web.race_nodes`) fed one :class:`~web.frame.RaceFrame` per tick.

The scene is built once in the constructor; :meth:`RaceScene.update` only moves, shows and hides existing nodes.
A live race's scene has one set of karts, plans and HUD, which every viewer sees; a replay's
(``shared=False``, :mod:`web.replay_scene`) has none of its own: its owner gives each viewer theirs, in that
viewer's scope, when it connects (``viewer_joined``). Node names: ``/track/...`` (:mod:`web.meshes`), and
``/karts/...`` and ``/plans/...`` (:mod:`web.race_nodes`).

The GUI has the HUD (:mod:`web.hud`: markdown), the colour legend and a per-viewer "Follow" dropdown whose camera
chases the chosen kart; a viewer whose websocket URL asks for ``?follow=K`` (the drive page's view, through
viser's ``?websocket=`` page parameter) starts chasing kart ``K`` (grid index). The viser server listens on
127.0.0.1 only; browsers reach it through :mod:`web.viewer`'s relay.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from urllib.parse import parse_qs, urlsplit

import viser

from sim_core.track import Track
from web.frame import KartFrame, RaceFrame
from web.hud import legend_text
from web.meshes import add_lighting, add_track
from web.race_nodes import HUD_ORDER, RaceNodes, _PoseWriter
from web.race_nodes import WAYPOINT_POOL as WAYPOINT_POOL

log = logging.getLogger(__name__)

CAMERA_PERIOD = 0.05  # [s] wall-clock time between follow-camera moves (20 Hz)
FOLLOW_BEHIND = 11.0  # [m] follow camera distance behind the kart
FOLLOW_ABOVE = 5.0  # [m] follow camera height
FOLLOW_AHEAD = 6.0  # [m] the follow camera looks this far ahead of the kart
FREE_CAMERA = "Free camera"
# contextlib.redirect_stdout swaps the process-wide sys.stdout; races start their scenes in threads at once, and
# unserialised swaps could leave sys.stdout pointing at one scene's buffer for good
_STDOUT_SWAP = threading.Lock()


@dataclass
class _Viewer:
    """One connected browser tab and its "Follow" dropdown."""

    client: viser.ClientHandle
    follow: viser.GuiDropdownHandle[str]


ViewerHook = Callable[[viser.ClientHandle], None]


class RaceScene:
    """One race's 3D scene on its own viser server (``127.0.0.1``, an ephemeral port).

    Args:
        track: the race's track.
        karts: ``(display name, controller name)`` per grid slot.
        label: shown in the viewer's panel title (e.g. ``"Race 3f2a: oval"``).
        shared: one set of karts, plans and HUD for every viewer (:attr:`nodes`, fed by :meth:`update`); False:
            none (each viewer gets its own from ``viewer_joined``).
        viewer_joined: called (in one of viser's threads) with each viewer once its "Follow" dropdown is there.
        viewer_left: called with each viewer that went away.
    """

    def __init__(
        self,
        track: Track,
        karts: Sequence[tuple[str, str]],
        label: str,
        *,
        shared: bool = True,
        viewer_joined: ViewerHook | None = None,
        viewer_left: ViewerHook | None = None,
    ) -> None:
        self.track = track
        self.karts = [(str(name), str(controller)) for name, controller in karts]
        self.label = label
        self._closed = False
        self._errors = 0
        self._camera_due = 0.0
        self._viewers: dict[int, _Viewer] = {}
        self._viewers_lock = threading.Lock()
        self._joined, self._left = viewer_joined, viewer_left
        self.nodes: RaceNodes | None = None

        # viser prints a banner to stdout on start even when not verbose; keep the server's output clean
        with _STDOUT_SWAP, contextlib.redirect_stdout(io.StringIO()):
            self.server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False, label=label)
        log.debug("race viewer %s: viser on 127.0.0.1:%d", label, self.server.get_port())
        try:
            self._build(shared)
        except BaseException:
            self.server.stop()
            raise
        self.server.on_client_connect(self._on_connect)
        self.server.on_client_disconnect(self._on_disconnect)

    # ------------------------------------------------------------------ public API
    @property
    def port(self) -> int:
        """The viser server's TCP port on 127.0.0.1."""
        return int(self.server.get_port())

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._closed

    @property
    def viewer_count(self) -> int:
        """Browser tabs connected now."""
        with self._viewers_lock:
            return len(self._viewers)

    @property
    def _hud(self) -> viser.GuiMarkdownHandle:
        """The shared HUD (a scene with ``shared`` nodes)."""
        assert self.nodes is not None
        return self.nodes.hud

    @property
    def _kart_writers(self) -> list[_PoseWriter]:
        """The shared karts' pose writers (a scene with ``shared`` nodes)."""
        assert self.nodes is not None
        return self.nodes.kart_writers

    def update(self, frame: RaceFrame) -> None:
        """Show ``frame`` on the shared nodes (:meth:`RaceNodes.show <web.race_nodes.RaceNodes.show>`) and move
        the follow cameras at ~20 Hz.

        Cheap, synchronous and non-blocking (called on the server's event loop every tick); never raises: a
        broken viewer must not break a race, so errors are logged (rate-limited) and the frame is dropped.
        """
        if self._closed:
            return
        try:
            now = time.monotonic()
            if self.nodes is not None:
                with self.server.atomic():
                    self.nodes.show(frame, now)
            if now >= self._camera_due:
                self._camera_due = now + CAMERA_PERIOD
                with self._viewers_lock:
                    viewers = list(self._viewers)
                for client_id in viewers:
                    self.follow(client_id, frame.karts)
        except Exception:
            self._errors += 1
            if self._errors <= 3 or self._errors % 1000 == 0:
                log.exception("race viewer %s: update failed (%d errors so far)", self.label, self._errors)

    def follow(self, client_id: int, karts: Sequence[KartFrame]) -> None:
        """Move viewer ``client_id``'s camera behind the kart it follows in ``karts`` (if it follows one)."""
        with self._viewers_lock:
            viewer = self._viewers.get(client_id)
        if viewer is None:
            return
        options = self._follow_options()
        choice = viewer.follow.value
        if choice == FREE_CAMERA or choice not in options:
            return
        index = options.index(choice) - 1
        if index >= len(karts):
            return
        kart = karts[index]
        camera = viewer.client.camera
        try:
            camera.update_timestamp  # noqa: B018  (raises until the browser reported its camera)
        except AssertionError:
            return
        c, s = math.cos(kart.heading), math.sin(kart.heading)
        with contextlib.suppress(ValueError), viewer.client.atomic():
            camera.position = (kart.x - FOLLOW_BEHIND * c, kart.y - FOLLOW_BEHIND * s, FOLLOW_ABOVE)
            camera.look_at = (kart.x + FOLLOW_AHEAD * c, kart.y + FOLLOW_AHEAD * s, 0.0)

    def close(self) -> None:
        """Stop the viser server (blocking, up to a few seconds with live viewers; idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            self.server.stop()
        except Exception:
            log.exception("race viewer %s: stopping viser failed", self.label)

    # ------------------------------------------------------------------ scene construction
    def _build(self, shared: bool) -> None:
        server = self.server
        server.gui.configure_theme(show_share_button=False, control_layout="floating", control_width="large")
        add_lighting(server)
        server.scene.set_up_direction("+z")
        add_track(server, self.track)
        if shared:
            self.nodes = RaceNodes(server.scene, server.gui, self.track, self.karts)
        server.gui.add_markdown(legend_text(), order=HUD_ORDER + 1.0)

    # ------------------------------------------------------------------ per-viewer GUI
    def _follow_options(self) -> list[str]:
        return [FREE_CAMERA, *(f"{i + 1}: {name}" for i, (name, _) in enumerate(self.karts))]

    def _requested_follow(self, client: viser.ClientHandle) -> str:
        """The option a viewer asked to start on (``?follow=K`` on its websocket URL), else the free camera."""
        try:  # viser 1.1.x keeps each client's websocket connection, with its request, here
            request = self.server._websock_server._live_connections[client.client_id].request
        except Exception:
            return FREE_CAMERA
        asked = parse_qs(urlsplit(request.path).query).get("follow", [""])[-1] if request is not None else ""
        options = self._follow_options()
        if asked.isascii() and asked.isdigit() and int(asked) + 1 < len(options):
            return options[int(asked) + 1]
        return FREE_CAMERA

    def _on_connect(self, client: viser.ClientHandle) -> None:
        initial = self._requested_follow(client)
        follow = client.gui.add_dropdown("Follow", self._follow_options(), initial_value=initial, order=0.0)
        if self._joined is not None:
            try:
                self._joined(client)
            except Exception as exc:  # (a tab closed while its view was being built, most likely)
                log.warning("race viewer %s: viewer %d not set up: %r", self.label, client.client_id, exc)
                return
        with self._viewers_lock:
            self._viewers[client.client_id] = _Viewer(client, follow)

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._viewers_lock:
            self._viewers.pop(client.client_id, None)
        if self._left is not None:
            self._left(client)
