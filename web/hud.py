"""The scene's heads-up display: the standings table (markdown, shared by every viewer) and the colour legend.

Display names come from users and viser renders raw HTML unsanitised, so every name is escaped
(:func:`markdown_text`).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence

from web.frame import KART_COLORS, KartFrame, RaceFrame, team_colors
from web.meshes import CHECKPOINT_COLOR, PREDICTION_COLOR, WAYPOINT_COLOR

_MARKDOWN_ESCAPES = str.maketrans({c: "\\" + c for c in "\\`*_[]|#!~"})
_TABLE_HEAD = "| kart | pos | lap | km/h | at fault | illegal LC | controller faults |\n|---|---|---|---|---|---|---|\n"


def markdown_text(text: str) -> str:
    """``text`` as literal markdown text: HTML and markdown syntax escaped (viser renders raw HTML unsanitised,
    and display names come from users)."""
    return html.escape(text.translate(_MARKDOWN_ESCAPES), quote=False)


def laps_text(laps: int) -> str:
    """``"1 lap"``, ``"3 laps"``."""
    return f"{laps} lap" if laps == 1 else f"{laps} laps"


def _swatch(index: int) -> str:
    r, g, b = KART_COLORS[index % len(KART_COLORS)]
    return f'<span style="color: rgb({r}, {g}, {b})">■</span>'


def _team_badge(team: str, color: tuple[int, int, int]) -> str:
    """The team's name in its colour's box (the roof plate's colour in the 3D view)."""
    r, g, b = color
    return f'<span style="border: 2px solid rgb({r}, {g}, {b}); padding: 0 2px">{markdown_text(team)}</span>'


def _nowrap(text: str) -> str:
    """``text`` kept on one line in the table (names and times wrapped mid-way in a narrow panel)."""
    return f'<span style="white-space: nowrap">{text}</span>'


def _lap(kart: KartFrame) -> str:
    if not kart.finished:
        return str(kart.lap)
    return _nowrap("✓ " + (f"{kart.finish_time:.2f} s" if kart.finish_time is not None else ""))


def _speed(kart: KartFrame) -> str:
    return "–" if kart.finished else f"{kart.speed * 3.6:.0f}"  # a finished kart's speed is of no interest


def hud_text(track_name: str, karts: Sequence[tuple[str, str]], frame: RaceFrame | None) -> str:
    """The standings table of ``frame`` (before the first frame: the grid of ``karts``, ``(name, controller)``)."""
    if frame is None:
        rows = [
            f"| {_nowrap(_swatch(i) + ' ' + markdown_text(name))} | – | – | – | – | – | – |"
            for i, (name, _) in enumerate(karts)
        ]
        head = f"**{markdown_text(track_name)}** · waiting for the start"
    else:
        rows = []
        teams = team_colors([k.team for k in frame.karts])
        for k in sorted(frame.karts, key=lambda k: k.position):
            team = "" if k.team is None else " " + _team_badge(k.team, teams[k.team])
            rows.append(
                f"| {_nowrap(_swatch(k.index) + ' ' + markdown_text(k.name) + team)} | {k.position} | {_lap(k)} | "
                f"{_speed(k)} | {k.collisions_at_fault} | {k.illegal_lane_changes} | "
                f"{k.controller_faults} |"
            )
        status = f"starts in {math.ceil(frame.countdown)}" if frame.countdown is not None else frame.status
        head = (
            f"**{markdown_text(frame.track)}** · {markdown_text(status)} · {frame.time:.1f} s · {laps_text(frame.laps)}"
        )
    return head + "\n\n" + _TABLE_HEAD + "\n".join(rows)


def legend_text() -> str:
    """What the colours and the table's columns mean."""
    legend = " · ".join(
        f'<span style="color: rgb{color}">■</span> {what}'
        for color, what in (
            (CHECKPOINT_COLOR, "checkpoints"),
            (WAYPOINT_COLOR, "planned waypoints"),
            (PREDICTION_COLOR, "predicted opponents"),
        )
    )
    return (
        f"{legend} · a kart's roof plate: its team's colour<br/>at fault: collisions at fault · "
        "illegal LC: illegal lane changes · controller faults: errors, hangs, missed deadlines, failed plans"
    )
