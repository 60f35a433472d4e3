"""A pure-pursuit lane follower: the simplest competent driver, used as a baseline and in tests.

It steers toward a point ``lookahead`` metres ahead on a chosen lateral offset (a lane) and sets its speed
from the tightest curvature it will meet within its braking distance. Vectorised over a whole batched
world, so it can drive thousands of races at once.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass

import numpy as np

from controllers.base import Action, RaceContext
from controllers.parameters import parameter
from sim_core import state as st
from sim_core.observation import Observation
from sim_core.params import SIM_HZ, KartParams
from sim_core.track import Track
from sim_core.world import World


@dataclass(frozen=True)
class LaneFollowerParams:
    """Tuning of :class:`LaneFollower` (the public parameters of ``lane-follower``; bounds keep it driving)."""

    lookahead_time: float = parameter(
        0.45, "lookahead distance = max(min_lookahead, speed * this)", unit="s", minimum=0.0, maximum=2.0
    )
    min_lookahead: float = parameter(3.0, "shortest lookahead distance", unit="m", minimum=0.5, maximum=20.0)
    acceleration_gain: float = parameter(
        6.0, "commanded acceleration per m/s of speed error", unit="1/s", minimum=0.0, maximum=50.0
    )
    grip_margin: float = parameter(0.9, "fraction of the lateral limit it plans to use", minimum=0.1, maximum=1.2)
    preview: float = parameter(40.0, "how far ahead it looks for corners", unit="m", minimum=1.0, maximum=200.0)


class LaneFollower:
    """Pure pursuit on a fixed lateral offset with a curvature-limited speed profile."""

    def __init__(self, track: Track, kart: KartParams, params: LaneFollowerParams | None = None) -> None:
        self.track = track
        self.kart = kart
        self.params = params or LaneFollowerParams()
        s = track.centre_s
        self._s_ext = np.concatenate([s - track.length, s, s + track.length])
        self._x_ext = np.tile(track.centre_xy[:, 0], 3)
        self._y_ext = np.tile(track.centre_xy[:, 1], 3)
        self._preview_offsets = np.linspace(0.0, self.params.preview, 41)
        # the curvature with one sample wrapped onto each end: ``np.interp(..., period=length)`` builds these
        # (and sorts the samples) on every call; built once, the interpolation is the same to the bit
        self._kappa_s = np.concatenate([s[-1:] - track.length, s, s[:1] + track.length])
        kappa = track.centre_curvature
        self._kappa = np.concatenate([kappa[-1:], kappa, kappa[:1]])
        self._kappa_abs = np.abs(self._kappa)

    def act(
        self,
        positions: np.ndarray,
        headings: np.ndarray,
        speeds: np.ndarray,
        progress: np.ndarray,
        wear: np.ndarray,
        lateral_target: np.ndarray | float,
        speed_cap: np.ndarray | float = np.inf,
    ) -> np.ndarray:
        """Actions (..., 2) = [steer, throttle] for karts at ``positions`` (..., 2) etc.

        ``lateral_target`` is the left-positive offset [m] to follow; ``speed_cap`` an optional top speed [m/s].
        """
        p = self.params
        track = self.track
        lookahead = np.maximum(p.min_lookahead, np.abs(speeds) * p.lookahead_time)
        s_ahead = progress + lookahead
        normal_x, normal_y, cx, cy = self._frame(s_ahead)
        tx = cx + normal_x * lateral_target
        ty = cy + normal_y * lateral_target
        dx = tx - positions[..., 0]
        dy = ty - positions[..., 1]
        alpha = np.arctan2(dy, dx) - headings
        alpha = (alpha + np.pi) % (2 * np.pi) - np.pi
        dist = np.maximum(np.hypot(dx, dy), 1e-3)
        delta = np.arctan2(2.0 * self.kart.wheelbase * np.sin(alpha), dist)
        steer = np.clip(delta / self.kart.max_steer_angle, -1.0, 1.0)
        # speed profile: v(s') limited by the corner at s' and the braking distance to it
        s_prev = (progress[..., None] + self._preview_offsets) % track.length % track.length
        kappa = np.interp(s_prev, self._kappa_s, self._kappa_abs)
        kappa_signed = np.interp(s_prev, self._kappa_s, self._kappa)
        # radius of the followed offset: R_offset = R_centre - d * sign(kappa)
        offset = np.asarray(lateral_target)[..., None] if np.ndim(lateral_target) else lateral_target
        radius = np.maximum(1.0 / np.maximum(kappa, 1e-6) - offset * np.sign(kappa_signed), 1.0)
        a_lat = np.asarray(self.kart.lateral_limit(wear))[..., None] * p.grip_margin
        v_corner = np.sqrt(a_lat * radius)
        v_allowed = np.sqrt(v_corner**2 + 2.0 * self.kart.braking * p.grip_margin * self._preview_offsets)
        target = np.minimum(np.min(v_allowed, axis=-1), np.minimum(self.kart.top_speed, speed_cap))
        # the commanded acceleration through the kart's own longitudinal model (drag included)
        throttle = self.kart.throttle_for_acceleration(speeds, p.acceleration_gain * (target - speeds))
        return np.stack([steer, throttle], axis=-1)

    def act_on(
        self, world: World, lateral_target: np.ndarray | float, speed_cap: np.ndarray | float = np.inf
    ) -> np.ndarray:
        """:meth:`act` for every kart of ``world``: actions (B, K, 2)."""
        return self.act(
            world.positions,
            world.headings,
            world.speeds,
            world.fstate[:, :, st.F_S],
            world.fstate[:, :, st.F_WEAR],
            lateral_target,
            speed_cap,
        )

    def _frame(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        track = self.track
        s = np.mod(s, track.length)
        eps = 0.5
        # the point and its neighbours either side in one interpolation per coordinate (elementwise: the same
        # numbers as one call each)
        around = np.stack([s, s + eps, s - eps])
        x = np.interp(around, self._s_ext, self._x_ext)
        y = np.interp(around, self._s_ext, self._y_ext)
        fx, fy = x[1] - x[2], y[1] - y[2]
        norm = np.hypot(fx, fy)
        return -fy / norm, fx / norm, x[0], y[0]


class LaneFollowerController:
    """The pure-pursuit baseline as a registered driver: it follows the lane it started in."""

    name = "lane-follower"
    rate_hz = float(SIM_HZ)

    def __init__(self, params: LaneFollowerParams | None = None) -> None:
        self.params = params or LaneFollowerParams()
        self._follower: LaneFollower | None = None
        self._lateral = 0.0

    def reset(self, context: RaceContext) -> None:
        """Pick the start lane's offset to follow."""
        self._follower = LaneFollower(context.track, context.kart, self.params)
        self._lateral = float("nan")

    def act(self, observation: Observation) -> Action:
        """Pure pursuit on its lane with a curvature-limited speed."""
        return self.act_batch([self], [observation])[0]

    def batch_key(self) -> Hashable:
        """Lane followers of one track (the same object), kart and parameters decide in one call
        (:class:`~controllers.race.BatchDriver`)."""
        assert self._follower is not None, "reset() first"
        return (id(self._follower.track), self._follower.kart, self.params)

    def act_batch(self, drivers: Sequence[LaneFollowerController], observations: Sequence[Observation]) -> list[Action]:
        """Every driver's pure pursuit in one vectorised :meth:`LaneFollower.act` (elementwise arithmetic: each
        kart's inputs are the ones it gets alone, to the bit)."""
        assert self._follower is not None, "reset() first"
        mine = [o.me for o in observations]
        for driver, me in zip(drivers, mine, strict=True):
            if driver._lateral != driver._lateral:  # the first decision: keep the lane it starts in
                driver._lateral = me.lateral
        inputs = self._follower.act(
            np.array([[me.x, me.y] for me in mine]),
            np.array([me.heading for me in mine]),
            np.array([me.speed for me in mine]),
            np.array([me.progress for me in mine]),
            np.array([me.wear for me in mine]),
            np.array([driver._lateral for driver in drivers]),
        )
        return [Action(float(steer), float(throttle)) for steer, throttle in inputs]
