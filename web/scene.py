"""The live 3D view of one race: a viser server per race session, fed one :class:`~web.frame.RaceFrame` per tick.

The scene is built once in the constructor; :meth:`RaceScene.update` only moves, shows and hides existing nodes
(viser coalesces to the latest value per node, so slow viewers skip frames instead of queueing them). Node names:

* ``/track/ground``, ``/track/surface`` (grey road mesh between the walls), ``/track/walls/left`` and
  ``/track/walls/right`` (thin vertical meshes), ``/track/lanes`` (the lane lines, one line-segments node),
  ``/track/start`` (the start/finish line), ``/track/checkpoints/cp{c}`` (purple boxes across the road);
* ``/karts/kart{i}`` (a box in the kart's colour), ``/karts/kart{i}/nose`` (marks the front),
  ``/karts/kart{i}/label`` (its display name);
* ``/plans/kart{i}/wp{j}`` (green boxes: the kart's planned waypoints) and ``/plans/kart{i}/pred{j}``
  (translucent orange boxes: its planner's predictions of the other karts' waypoints), hidden when unused.

The GUI has a HUD (markdown, shared by every viewer) and a per-viewer "Follow" dropdown whose camera chases the
chosen kart. The viser server listens on 127.0.0.1 only; browsers reach it through :mod:`web.viewer`'s relay.
"""

from __future__ import annotations

import contextlib
import html
import io
import logging
import math
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import viser

from sim_core.track import Track
from web.frame import KART_COLORS, KartFrame, RaceFrame

log = logging.getLogger(__name__)

KART_SIZE = (2.0, 0.9, 0.5)  # [m] length, width, height of the kart boxes
KART_CLEARANCE = 0.05  # [m] gap under the kart box
WAYPOINT_POOL = 10  # green waypoint boxes per kart
PREDICTION_POOL_PER_OPPONENT = 8  # orange prediction boxes per opponent (the planner's horizon)
PREDICTION_POOL_MAX = 24
WAYPOINT_SIZE = 1.0  # [m] edge of a green waypoint box
PREDICTION_SIZE = 0.7  # [m] edge of an orange prediction box
WALL_HEIGHT = 0.6  # [m]
HUD_PERIOD = 0.25  # [s] wall-clock time between HUD refreshes
CAMERA_PERIOD = 0.05  # [s] wall-clock time between follow-camera moves (20 Hz)
FOLLOW_BEHIND = 11.0  # [m] follow camera distance behind the kart
FOLLOW_ABOVE = 5.0  # [m] follow camera height
FOLLOW_AHEAD = 6.0  # [m] the follow camera looks this far ahead of the kart
FREE_CAMERA = "Free camera"

ROAD_COLOR = (105, 105, 112)
GROUND_COLOR = (196, 190, 170)
WALL_COLOR = (236, 236, 236)
LANE_COLOR = (250, 250, 250)
START_COLOR = (20, 20, 20)
CHECKPOINT_COLOR = (150, 40, 220)  # purple
WAYPOINT_COLOR = (20, 200, 60)  # green
PREDICTION_COLOR = (255, 140, 20)  # orange

_MARKDOWN_ESCAPES = str.maketrans({c: "\\" + c for c in "\\`*_[]|#!~"})


def markdown_text(text: str) -> str:
    """``text`` as literal markdown text: HTML and markdown syntax escaped (viser renders raw HTML unsanitised,
    and display names come from users)."""
    return html.escape(text.translate(_MARKDOWN_ESCAPES), quote=False)


def _swatch(index: int) -> str:
    r, g, b = KART_COLORS[index % len(KART_COLORS)]
    return f'<span style="color: rgb({r}, {g}, {b})">■</span>'


def heading_wxyz(heading: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation by ``heading`` [rad] about +z."""
    half = 0.5 * heading
    return (math.cos(half), 0.0, 0.0, math.sin(half))


def _strip_mesh(a: np.ndarray, b: np.ndarray, za: float, zb: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a closed strip between the closed polylines ``a`` and ``b`` (both (M, 2))."""
    m = len(a)
    vertices = np.empty((2 * m, 3), dtype=np.float32)
    vertices[0::2, :2] = a
    vertices[0::2, 2] = za
    vertices[1::2, :2] = b
    vertices[1::2, 2] = zb
    i = np.arange(m)
    j = (i + 1) % m
    a0, b0, a1, b1 = 2 * i, 2 * i + 1, 2 * j, 2 * j + 1
    faces = np.concatenate([np.stack([a0, b0, a1], axis=1), np.stack([a1, b0, b1], axis=1)]).astype(np.uint32)
    return vertices, faces


def lane_polylines(track: Track) -> np.ndarray:
    """(n_lanes, M, 2) world positions of every lane along the whole centre line (lane 1 first)."""
    frac = np.asarray(track.lane_fractions, dtype=float)[:, None]
    offsets = np.where(frac > 0, frac * track.lane_half_left[None, :], frac * track.lane_half_right[None, :])
    return track.centre_xy[None, :, :] + track.centre_normal[None, :, :] * offsets[:, :, None]


def _polyline_segments(points: np.ndarray, z: float, step: int = 1) -> np.ndarray:
    """(S, 2, 3) segments of a closed polyline, taking every ``step``-th point."""
    p = points[::step]
    seg = np.empty((len(p), 2, 3), dtype=np.float32)
    seg[:, 0, :2] = p
    seg[:, 1, :2] = np.roll(p, -1, axis=0)
    seg[:, :, 2] = z
    return seg


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
        with contextlib.redirect_stdout(io.StringIO()):
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

        lo = np.minimum(track.left_wall.min(axis=0), track.right_wall.min(axis=0))
        hi = np.maximum(track.left_wall.max(axis=0), track.right_wall.max(axis=0))
        centre = 0.5 * (lo + hi)
        extent = float(max(hi[0] - lo[0], hi[1] - lo[1], 20.0))
        server.initial_camera.look_at = (float(centre[0]), float(centre[1]), 0.0)
        server.initial_camera.position = (float(centre[0]), float(centre[1] - 0.6 * extent), 0.6 * extent)

        size = extent * 1.4
        scene.add_grid(
            "/track/ground",
            width=size,
            height=size,
            plane="xy",
            cell_size=5.0,
            section_size=25.0,
            position=(float(centre[0]), float(centre[1]), -0.05),
            plane_color=GROUND_COLOR,
            plane_opacity=1.0,
            cell_color=(180, 174, 154),
            section_color=(160, 154, 134),
            fade_distance=3.0 * extent,
            shadow_opacity=0.0,
        )
        vertices, faces = _strip_mesh(track.left_wall, track.right_wall, 0.0, 0.0)
        scene.add_mesh_simple(
            "/track/surface",
            vertices,
            faces,
            color=ROAD_COLOR,
            side="double",
            flat_shading=True,
            cast_shadow=False,
            receive_shadow=0.3,
        )
        for side, wall in (("left", track.left_wall), ("right", track.right_wall)):
            vertices, faces = _strip_mesh(wall, wall, 0.0, WALL_HEIGHT)
            scene.add_mesh_simple(
                f"/track/walls/{side}", vertices, faces, color=WALL_COLOR, side="double", cast_shadow=False
            )

        lanes = lane_polylines(track)
        segments = np.concatenate([_polyline_segments(lane, 0.02, step=2) for lane in lanes])
        scene.add_line_segments("/track/lanes", segments, LANE_COLOR, thickness=0.12)

        width = float(track.lane_half_left[0] + track.lane_half_right[0])
        for c in range(track.n_checkpoints):
            point, normal = track.checkpoint_frame(c)
            left = float(track.width_left[track.checkpoint_sample[c]])
            right = float(track.width_right[track.checkpoint_sample[c]])
            mid = point + normal * 0.5 * (left - right)
            heading = math.atan2(-float(normal[0]), float(normal[1]))  # the tangent is the normal turned right
            scene.add_box(
                f"/track/checkpoints/cp{c}",
                color=CHECKPOINT_COLOR,
                dimensions=(0.6, left + right, 0.2),
                position=(float(mid[0]), float(mid[1]), 0.1),
                wxyz=heading_wxyz(heading),
                opacity=0.85,
                cast_shadow=False,
            )
        point, normal = track.checkpoint_frame(0)
        across = np.stack([point + normal * width * 0.55, point - normal * width * 0.55])
        scene.add_line_segments(
            "/track/start", np.array([[[*across[0], 0.14], [*across[1], 0.14]]]), START_COLOR, thickness=0.25
        )

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
                f"{name} ({controller})" if controller and controller != name else name,
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
        self._hud = server.gui.add_markdown(self._hud_text(None), order=10.0)
        legend = " · ".join(
            f'<span style="color: rgb{color}">■</span> {what}'
            for color, what in (
                (CHECKPOINT_COLOR, "checkpoints"),
                (WAYPOINT_COLOR, "planned waypoints"),
                (PREDICTION_COLOR, "predicted opponents"),
            )
        )
        self._legend = server.gui.add_markdown(
            f"{legend}<br/>fault: collisions at fault · illegal LC: illegal lane changes · "
            "drv. faults: driver errors and missed deadlines",
            order=11.0,
        )

    # ------------------------------------------------------------------ per-viewer GUI
    def _follow_options(self) -> list[str]:
        return [FREE_CAMERA, *(f"{i + 1}: {name}" for i, (name, _) in enumerate(self.karts))]

    def _on_connect(self, client: viser.ClientHandle) -> None:
        follow = client.gui.add_dropdown("Follow", self._follow_options(), initial_value=FREE_CAMERA, order=0.0)
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
                self._hud.content = self._hud_text(frame)
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

    def _hud_text(self, frame: RaceFrame | None) -> str:
        if frame is None:
            rows = [
                f"| {_swatch(i)} {markdown_text(name)} | – | – | – | – | – | – |"
                for i, (name, _) in enumerate(self.karts)
            ]
            head = f"**{markdown_text(self.track.name)}** · waiting for the start"
        else:
            rows = []
            for k in sorted(frame.karts, key=lambda k: k.position):
                if k.finished:
                    lap = "✓ " + (f"{k.finish_time:.2f} s" if k.finish_time is not None else "")
                else:
                    lap = str(k.lap)
                rows.append(
                    f"| {_swatch(k.index)} {markdown_text(k.name)} | {k.position} | {lap} | "
                    f"{k.speed * 3.6:.0f} | {k.collisions_at_fault} | {k.illegal_lane_changes} | "
                    f"{k.controller_faults} |"
                )
            head = (
                f"**{markdown_text(frame.track)}** · {markdown_text(frame.status)} · {frame.time:.1f} s · "
                f"{frame.laps} laps"
            )
        table = "| kart | pos | lap | km/h | fault | illegal LC | drv. faults |\n|---|---|---|---|---|---|---|\n"
        return head + "\n\n" + table + "\n".join(rows)


def _show_points(pool: list[_PoseWriter], points: Sequence[tuple[float, float]], z: float) -> None:
    """Put the first ``len(points)`` boxes of a pool at ``points`` and hide the rest."""
    for j, writer in enumerate(pool):
        if j < len(points):
            x, y = points[j]
            writer.position((float(x), float(y), z))
            writer.node.visible = True
        else:
            writer.node.visible = False
