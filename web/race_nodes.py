"""The moving part of a race's 3D scene: the karts, their plans and the HUD, built on one scope of a viser server
(:class:`RaceNodes`): the server's, which every viewer sees (a live race), or one viewer's (a replay, where each
viewer watches its own moment).

Node names (the same in either scope):

* ``/karts/kart{i}`` (a box in the kart's colour), ``/karts/kart{i}/nose`` (marks the front),
  ``/karts/kart{i}/team`` (a roof plate in its team's colour, :data:`web.frame.TEAM_COLORS`; hidden for a kart
  racing for itself), ``/karts/kart{i}/label`` (its display name);
* ``/plans/kart{i}/wp{j}`` (green boxes: the kart's planned waypoints) and ``/plans/kart{i}/pred{j}``
  (translucent orange boxes: its planner's predictions of the other karts' waypoints), hidden when unused.

:meth:`RaceNodes.show` only moves, shows and hides these nodes (viser coalesces to the latest value per node, so
slow viewers skip frames instead of queueing them).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import viser

from sim_core.track import Track
from web.frame import KART_COLORS, KartFrame, RaceFrame, kart_label, team_colors
from web.hud import hud_text
from web.meshes import PREDICTION_COLOR, WAYPOINT_COLOR, heading_wxyz

log = logging.getLogger(__name__)

KART_SIZE = (2.0, 0.9, 0.5)  # [m] length, width, height of the kart boxes
KART_CLEARANCE = 0.05  # [m] gap under the kart box
WAYPOINT_POOL = 10  # green waypoint boxes per kart
PREDICTION_POOL_PER_OPPONENT = 8  # orange prediction boxes per opponent (the planner's horizon)
PREDICTION_POOL_MAX = 24
WAYPOINT_SIZE = 1.0  # [m] edge of a green waypoint box
PREDICTION_SIZE = 0.7  # [m] edge of an orange prediction box
HUD_PERIOD = 0.25  # [s] wall-clock time between HUD refreshes
HUD_ORDER = 10.0  # the HUD's place in the panel (the legend follows it)

PlanKey = tuple[tuple[tuple[float, float], ...], tuple[tuple[float, float], ...]]


class _PoseWriter:
    """Sets a scene node's position / orientation for the per-tick path.

    viser's public setters compare every new value with the old one through ``np.allclose`` (about 15-30 µs per
    assignment, most of :meth:`RaceNodes.show`); the nodes already skip unchanged poses themselves, so with the
    pinned viser (1.1.x) this writes the handle's state and queues the same message directly (through the
    node's own scope: the server's, or one viewer's). If viser's internals ever differ, it falls back to the
    public setters (``fast`` is then False).
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


class RaceNodes:
    """The karts, plans and HUD of a race with ``karts`` (``(display name, controller name)`` per grid slot) on
    ``track``, added to the scope of ``scene`` and ``gui`` (a :class:`viser.ViserServer`'s or a
    :class:`viser.ClientHandle`'s)."""

    def __init__(
        self, scene: viser.SceneApi, gui: viser.GuiApi, track: Track, karts: Sequence[tuple[str, str]]
    ) -> None:
        self.track = track
        self.karts = [(str(name), str(controller)) for name, controller in karts]
        self._plans_version: int | None = None
        self._plan_cache: dict[int, PlanKey] = {}
        self._pose_cache: dict[int, tuple[float, float, float]] = {}
        self._hud_due = 0.0
        self._hud_status = ""
        self.kart_writers: list[_PoseWriter] = []
        self.team_plates: list[viser.BoxHandle] = []
        self._teams_shown = False
        self._waypoint_writers: list[list[_PoseWriter]] = []
        self._prediction_writers: list[list[_PoseWriter]] = []
        n = len(self.karts)
        pred_pool = min(PREDICTION_POOL_MAX, PREDICTION_POOL_PER_OPPONENT * max(n - 1, 1))
        for i, (name, controller) in enumerate(self.karts):
            self.kart_writers.append(_PoseWriter(self._add_kart(scene, i, name, controller)))
            self._waypoint_writers.append(_pool(scene, i, "wp", WAYPOINT_POOL, WAYPOINT_COLOR, WAYPOINT_SIZE, None))
            self._prediction_writers.append(_pool(scene, i, "pred", pred_pool, PREDICTION_COLOR, PREDICTION_SIZE, 0.55))
        self.hud = gui.add_markdown(hud_text(track.name, self.karts, None), order=HUD_ORDER)

    def _add_kart(self, scene: viser.SceneApi, i: int, name: str, controller: str) -> viser.BoxHandle:
        start = self.track.lane_point(0, 1 + i % self.track.n_lanes)
        kart = scene.add_box(
            f"/karts/kart{i}",
            color=KART_COLORS[i % len(KART_COLORS)],
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
        self.team_plates.append(
            scene.add_box(
                f"/karts/kart{i}/team",
                color=(250, 250, 250),
                dimensions=(KART_SIZE[0] * 0.45, KART_SIZE[1] * 0.9, 0.1),
                position=(-0.2, 0.0, KART_SIZE[2] / 2 + 0.05),
                visible=False,
                cast_shadow=False,
            )
        )
        scene.add_label(
            f"/karts/kart{i}/label",
            kart_label(name, controller),
            position=(0.0, 0.0, 1.0),
            anchor="bottom-center",
            font_screen_scale=1.1,
        )
        return kart

    def show(self, frame: RaceFrame, now: float) -> None:
        """Show ``frame`` at wall time ``now`` [s, monotonic]: kart poses every call, plans when
        ``frame.plans_version`` changed, the HUD every :data:`HUD_PERIOD` or when the status changed. Call it
        inside its scope's ``atomic()``."""
        karts = frame.karts[: len(self.kart_writers)]
        if not self._teams_shown:
            self._show_teams(karts)
        for kart in karts:
            self._move_kart(kart)
        if frame.plans_version != self._plans_version:
            self._plans_version = frame.plans_version
            for kart in karts:
                self._show_plan(kart)
        if now >= self._hud_due or frame.status != self._hud_status:
            self._hud_due = now + HUD_PERIOD
            self._hud_status = frame.status
            self.hud.content = hud_text(self.track.name, self.karts, frame)

    def _show_teams(self, karts: Sequence[KartFrame]) -> None:
        """Colour the roof plate of every kart of a team (once: a race's teams do not change)."""
        self._teams_shown = True
        colors = team_colors([kart.team for kart in karts])
        for kart in karts:
            if kart.team is not None:
                plate = self.team_plates[kart.index]
                plate.color = colors[kart.team]
                plate.visible = True

    def _move_kart(self, kart: KartFrame) -> None:
        pose = (kart.x, kart.y, kart.heading)
        if self._pose_cache.get(kart.index) == pose:
            return
        self._pose_cache[kart.index] = pose
        writer = self.kart_writers[kart.index]
        writer.position((float(kart.x), float(kart.y), KART_CLEARANCE + KART_SIZE[2] / 2))
        writer.wxyz(heading_wxyz(float(kart.heading)))

    def _show_plan(self, kart: KartFrame) -> None:
        key = (kart.waypoints, kart.predicted)
        if self._plan_cache.get(kart.index) == key:
            return
        self._plan_cache[kart.index] = key
        _show_points(self._waypoint_writers[kart.index], kart.waypoints, WAYPOINT_SIZE / 2 + 0.05)
        _show_points(self._prediction_writers[kart.index], kart.predicted, PREDICTION_SIZE / 2 + 0.05)


def _pool(
    scene: viser.SceneApi,
    kart: int,
    kind: str,
    size: int,
    color: tuple[int, int, int],
    edge: float,
    opacity: float | None,
) -> list[_PoseWriter]:
    """``size`` hidden boxes ``/plans/kart{kart}/{kind}{j}`` (waypoints or predictions), to be placed later."""
    return [
        _PoseWriter(
            scene.add_box(
                f"/plans/kart{kart}/{kind}{j}",
                color=color,
                dimensions=(edge,) * 3,
                position=(0.0, 0.0, edge / 2),
                opacity=opacity,
                visible=False,
                cast_shadow=False,
            )
        )
        for j in range(size)
    ]


def _show_points(pool: list[_PoseWriter], points: Sequence[tuple[float, float]], z: float) -> None:
    """Put the first ``len(points)`` boxes of a pool at ``points`` and hide the rest."""
    for j, writer in enumerate(pool):
        if j < len(points):
            x, y = points[j]
            writer.position((float(x), float(y), z))
            writer.node.visible = True
        else:
            writer.node.visible = False
