"""Race tracks: a closed sequence of checkpoints with lanes, the road between them, and walls.

Conventions
-----------
* World frame: x right, y up (seen from above), metres; headings counter-clockwise from +x, radians.
* The centre line is a closed polyline sampled every ~0.25 m with arc length ``s`` (progress).
* Lateral offset ``d`` is positive to the LEFT of the driving direction.
* Lanes are numbered 1..n from left to right, as in the paper's original implementation; lane ``k`` sits
  at ``lane_fractions[k-1]`` times the local half width (left half width for positive fractions).
* ``sections[i]`` describes the road from checkpoint ``i`` to checkpoint ``i + 1`` (wrapping).
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

CENTRE_SAMPLE_SPACING = 0.25  # [m] spacing of the centre-line samples
DEFAULT_LANE_FRACTIONS = (0.7, 0.25, -0.25, -0.7)  # lanes at +3.5, +1.25, -1.25, -3.5 m on a 10 m road


@dataclass(frozen=True)
class Section:
    """The road from one checkpoint to the next: a straight of ``length`` or a curve.

    For curves, ``inside_radius`` is the radius of the inner track edge, ``angle_deg`` the turn angle
    and ``left_turn`` its direction; the discrete planner uses these nominal figures (as the paper's
    original implementation did), while the physics runs on the sampled centre line.
    """

    is_straight: bool
    length: float = 0.0  # [m] straight length (also filled for curves: centre-line length)
    inside_radius: float = 0.0  # [m] 0 for straights
    angle_deg: float = 0.0  # [deg] turn angle, 0 for straights
    left_turn: bool = False

    def lane_radius(self, lane: int, n_lanes: int, width: float) -> float:
        """Nominal radius [m] of ``lane`` (1-based) through this curve; 0 on straights.

        Lanes are spread evenly from the inside edge: [R, R + W/n, ...] counted from the inner lane,
        which is lane 1 on a left turn and lane n on a right turn (the original's model).
        """
        if self.is_straight:
            return 0.0
        index_from_inside = (lane - 1) if self.left_turn else (n_lanes - lane)
        return self.inside_radius + index_from_inside * width / n_lanes

    def reversed(self) -> Section:
        """The same road driven the other way."""
        return replace(self, left_turn=not self.left_turn) if not self.is_straight else self


@dataclass(frozen=True)
class Checkpoint:
    """A line across the track at ``centre`` facing ``heading`` [rad], with an optional hand-set racing lane."""

    centre: tuple[float, float]  # [m]
    heading: float  # [rad]
    racing_lane: int | None = None  # hand-set lane to aim for at the NEXT checkpoint (original's optimalLane)


@dataclass(frozen=True, eq=False)
class Track:
    """A closed race track. Load with :func:`sim_core.track_io.load_track`, build with
    :func:`sim_core.track_builder.build_track`."""

    name: str
    checkpoints: tuple[Checkpoint, ...]
    sections: tuple[Section, ...]
    centre_xy: np.ndarray  # (M, 2) [m] closed polyline, sample M-1 connects back to sample 0
    centre_s: np.ndarray  # (M,) [m] arc length of each sample, centre_s[0] == 0
    length: float  # [m] lap length along the centre line
    width_left: np.ndarray  # (M,) [m] distance from centre to the left wall
    width_right: np.ndarray  # (M,) [m] distance from centre to the right wall
    checkpoint_s: np.ndarray  # (N,) [m] arc length of each checkpoint line
    lane_half_left: np.ndarray  # (M,) [m] nominal left half width that lanes are placed in (walls may be narrower)
    lane_half_right: np.ndarray  # (M,) [m] nominal right half width that lanes are placed in
    laps: int = 3
    lane_change_limit: int = 4  # L: lanes a kart may cross on one straight
    lane_fractions: tuple[float, ...] = DEFAULT_LANE_FRACTIONS
    description: str = ""
    meta: dict[str, object] = field(default_factory=dict)

    # ----------------------------------------------------------------- basic sizes
    @property
    def n_checkpoints(self) -> int:
        """Number of checkpoints per lap."""
        return len(self.checkpoints)

    @property
    def n_lanes(self) -> int:
        """Number of lanes."""
        return len(self.lane_fractions)

    @cached_property
    def centre_tangent(self) -> np.ndarray:
        """(M, 2) unit tangent of the centre line at each sample (central differences)."""
        forward = np.roll(self.centre_xy, -1, axis=0) - np.roll(self.centre_xy, 1, axis=0)
        return forward / np.linalg.norm(forward, axis=1, keepdims=True)

    @cached_property
    def centre_normal(self) -> np.ndarray:
        """(M, 2) unit normal pointing to the left of the driving direction."""
        t = self.centre_tangent
        return np.stack([-t[:, 1], t[:, 0]], axis=1)

    @cached_property
    def centre_heading(self) -> np.ndarray:
        """(M,) heading [rad] of the centre line."""
        t = self.centre_tangent
        return np.arctan2(t[:, 1], t[:, 0])

    @cached_property
    def centre_curvature(self) -> np.ndarray:
        """(M,) signed curvature [1/m] (positive = turning left) from the heading change per sample."""
        h = self.centre_heading
        dh = np.angle(np.exp(1j * (np.roll(h, -1) - np.roll(h, 1))))
        ds = np.roll(self.centre_s, -1) - np.roll(self.centre_s, 1)
        ds[0] += self.length
        ds[-1] += self.length
        return dh / ds

    @cached_property
    def left_wall(self) -> np.ndarray:
        """(M, 2) left wall polyline (closed)."""
        return self.centre_xy + self.centre_normal * self.width_left[:, None]

    @cached_property
    def right_wall(self) -> np.ndarray:
        """(M, 2) right wall polyline (closed)."""
        return self.centre_xy - self.centre_normal * self.width_right[:, None]

    @cached_property
    def checkpoint_sample(self) -> np.ndarray:
        """(N,) index of the centre sample at (or just before) each checkpoint."""
        return np.clip(np.searchsorted(self.centre_s, self.checkpoint_s, side="right") - 1, 0, len(self.centre_s) - 1)

    # ----------------------------------------------------------------- lanes
    def lane_offsets(self, checkpoint: int) -> np.ndarray:
        """(n_lanes,) lateral offsets [m] (left-positive) of the lanes at ``checkpoint`` (read-only)."""
        return self._checkpoint_lane_offsets[checkpoint % len(self.checkpoints)]

    @cached_property
    def _checkpoint_lane_offsets(self) -> np.ndarray:
        # looked up at every step by every LQ tracker: computed once per checkpoint
        table = np.stack([self._lane_offsets_at_sample(int(i)) for i in self.checkpoint_sample])
        table.flags.writeable = False
        return table

    def _lane_offsets_at_sample(self, i: int) -> np.ndarray:
        frac = np.asarray(self.lane_fractions)
        return np.where(frac > 0, frac * self.lane_half_left[i], frac * self.lane_half_right[i])

    def sample_lane_offsets(self) -> np.ndarray:
        """(M, n_lanes) left-positive lateral offsets [m] of the lanes at every centre-line sample."""
        frac = np.asarray(self.lane_fractions)[None, :]
        left = np.asarray(self.lane_half_left)[:, None]
        right = np.asarray(self.lane_half_right)[:, None]
        return np.where(frac > 0, frac * left, frac * right)

    def lane_point(self, checkpoint: int, lane: int) -> np.ndarray:
        """World position [m] of ``lane`` (1-based) on the line of ``checkpoint`` (taken modulo a lap)."""
        if not 1 <= lane <= self.n_lanes:
            raise ValueError(f"lane must be in 1..{self.n_lanes}, got {lane}")
        return self._lane_point_table[checkpoint % self.n_checkpoints, lane - 1]

    def lane_points(self) -> np.ndarray:
        """(N, n_lanes, 2) world positions of every lane point."""
        return self._lane_point_table.copy()

    @cached_property
    def _lane_point_table(self) -> np.ndarray:
        # looked up at every step by every LQ tracker for each kart's next lane points: computed once (the same
        # arithmetic as per call, so the same numbers to the last bit)
        points = np.empty((self.n_checkpoints, self.n_lanes, 2))
        for c in range(self.n_checkpoints):
            centre, normal = self.checkpoint_frame(c)
            for k in range(self.n_lanes):
                points[c, k] = centre + normal * self.lane_offsets(c)[k]
        points.flags.writeable = False
        return points

    def checkpoint_frame(self, checkpoint: int) -> tuple[np.ndarray, np.ndarray]:
        """(centre, left normal) of the checkpoint line on the sampled centre line."""
        c = checkpoint % self.n_checkpoints
        point, tangent = self.point_at(float(self.checkpoint_s[c]))
        return point, np.array([-tangent[1], tangent[0]])

    def lane_id(self, checkpoint: int, lateral_offset: float) -> int:
        """Lane (1-based) whose point at ``checkpoint`` is nearest to ``lateral_offset`` [m]."""
        return int(np.argmin(np.abs(self.lane_offsets(checkpoint) - lateral_offset))) + 1

    def lane_of_position(self, xy: np.ndarray) -> int:
        """Lane (1-based) of a world position: nearest lane at that point of the track."""
        s, d = self.project(xy)
        i = int(np.searchsorted(self.centre_s, s, side="right") - 1)
        return int(np.argmin(np.abs(self._lane_offsets_at_sample(i) - d))) + 1

    # ----------------------------------------------------------------- centre line queries
    def gap(self, s_from: float, s_to: float) -> float:
        """[m] how far ``s_to`` lies ahead of ``s_from`` along the centre line (negative: behind), the nearer way
        round the lap: in [-length / 2, length / 2)."""
        return (s_to - s_from + 0.5 * self.length) % self.length - 0.5 * self.length

    def sample_at(self, s: float) -> int:
        """The index of the centre-line sample at or before arc length ``s`` [m] in the lap (clamped to the line's
        samples): the row of :meth:`sample_lane_offsets` the referee's lane membership reads there."""
        starts = self.segments[0]
        return min(max(bisect.bisect_right(starts, s) - 1, 0), len(starts) - 1)

    def point_at(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(position, unit tangent) on the centre line at arc length ``s`` [m] (wraps)."""
        s = s % self.length
        starts, ends, deltas, tangents = self.segments
        i = bisect.bisect_right(starts, s) - 1
        u = (s - starts[i]) / max(ends[i] - starts[i], 1e-12)
        return self.centre_xy[i] + u * deltas[i], tangents[i]

    @cached_property
    def segments(self) -> tuple[list[float], list[float], np.ndarray, np.ndarray]:
        """The centre line's segments as :meth:`point_at` reads them: starts and ends [m], vectors and unit
        tangents (read-only)."""
        # point_at runs at every step of every LQ tracker: each segment's start and end [m], its vector and its
        # unit tangent, computed once (as point_at computed them per call: the same numbers to the last bit)
        m = len(self.centre_s)
        starts = [float(v) for v in self.centre_s]
        ends = [*starts[1:], float(self.length)]
        deltas = np.stack([self.centre_xy[(i + 1) % m] - self.centre_xy[i] for i in range(m)])
        tangents = np.stack([d / np.linalg.norm(d) for d in deltas])
        deltas.flags.writeable = tangents.flags.writeable = False
        return starts, ends, deltas, tangents

    def project(self, xy: np.ndarray) -> tuple[float, float]:
        """Progress ``s`` [m] and lateral offset ``d`` [m, left-positive] of a world position (global search)."""
        p = np.asarray(xy, dtype=float)
        a = self.centre_xy
        b = np.roll(a, -1, axis=0)
        ab = b - a
        seg_len2 = np.einsum("ij,ij->i", ab, ab)
        u = np.clip(np.einsum("ij,ij->i", p - a, ab) / seg_len2, 0.0, 1.0)
        closest = a + u[:, None] * ab
        dist2 = np.einsum("ij,ij->i", p - closest, p - closest)
        i = int(np.argmin(dist2))
        seg_len = np.sqrt(seg_len2[i])
        tangent = ab[i] / seg_len
        rel = p - a[i]
        d = tangent[0] * rel[1] - tangent[1] * rel[0]
        return float((self.centre_s[i] + u[i] * seg_len) % self.length), float(d)

    def half_widths_at(self, s: float) -> tuple[float, float]:
        """(left, right) distance [m] from the centre line to the walls at arc length ``s``."""
        i = int(np.searchsorted(self.centre_s, s % self.length, side="right") - 1)
        return float(self.width_left[i]), float(self.width_right[i])

    def section_is_straight(self, section: int) -> bool:
        """Whether the road from checkpoint ``section`` to the next one is a straight (wraps)."""
        return self.sections[section % self.n_checkpoints].is_straight

    @property
    def straight_flags(self) -> np.ndarray:
        """(N,) bool, ``sections[i].is_straight``."""
        return np.array([sec.is_straight for sec in self.sections], dtype=np.bool_)

    @property
    def racing_lanes(self) -> tuple[int | None, ...]:
        """Hand-set lane per section (target lane at the following checkpoint), as in the original scenes."""
        return tuple(cp.racing_lane for cp in self.checkpoints)

    @property
    def nominal_width(self) -> float:
        """Track width [m] at checkpoint 0."""
        i = self.checkpoint_sample[0]
        return float(self.lane_half_left[i] + self.lane_half_right[i])

    # ----------------------------------------------------------------- transformations
    def reversed(self) -> Track:
        """The same circuit driven in the opposite direction.

        Checkpoint 0 stays where it is; the others come in reverse order. Lanes keep their meaning
        (lane 1 is on the left of the new driving direction), so the hand-set racing lanes are mirrored.
        """
        n = self.n_checkpoints
        order = [0, *list(range(n - 1, 0, -1))]
        # New section j runs from old checkpoint order[j] to order[j+1], i.e. old section order[j+1] backwards.
        new_sections = tuple(self.sections[order[(j + 1) % n]].reversed() for j in range(n))
        new_checkpoints = []
        for j, old in enumerate(order):
            cp = self.checkpoints[old]
            # Racing lane of new section j = target lane at new checkpoint j+1 = old checkpoint order[j+1],
            # which the old track stored on the section before it (old index order[j+1] - 1).
            target_old = self.checkpoints[(order[(j + 1) % n] - 1) % n].racing_lane
            mirrored = None if target_old is None else self.n_lanes + 1 - target_old
            new_checkpoints.append(Checkpoint(cp.centre, (cp.heading + np.pi) % (2 * np.pi), mirrored))
        xy = self.centre_xy[::-1]
        xy = np.roll(xy, 1, axis=0)  # keep sample 0 at the old sample 0
        # Same arc lengths as the forward track, measured the other way (new sample i is old sample -i), so
        # the length is preserved exactly and reversing twice gives back centre_s / checkpoint_s.
        length = self.length
        s = np.concatenate([[0.0], length - self.centre_s[:0:-1]])
        cps = np.array([(length - self.checkpoint_s[old]) % length for old in order])

        def flip(a: np.ndarray) -> np.ndarray:
            return np.roll(a[::-1], 1).copy()

        return Track(
            name=_reversed_name(self.name),
            checkpoints=tuple(new_checkpoints),
            sections=new_sections,
            centre_xy=xy.copy(),
            centre_s=s,
            length=length,
            width_left=flip(self.width_right),
            width_right=flip(self.width_left),
            checkpoint_s=cps,
            lane_half_left=flip(self.lane_half_right),
            lane_half_right=flip(self.lane_half_left),
            laps=self.laps,
            lane_change_limit=self.lane_change_limit,
            lane_fractions=tuple(-f for f in reversed(self.lane_fractions)),
            description=_reversed_description(self.description),
            meta=dict(self.meta),
        )

    def summary(self) -> dict[str, object]:
        """Short description for listings."""
        return {
            "name": self.name,
            "checkpoints": self.n_checkpoints,
            "lanes": self.n_lanes,
            "length_m": round(self.length, 1),
            "laps": self.laps,
            "lane_change_limit": self.lane_change_limit,
            "straights": int(self.straight_flags.sum()),
            "description": self.description,
        }


REVERSED_PREFIX = "Driven the other way round: "
_HANDS = {"left-hand": "right-hand", "right-hand": "left-hand"}


def _reversed_description(description: str) -> str:
    """The description of a track driven the other way: its corners turn the other way (a reversed track's
    reverse gets the original description back)."""
    if description.startswith(REVERSED_PREFIX):
        body = description[len(REVERSED_PREFIX) :]
    else:
        body = REVERSED_PREFIX + description
    return re.sub("|".join(_HANDS), lambda m: _HANDS[m.group(0)], body)


def _reversed_name(name: str) -> str:
    return name[: -len("-reversed")] if name.endswith("-reversed") else f"{name}-reversed"
