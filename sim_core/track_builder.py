"""Building tracks: :func:`build_track` makes a :class:`~sim_core.track.Track` from checkpoints and sections
(the centre line, its samples and the walls), and :func:`chain_track` designs one from modular pieces
(straights and constant-radius curves), like the kit the paper's tracks were built from.

:mod:`sim_core.track` holds the track type and its queries; the files under ``sim_core/tracks`` are read in
:mod:`sim_core.track_io`, which builds them here."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_core.track import CENTRE_SAMPLE_SPACING, DEFAULT_LANE_FRACTIONS, Checkpoint, Section, Track


# --------------------------------------------------------------------------- from sections
def _arc_hermite_segment(p0: np.ndarray, h0: float, p1: np.ndarray, h1: float, n: int) -> np.ndarray:
    """Points on a cubic Hermite curve from pose (p0, h0) to (p1, h1), tangents sized to approximate an arc."""
    chord = float(np.linalg.norm(p1 - p0))
    turn = abs(float(np.angle(np.exp(1j * (h1 - h0)))))
    if turn < 1e-6:
        handle = chord / 3.0
    else:
        radius = chord / (2.0 * np.sin(turn / 2.0))
        handle = 4.0 / 3.0 * np.tan(turn / 4.0) * radius
    t0 = np.array([np.cos(h0), np.sin(h0)]) * 3.0 * handle
    t1 = np.array([np.cos(h1), np.sin(h1)]) * 3.0 * handle
    u = np.linspace(0.0, 1.0, n, endpoint=False)[:, None]
    h00 = 2 * u**3 - 3 * u**2 + 1
    h10 = u**3 - 2 * u**2 + u
    h01 = -2 * u**3 + 3 * u**2
    h11 = u**3 - u**2
    return h00 * p0 + h10 * t0 + h01 * p1 + h11 * t1


INNER_WALL_CURVATURE_MARGIN = 0.85  # [-] the inner wall stays within this fraction of the local radius


def _clip_inner_widths(xy: np.ndarray, wl: np.ndarray, wr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Narrow the inside of bends tighter than the half width so that walls never fold over themselves.

    A wall offset by ``w`` from a centre line whose radius of curvature is below ``w`` would loop back
    (and the lateral coordinate would become ambiguous); there the inner wall is pulled in to
    ``0.85 * radius``, spread over +-2 m so the wall stays smooth.
    """
    forward = np.roll(xy, -1, axis=0) - np.roll(xy, 1, axis=0)
    heading = np.arctan2(forward[:, 1], forward[:, 0])
    dh = np.angle(np.exp(1j * (np.roll(heading, -1) - np.roll(heading, 1))))
    ds = np.linalg.norm(forward, axis=1)
    curvature = dh / ds
    spacing = float(np.mean(np.linalg.norm(np.diff(xy, axis=0), axis=1)))
    half_window = max(round(2.0 / spacing), 1)
    out = []
    for width, side in ((wl, 1.0), (wr, -1.0)):
        inner = side * curvature > 0
        limit = np.where(inner, INNER_WALL_CURVATURE_MARGIN / np.maximum(np.abs(curvature), 1e-9), np.inf)
        spread = limit.copy()
        for shift in range(1, half_window + 1):
            spread = np.minimum(spread, np.minimum(np.roll(limit, shift), np.roll(limit, -shift)))
        out.append(np.minimum(width, spread))
    return out[0], out[1]


def resample_closed(points: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Resample a closed polyline at (nearly) uniform ``spacing`` [m]; returns (points, arc lengths, length)."""
    closed = np.vstack([points, points[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    length = float(cum[-1])
    m = max(round(length / spacing), 8)
    s = np.linspace(0.0, length, m, endpoint=False)
    x = np.interp(s, cum, closed[:, 0])
    y = np.interp(s, cum, closed[:, 1])
    return np.stack([x, y], axis=1), s, length


def build_track(
    name: str,
    checkpoints: list[Checkpoint],
    sections: list[Section],
    *,
    half_width: float = 5.0,
    laps: int = 3,
    lane_change_limit: int = 4,
    lane_fractions: tuple[float, ...] = DEFAULT_LANE_FRACTIONS,
    centreline: np.ndarray | None = None,
    description: str = "",
    meta: dict[str, object] | None = None,
) -> Track:
    """Make a :class:`Track` from checkpoints and sections.

    Without ``centreline`` the centre line is a chain of arc-like cubic Hermite curves through the
    checkpoint centres along their headings, and the road is ``2 * half_width`` wide everywhere.
    With ``centreline`` (rows ``x, y, w_left, w_right``, closed, dense) the checkpoints are placed at their
    projections onto it.
    """
    if len(checkpoints) != len(sections):
        raise ValueError("need exactly one section per checkpoint")
    if len(checkpoints) < 3:
        raise ValueError("a track needs at least 3 checkpoints")
    if centreline is None:
        pieces = []
        marks = []
        n = len(checkpoints)
        for i in range(n):
            a, b = checkpoints[i], checkpoints[(i + 1) % n]
            seg = _arc_hermite_segment(np.array(a.centre), a.heading, np.array(b.centre), b.heading, 400)
            pieces.append(seg)
        dense = np.vstack(pieces)
        xy, s, length = resample_closed(dense, CENTRE_SAMPLE_SPACING)
        # arc length of each checkpoint = where its dense start point lies along the dense polyline
        closed = np.vstack([dense, dense[:1]])
        cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
        marks = [cum[400 * i] * length / cum[-1] for i in range(n)]
        wl = np.full(len(xy), half_width)
        wr = np.full(len(xy), half_width)
        checkpoint_s = np.array(marks)
    else:
        cl = np.asarray(centreline, dtype=float)
        dense_xy = cl[:, :2]
        xy, s, length = resample_closed(dense_xy, CENTRE_SAMPLE_SPACING)
        closed = np.vstack([dense_xy, dense_xy[:1]])
        cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
        wl = np.interp(s, cum, np.append(cl[:, 2], cl[0, 2]))
        wr = np.interp(s, cum, np.append(cl[:, 3], cl[0, 3]))
        provisional = Track(
            name, tuple(checkpoints), tuple(sections), xy, s, length, wl, wr, np.zeros(len(checkpoints)), wl, wr
        )
        checkpoint_s = np.array([provisional.project(np.array(cp.centre))[0] for cp in checkpoints])
    wall_left, wall_right = _clip_inner_widths(xy, wl, wr)
    return Track(
        name=name,
        checkpoints=tuple(checkpoints),
        sections=tuple(sections),
        centre_xy=xy,
        centre_s=s,
        length=length,
        width_left=wall_left,
        width_right=wall_right,
        checkpoint_s=checkpoint_s,
        lane_half_left=wl,
        lane_half_right=wr,
        laps=laps,
        lane_change_limit=lane_change_limit,
        lane_fractions=tuple(lane_fractions),
        description=description,
        meta=dict(meta or {}),
    )


# --------------------------------------------------------------------------- from pieces
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


def narrow_hairpin_pieces(
    first_radius: float = 2.0, second_radius: float = 1.0, kink_radius: float = 3.0, width: float = 6.0
) -> list[Straight | Curve]:
    """A counter-clockwise circuit for a ``width`` [m] wide track with two 180 deg left hairpins of inside radii
    ``first_radius`` and ``second_radius`` [m], each followed by a right-left 90 deg kink of inside radius
    ``kink_radius`` (its reverse turns the other way). Straights are 10-11 m pieces; the last ones close it.

    A hairpin's racing lane takes the inside (lane 1) for its first half and lane 2 on its exit; a kink's right
    turn the last lane then the one beside it, its left turn lanes 1 and 2; straights leave the lane free.
    """
    half = width / 2.0

    def hairpin(radius: float) -> list[Straight | Curve]:
        return [Curve(radius, 45.0, True, lane) for lane in (1, 1, 2, 2)]

    def corner(radius: float, left: bool) -> list[Straight | Curve]:
        return [Curve(radius, 45.0, left, 1 if left else 4), Curve(radius, 45.0, left, 2 if left else 3)]

    def straight(length: float, pieces: int) -> list[Straight | Curve]:
        return [Straight(length / pieces) for _ in range(pieces)]

    up, down, west, south = 40.0, 20.0, 20.0, 40.0
    # sideways: the first hairpin, a kink and the west straight move the line west, the second hairpin and the
    # other kink (each kink moves it the same distance) back east; along the track the kinks' moves cancel
    east = 2 * (first_radius + half) + west - 2 * (second_radius + half)
    north = down + south - up
    return (
        straight(up, 4)
        + hairpin(first_radius)
        + straight(down, 2)
        + corner(kink_radius, False)
        + straight(west, 2)
        + corner(kink_radius, True)
        + straight(south, 4)
        + hairpin(second_radius)
        + corner(kink_radius, False)
        + straight(east, 2)
        + corner(kink_radius, True)
        + straight(north, 2)
    )
