"""The live 3D view of one race: a viser server per race session, fed one :class:`~web.frame.RaceFrame` per tick.

The scene is built once in the constructor; :meth:`RaceScene.update` only moves, shows and hides existing nodes
(viser coalesces to the latest value per node, so slow viewers skip frames instead of queueing them). Node names:

* ``/track/...``: the track (:mod:`web.meshes`);
* ``/karts/kart{i}`` (a box in the kart's colour), ``/karts/kart{i}/nose`` (marks the front),
  ``/karts/kart{i}/label`` (its display name);
* ``/plans/kart{i}/wp{j}`` (green boxes: the kart's planned waypoints) and ``/plans/kart{i}/pred{j}``
  (translucent orange boxes: its planner's predictions of the other karts' waypoints), hidden when unused.

The GUI has a HUD (:mod:`web.hud`: markdown, shared by every viewer) and a per-viewer "Follow" dropdown whose
camera chases the chosen kart; a viewer whose websocket URL asks for ``?follow=K`` (the drive page's view,
through viser's ``?websocket=`` page parameter) starts chasing kart ``K`` (grid index). The viser server listens
on 127.0.0.1 only; browsers reach it through :mod:`web.viewer`'s relay.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from urllib.parse import parse_qs, urlsplit

import viser

from sim_core.track import Track
from web.frame import KART_COLORS, KartFrame, RaceFrame, kart_label
from web.hud import hud_text, legend_text
from web.meshes import PREDICTION_COLOR, WAYPOINT_COLOR, add_track, heading_wxyz

log = logging.getLogger(__name__)

KART_SIZE = (2.0, 0.9, 0.5)  # [m] length, width, height of the kart boxes
KART_CLEARANCE = 0.05  # [m] gap under the kart box
WAYPOINT_POOL = 10  # green waypoint boxes per kart
PREDICTION_POOL_PER_OPPONENT = 8  # orange prediction boxes per opponent (the planner's horizon)
PREDICTION_POOL_MAX = 24
WAYPOINT_SIZE = 1.0  # [m] edge of a green waypoint box
PREDICTION_SIZE = 0.7  # [m] edge of an orange prediction box
HUD_PERIOD = 0.25  # [s] wall-clock time between HUD refreshes
CAMERA_PERIOD = 0.05  # [s] wall-clock time between follow-camera moves (20 Hz)
FOLLOW_BEHIND = 11.0  # [m] follow camera distance behind the kart
FOLLOW_ABOVE = 5.0  # [m] follow camera height
FOLLOW_AHEAD = 6.0  # [m] the follow camera looks this far ahead of the kart
FREE_CAMERA = "Free camera"
# contextlib.redirect_stdout swaps the process-wide sys.stdout; races start their scenes in threads at once, and
# unserialised swaps could leave sys.stdout pointing at one scene's buffer for good
_STDOUT_SWAP = threading.Lock()


class _PoseWriter:
    """Sets a scene node's position / orientation for the per-tick path.

    viser's public setters compare every new value with the old one through ``np.allclose`` (about 15-30 µs per
    assignment, most of :meth:`RaceScene.update`); the scene already skips unchanged poses itself, so with the
    pinned viser (1.1.x) this writes the handle's state and queues the same message directly. If viser's
    internals ever differ, it falls back to the public setters (``fast`` is then False).
    """

    def __init__(self, node: viser.SceneNodeHandle) -> None:
        self.node = node
        self.fast = False
        try:
            from viser import _messages

            impl = node._impl
            position, wxyz = impl.position, impl.wxyz
            if position.shape == (3,) and wxyz.shape == (4,):
                self._position, self._wxyz, self._name = position, wxyz, str(impl.name)
                self._queue = impl.api._queue_scene_message
                self._position_message = _messages.SetPositionMessage
                self._wxyz_message = _messages.SetOrientationMessage
                self.fast = True
        except Exception:  # pragma: no cover - only with a different viser
            log.warning("viser internals changed: scene updates use the (slower) public setters")

    def position(self, value: tuple[float, float, float]) -> None:
        """Move the node to ``value`` (parent frame)."""
        if self.fast:
            self._position[:] = value
            self._queue(self._position_message(self._name, value))
        else:
            self.node.position = value

    def wxyz(self, value: tuple[float, float, float, float]) -> None:
        """Set the node's orientation (a unit quaternion)."""
        if self.fast:
            self._wxyz[:] = value
            self._queue(self._wxyz_message(self._name, value))
        else:
            self.node.wxyz = value


@dataclass
class _Viewer:
    """One connected browser tab and its "Follow" dropdown."""

    client: viser.ClientHandle
    follow: viser.GuiDropdownHandle[str]


class RaceScene:
    """One race's 3D scene on its own viser server (``127.0.0.1``, an ephemeral port).

    Args:
        track: the race's track.
        karts: ``(display name, controller name)`` per grid slot.
        label: shown in the viewer's panel title (e.g. ``"Race 3f2a: oval"``).
    """

    def __init__(self, track: Track, karts: Sequence[tuple[str, str]], label: str) -> None:
        self.track = track
        self.karts = [(str(name), str(controller)) for name, controller in karts]
        self.label = label
        self._closed = False
        self._errors = 0
        self._plans_version: int | None = None
        self._plan_cache: dict[int, tuple[tuple[tuple[float, float], ...], tuple[tuple[float, float], ...]]] = {}
        self._pose_cache: dict[int, tuple[float, float, float]] = {}
        self._hud_due = 0.0
        self._hud_status = ""
        self._camera_due = 0.0
        self._viewers: dict[int, _Viewer] = {}
        self._viewers_lock = threading.Lock()

        # viser prints a banner to stdout on start even when not verbose; keep the server's output clean
        with _STDOUT_SWAP, contextlib.redirect_stdout(io.StringIO()):
            self.server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False, label=label)
        log.debug("race viewer %s: viser on 127.0.0.1:%d", label, self.server.get_port())
        try:
            self._build()
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

    def update(self, frame: RaceFrame) -> None:
        """Show ``frame``: kart poses every call, plans when ``frame.plans_version`` changed, the HUD a few
        times per second and follow cameras at ~20 Hz.

        Cheap, synchronous and non-blocking (called on the server's event loop every tick); never raises: a
        broken viewer must not break a race, so errors are logged (rate-limited) and the frame is dropped.
        """
        if self._closed:
            return
        try:
            self._update(frame)
        except Exception:
            self._errors += 1
            if self._errors <= 3 or self._errors % 1000 == 0:
                log.exception("race viewer %s: update failed (%d errors so far)", self.label, self._errors)

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
    def _build(self) -> None:
        server = self.server
        track = self.track
        server.gui.configure_theme(show_share_button=False, control_layout="floating", control_width="large")
        server.scene.configure_environment_map("warehouse", environment_intensity=0.45)
        server.scene.set_up_direction("+z")
        scene = server.scene
        add_track(server, track)

        self._kart_nodes: list[viser.BoxHandle] = []
        self._kart_writers: list[_PoseWriter] = []
        self._waypoint_nodes: list[list[viser.BoxHandle]] = []
        self._prediction_nodes: list[list[viser.BoxHandle]] = []
        n = len(self.karts)
        pred_pool = min(PREDICTION_POOL_MAX, PREDICTION_POOL_PER_OPPONENT * max(n - 1, 1))
        for i, (name, controller) in enumerate(self.karts):
            color = KART_COLORS[i % len(KART_COLORS)]
            start = track.lane_point(0, 1 + i % track.n_lanes)
            kart = scene.add_box(
                f"/karts/kart{i}",
                color=color,
                dimensions=KART_SIZE,
                position=(float(start[0]), float(start[1]), KART_CLEARANCE + KART_SIZE[2] / 2),
            )
            scene.add_box(
                f"/karts/kart{i}/nose",
                color=(250, 250, 250),
                dimensions=(0.25, KART_SIZE[1] * 0.8, 0.12),
                position=(KART_SIZE[0] / 2 - 0.2, 0.0, KART_SIZE[2] / 2 + 0.03),
                cast_shadow=False,
            )
            scene.add_label(
                f"/karts/kart{i}/label",
                kart_label(name, controller),
                position=(0.0, 0.0, 1.0),
                anchor="bottom-center",
                font_screen_scale=1.1,
            )
            self._kart_nodes.append(kart)
            self._kart_writers.append(_PoseWriter(kart))
            self._waypoint_nodes.append(
                [
                    scene.add_box(
                        f"/plans/kart{i}/wp{j}",
                        color=WAYPOINT_COLOR,
                        dimensions=(WAYPOINT_SIZE,) * 3,
                        position=(0.0, 0.0, WAYPOINT_SIZE / 2),
                        visible=False,
                        cast_shadow=False,
                    )
                    for j in range(WAYPOINT_POOL)
                ]
            )
            self._prediction_nodes.append(
                [
                    scene.add_box(
                        f"/plans/kart{i}/pred{j}",
                        color=PREDICTION_COLOR,
                        dimensions=(PREDICTION_SIZE,) * 3,
                        position=(0.0, 0.0, PREDICTION_SIZE / 2),
                        opacity=0.55,
                        visible=False,
                        cast_shadow=False,
                    )
                    for j in range(pred_pool)
                ]
            )

        self._waypoint_writers = [[_PoseWriter(node) for node in pool] for pool in self._waypoint_nodes]
        self._prediction_writers = [[_PoseWriter(node) for node in pool] for pool in self._prediction_nodes]
        self._hud = server.gui.add_markdown(hud_text(track.name, self.karts, None), order=10.0)
        self._legend = server.gui.add_markdown(legend_text(), order=11.0)

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
        with self._viewers_lock:
            self._viewers[client.client_id] = _Viewer(client, follow)

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._viewers_lock:
            self._viewers.pop(client.client_id, None)

    # ------------------------------------------------------------------ per-tick work
    def _update(self, frame: RaceFrame) -> None:
        now = time.monotonic()
        karts = frame.karts[: len(self._kart_nodes)]
        plans_changed = frame.plans_version != self._plans_version
        hud_due = now >= self._hud_due or frame.status != self._hud_status
        with self.server.atomic():
            for kart in karts:
                self._move_kart(kart)
            if plans_changed:
                self._plans_version = frame.plans_version
                for kart in karts:
                    self._show_plan(kart)
            if hud_due:
                self._hud_due = now + HUD_PERIOD
                self._hud_status = frame.status
                self._hud.content = hud_text(self.track.name, self.karts, frame)
        if now >= self._camera_due:
            self._camera_due = now + CAMERA_PERIOD
            self._follow_cameras(karts)

    def _move_kart(self, kart: KartFrame) -> None:
        pose = (kart.x, kart.y, kart.heading)
        if self._pose_cache.get(kart.index) == pose:
            return
        self._pose_cache[kart.index] = pose
        writer = self._kart_writers[kart.index]
        writer.position((float(kart.x), float(kart.y), KART_CLEARANCE + KART_SIZE[2] / 2))
        writer.wxyz(heading_wxyz(float(kart.heading)))

    def _show_plan(self, kart: KartFrame) -> None:
        key = (kart.waypoints, kart.predicted)
        if self._plan_cache.get(kart.index) == key:
            return
        self._plan_cache[kart.index] = key
        _show_points(self._waypoint_writers[kart.index], kart.waypoints, WAYPOINT_SIZE / 2 + 0.05)
        _show_points(self._prediction_writers[kart.index], kart.predicted, PREDICTION_SIZE / 2 + 0.05)

    def _follow_cameras(self, karts: Sequence[KartFrame]) -> None:
        with self._viewers_lock:
            viewers = list(self._viewers.values())
        if not viewers:
            return
        options = self._follow_options()
        for viewer in viewers:
            choice = viewer.follow.value
            if choice == FREE_CAMERA or choice not in options:
                continue
            index = options.index(choice) - 1
            if index >= len(karts):
                continue
            kart = karts[index]
            camera = viewer.client.camera
            try:
                camera.update_timestamp  # noqa: B018  (raises until the browser reported its camera)
            except AssertionError:
                continue
            c, s = math.cos(kart.heading), math.sin(kart.heading)
            with contextlib.suppress(ValueError), viewer.client.atomic():
                camera.position = (kart.x - FOLLOW_BEHIND * c, kart.y - FOLLOW_BEHIND * s, FOLLOW_ABOVE)
                camera.look_at = (kart.x + FOLLOW_AHEAD * c, kart.y + FOLLOW_AHEAD * s, 0.0)


def _show_points(pool: list[_PoseWriter], points: Sequence[tuple[float, float]], z: float) -> None:
    """Put the first ``len(points)`` boxes of a pool at ``points`` and hide the rest."""
    for j, writer in enumerate(pool):
        if j < len(points):
            x, y = points[j]
            writer.position((float(x), float(y), z))
            writer.node.visible = True
        else:
            writer.node.visible = False
