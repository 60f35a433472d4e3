"""Design tracks from modular pieces (straights and constant-radius curves), like the kit the paper's
tracks were built from."""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim_core.track import Checkpoint, Section, Track, build_track


@dataclass(frozen=True)
class Straight:
    """A straight piece of ``length`` [m], one checkpoint at its start."""

    length: float = 10.0  # [m]
    racing_lane: int | None = None


@dataclass(frozen=True)
class Curve:
    """A curve of inner-edge radius ``inside_radius`` [m] turning ``angle_deg`` [deg], one checkpoint at its start."""

    inside_radius: float
    angle_deg: float = 45.0
    left: bool = True
    racing_lane: int | None = None


def chain_track(
    name: str,
    pieces: list[Straight | Curve],
    *,
    width: float = 10.0,
    laps: int = 3,
    lane_change_limit: int = 4,
    description: str = "",
    close_tolerance: float = 0.05,
) -> Track:
    """Lay ``pieces`` end to end from the origin heading +y; the chain must close on itself.

    Raises ``ValueError`` naming the gap when the last piece does not end where the first began.
    """
    x, y, heading = 0.0, 0.0, math.pi / 2
    checkpoints: list[Checkpoint] = []
    sections: list[Section] = []
    half = width / 2.0
    for piece in pieces:
        checkpoints.append(Checkpoint((x, y), heading % (2 * math.pi), piece.racing_lane))
        if isinstance(piece, Straight):
            x += piece.length * math.cos(heading)
            y += piece.length * math.sin(heading)
            sections.append(Section(is_straight=True, length=piece.length))
        else:
            radius = piece.inside_radius + half
            sign = 1.0 if piece.left else -1.0
            turn = math.radians(piece.angle_deg) * sign
            cx = x - sign * radius * math.sin(heading)
            cy = y + sign * radius * math.cos(heading)
            heading += turn
            x = cx + sign * radius * math.sin(heading)
            y = cy - sign * radius * math.cos(heading)
            sections.append(
                Section(
                    is_straight=False,
                    length=abs(turn) * radius,
                    inside_radius=piece.inside_radius,
                    angle_deg=piece.angle_deg,
                    left_turn=piece.left,
                )
            )
    gap = math.hypot(x, y)
    heading_gap = abs(math.remainder(heading - math.pi / 2, 2 * math.pi))
    if gap > close_tolerance or heading_gap > 1e-6:
        raise ValueError(
            f"pieces do not close: end is {gap:.3f} m and {math.degrees(heading_gap):.2f} deg from the start"
        )
    return build_track(
        name,
        checkpoints,
        sections,
        half_width=half,
        laps=laps,
        lane_change_limit=lane_change_limit,
        description=description,
    )


def oval_pieces(
    long_straight: int, short_straight: int, inside_radius: float, racing_lanes: bool = True
) -> list[Straight | Curve]:
    """A counter-clockwise oval: long straight, 180 deg, short... as 10 m straights and 45 deg curve pieces.

    ``long_straight`` and ``short_straight`` count 10 m pieces; each corner is 90 deg in two 45 deg pieces.
    The hand-set racing lane follows the original's pattern: outside before a corner, apex inside, out on exit.
    """

    def straight_run(n: int) -> list[Straight | Curve]:
        run: list[Straight | Curve] = [Straight(10.0, 3 if racing_lanes else None) for _ in range(n)]
        if racing_lanes and n:
            run[-1] = Straight(10.0, 2)
        return run

    def corner() -> list[Straight | Curve]:
        return [
            Curve(inside_radius, 45.0, True, 1 if racing_lanes else None),
            Curve(inside_radius, 45.0, True, 2 if racing_lanes else None),
        ]

    return (
        straight_run(long_straight)
        + corner()
        + straight_run(short_straight)
        + corner()
        + straight_run(long_straight)
        + corner()
        + straight_run(short_straight)
        + corner()
    )


def hairpin_pieces(
    outer_radius: float = 5.0, notch_radius: float = 1.0, inner_radius: float = 7.0
) -> list[Straight | Curve]:
    """A counter-clockwise circuit with a notch in one side: six left and two right 90 deg corners of inside
    radii ``outer_radius``, ``inner_radius`` and ``notch_radius`` [m] (tight corners both ways, as ``complex``
    has and the ovals have not). Straights are laid in 10-12 m pieces; the last two straights' lengths close it.

    The racing lane takes the inside at each corner's first half (lane 1 turning left, the last lane turning
    right) and lane 2 or 3 on its exit; straights leave the lane free. Laid for a 10 m wide track.
    """

    def corner(radius: float, left: bool) -> list[Straight | Curve]:
        return [Curve(radius, 45.0, left, 1 if left else 4), Curve(radius, 45.0, left, 2 if left else 3)]

    def straight(length: float, pieces: int) -> list[Straight | Curve]:
        return [Straight(length / pieces) for _ in range(pieces)]

    side, top, notch_depth, notch_width = 30.0, 20.0, 20.0, 20.0
    half = 5.0  # centre-line radius - inside radius, for the 10 m width of the built-in tracks
    # the bottom spans the top side: two top straights, the notch, and the sideways reach of the notch's four
    # corners (the outer corners' reach cancels between top and bottom)
    bottom = 2 * top + notch_width + 2 * (inner_radius + half) + 2 * (notch_radius + half)
    return (
        straight(side, 3)
        + corner(outer_radius, True)
        + straight(top, 2)
        + corner(inner_radius, True)
        + straight(notch_depth, 2)
        + corner(notch_radius, False)
        + straight(notch_width, 2)
        + corner(notch_radius, False)
        + straight(notch_depth, 2)
        + corner(inner_radius, True)
        + straight(top, 2)
        + corner(outer_radius, True)
        + straight(side, 3)
        + corner(outer_radius, True)
        + straight(bottom, 8)
        + corner(outer_radius, True)
    )
