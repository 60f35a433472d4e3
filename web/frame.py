"""The live race state handed from a race session to its viewers: one immutable frame per tick.

The server builds a :class:`RaceFrame` from the session's ``World`` and controllers every tick; the 3D scene
(:mod:`web.scene`) and the telemetry websocket both consume it. Only plain numbers and strings, so a frame can
be serialised with :func:`dataclasses.asdict` and compared in tests.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

# One colour per grid slot (RGB 0-255), shared by the 3D view and the pages.
KART_COLORS: tuple[tuple[int, int, int], ...] = (
    (230, 57, 70),  # red
    (29, 114, 243),  # blue
    (255, 183, 3),  # amber
    (42, 157, 143),  # teal
    (155, 93, 229),  # violet
    (244, 132, 95),  # coral
    (96, 108, 56),  # olive
    (33, 33, 33),  # black
)
# One colour per team, in the order the teams first stand on the grid (slot order): a kart of a team carries it on
# its roof in the 3D view and beside its name in the HUD and on the pages (the slot colours tell karts apart).
TEAM_COLORS: tuple[tuple[int, int, int], ...] = (
    (255, 204, 0),  # yellow
    (0, 180, 216),  # cyan
    (214, 40, 160),  # magenta
    (110, 190, 40),  # green
)


def team_colors(teams: Sequence[str | None]) -> dict[str, tuple[int, int, int]]:
    """Each team of ``teams`` (one per kart, by grid slot; ``None``: a kart racing for itself) and its colour:
    :data:`TEAM_COLORS` in the order the teams first appear (again from the first beyond four teams)."""
    order = list(dict.fromkeys(team for team in teams if team is not None))
    return {team: TEAM_COLORS[i % len(TEAM_COLORS)] for i, team in enumerate(order)}


def kart_label(name: str, controller: str) -> str:
    """A kart's label: its name, with its controller in brackets unless the name already says it
    (``"Alice (human)"``, but ``"mcts-lqng 1"`` rather than ``"mcts-lqng 1 (mcts-lqng)"``)."""
    return name if not controller or controller in name else f"{name} ({controller})"


@dataclass(frozen=True)
class KartFrame:
    """One kart at one tick, with its standing, safety counts and the waypoints its planner last delivered."""

    index: int
    name: str  # display name
    controller: str  # registered controller name, or "human"
    x: float  # [m]
    y: float  # [m]
    heading: float  # [rad]
    speed: float  # [m/s]
    steer: float  # last applied input in [-1, 1]
    throttle: float  # last applied input in [-1, 1]
    lap: int  # current lap, 1-based (laps completed + 1, capped at the race's laps)
    position: int  # 1-based running order
    checkpoints_passed: int
    lane: int  # lane at the last checkpoint crossing (1-based)
    collisions_at_fault: int
    illegal_lane_changes: int
    wall_hits: int
    finished: bool
    finish_time: float | None  # [s]
    controller_faults: int  # exceptions, hangs and missed deadlines of its driver
    waypoints: tuple[tuple[float, float], ...] = ()  # the ego plan's waypoints (drawn green; () once finished)
    predicted: tuple[tuple[float, float], ...] = ()  # its planner's predictions of the other karts' waypoints
    team: str | None = None  # its team (None: it races for itself)


@dataclass(frozen=True)
class RaceFrame:
    """A whole race at one tick."""

    race_id: str
    track: str
    time: float  # [s] race time
    step: int
    laps: int
    status: str  # the race status (server.status.RaceStatus values: "starting", "running", "finished", ...)
    karts: tuple[KartFrame, ...]
    plans_version: int  # changes whenever any kart's waypoints change (viewers redraw plans only then)
    countdown: float | None = None  # [s] wall time left before the start (status "countdown"), else None
